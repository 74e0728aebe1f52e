"""The Lambertian tube's exact irradiance (`attenfit.TubeEmitter`) against an independent
computation: the radiometric double integral over the tube's surface,
`E = L iint max(0, cos theta_x) max(0, cos theta_p) / |x - p|^2 dA`, by Gauss-Legendre panels
graded toward the receiver, over the part of the side that faces the receiver (a convex
solid: a side point is seen exactly when its outward normal faces `p`) and the part of each
end disk above the receiver's plane, each cut exactly where the receiver's plane crosses it
(found by root bracketing, not by the formulas under test), so every panel is smooth; and,
at two receivers, by mpmath to 20 digits."""

from __future__ import annotations

import itertools
import math

import jax
import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
from _splits import graded_splits
from scipy.optimize import brentq

from attenfit import BadValueError
from attenfit._truth import TubeEmitter, emitter_from_dict, irradiance

A = np.array([0.1, -0.2, 0.3])
B = np.array([0.9, 0.4, 0.1])
R = 0.15
LIGHT = TubeEmitter(A, B, R, 2.0)
CAPPED = TubeEmitter(A, B, R, 2.0, caps=True)
_GX, _GW = np.polynomial.legendre.leggauss(48)


def _frame(e):
    h = np.array([0.0, 0.0, 1.0]) if abs(e[2]) < 0.5 else np.array([1.0, 0.0, 0.0])
    u = np.cross(h, e)
    u /= np.linalg.norm(u)
    return u, np.cross(e, u)


def _splits(lo, hi, at, w) -> list:
    return graded_splits(lo, hi, at, w, 4.0, 16)


def _gl(lo, hi, at, w):
    xs, ws = [], []
    for a, b in itertools.pairwise(_splits(lo, hi, at, w)):
        xs.append((b - a) / 2 * _GX + (a + b) / 2)
        ws.append((b - a) / 2 * _GW)
    return np.concatenate(xs), np.concatenate(ws)


def _roots(f, lo, hi, extra=()):
    """`lo`, `hi`, `extra` and every sign change of `f` on a fine grid, bracketed."""
    grid = np.linspace(lo, hi, 4001)
    fv = np.array([f(x) for x in grid])
    cuts = {lo, hi, *[x for x in extra if lo < x < hi]}
    for i in np.nonzero(np.sign(fv[:-1]) != np.sign(fv[1:]))[0]:
        cuts.add(brentq(f, grid[i], grid[i + 1], xtol=1e-16, rtol=1e-15))
    return sorted(cuts)


def _above(h0: float, k: float, top: float) -> tuple[float, float]:
    """The part of [0, top] where `h0 + k s >= 0` (empty: lo >= hi)."""
    if k > 0:
        return max(0.0, -h0 / k), top
    if k < 0:
        return 0.0, min(top, -h0 / k)
    return (0.0, top) if h0 >= 0 else (0.0, 0.0)


def _oracle(e_: TubeEmitter, p, n) -> float:
    a, b = np.asarray(e_.a, float), np.asarray(e_.b, float)
    r, L = float(e_.radius), float(e_.radiance)
    p, n = np.asarray(p, float), np.asarray(n, float) / np.linalg.norm(n)
    ax = b - a
    l = float(np.linalg.norm(ax))
    e = ax / l
    u, v = _frame(e)
    w = p - a
    zp = float(w @ e)
    rho = math.hypot(w @ u, w @ v)
    total = 0.0
    if rho > r:  # the side: phi in the front-facing range, z between exact horizon limits
        beta = math.acos(r / rho)
        rh = (w - zp * e) / rho
        th = np.cross(e, rh)
        nr, nt, nu = float(n @ rh), float(n @ th), float(n @ e)
        dist = rho - r

        def h(dphi, z):  # n.(x - p) at the angle dphi from the receiver's foot (no cancellation)
            return (
                -(dist + 2 * r * math.sin(dphi / 2) ** 2) * nr
                + r * math.sin(dphi) * nt
                + (z - zp) * nu
            )

        cuts = _roots(lambda f: h(f, 0.0), -beta, beta, (0.0,))
        cuts = sorted(set(cuts) | set(_roots(lambda f: h(f, l), -beta, beta)))
        for lo, hi in itertools.pairwise(cuts):
            ph, wph = _gl(lo, hi, min(max(0.0, lo), hi), dist / r + 1e-300)
            for f, wf in zip(ph, wph, strict=True):
                z1, z2 = _above(h(f, 0.0), nu, l)
                if z1 >= z2:
                    continue
                # nodes in z - z_p, so that they resolve a peak narrower than z_p's ulp
                dz, wz = _gl(z1 - zp, z2 - zp, min(max(0.0, z1 - zp), z2 - zp), dist + 1e-300)
                s2 = math.sin(f / 2) ** 2
                cos_x = dist - 2 * rho * s2  # |x - p| cos(theta_x)
                R2 = dist * dist + 4 * rho * r * s2 + dz**2
                cos_p = h(f, zp) + dz * nu  # |x - p| cos(theta_p)
                integ = max(cos_x, 0.0) * np.maximum(cos_p, 0) / R2**2
                total += wf * r * float(np.sum(wz * integ))
    if e_.caps:  # each end disk facing p, in polar coordinates, the radius cut per angle
        for c, m in ((a, -e), (b, e)):
            zeta = float((p - c) @ m)
            if zeta <= 0:
                continue
            s0 = math.atan2((p - c) @ v, (p - c) @ u)

            def hr(t, c=c):
                return float(n @ (c + r * (math.cos(t) * u + math.sin(t) * v) - p))

            h_c = float(n @ (c - p))
            for lo, hi in itertools.pairwise(_roots(hr, s0 - math.pi, s0 + math.pi, (s0,))):
                ts, wts = _gl(lo, hi, s0, 0.5 * math.sqrt(zeta / r) + 1e-300)
                for t, wt in zip(ts, wts, strict=True):
                    dirv = math.cos(t) * u + math.sin(t) * v
                    s1, s2 = _above(h_c, float(n @ dirv), r)  # h = h_c + s n.dirv along the ray
                    if s1 >= s2:
                        continue
                    sfoot = max(0.0, float((p - c) @ dirv))
                    ss, wss = _gl(s1, s2, min(max(sfoot, s1), s2), zeta)
                    d = c[None] + ss[:, None] * dirv[None] - p[None]
                    R2 = np.sum(d * d, axis=1)
                    integ = zeta * np.maximum(d @ n, 0) / R2**2
                    total += wt * float(np.sum(wss * ss * integ))
    return L * total


def _E(e, p, n, dtype=np.float64):
    return float(irradiance(e, np.asarray([p], dtype), np.asarray([n], dtype))[0])


def _scale(e, p) -> float:
    """`I g / d^2` with `g = 2 l / (pi r)`: the tube's broadside point light, the scale
    absolute errors are measured against where the irradiance is a sliver of it."""
    d = np.asarray(p, float) - np.asarray(e.center, float)
    g = 2 * float(e.length) / (math.pi * float(e.radius))
    return float(e.intensity) * g / float(d @ d)


def _at(t: float, rho: float, psi: float, e_: TubeEmitter = LIGHT) -> np.ndarray:
    """The point at axial fraction `t` (of the length), distance `rho` from the axis, at
    angle `psi` around it."""
    a, b = np.asarray(e_.a, float), np.asarray(e_.b, float)
    e = (b - a) / np.linalg.norm(b - a)
    u, v = _frame(e)
    return a + t * (b - a) + rho * (math.cos(psi) * u + math.sin(psi) * v)


def _toward(p, q, tilt=(0.0, 0.0, 0.0)) -> np.ndarray:
    d = np.asarray(q, float) - np.asarray(p, float)
    return d / np.linalg.norm(d) + np.asarray(tilt)


C = (A + B) / 2
CASES = {
    "facing, near": (_at(0.5, 2 * R, 0.3), _toward(_at(0.5, 2 * R, 0.3), C)),
    "clipped tilt": (_at(0.3, 1.5 * R, 1.0), _toward(_at(0.3, 1.5 * R, 1.0), C, (0.9, -0.3, 0.4))),
    "at contact, middle": (_at(0.5, R * (1 + 1e-9), 2.0), _toward(_at(0.5, 2 * R, 2.0), C)),
    "at contact, tilted": (
        _at(0.4, R * (1 + 1e-7), -1.0),
        _toward(_at(0.4, 2 * R, -1.0), C, (0.5, 0.5, -0.2)),
    ),
    "near a rim": (_at(-1e-4, R * (1 + 1e-4), 0.5), _toward(_at(-1e-4, 2 * R, 0.5), C)),
    "beyond an end, grazing the side": (_at(1.2, R * 1.01, 0.0), _toward(_at(1.2, R, 0.0), C)),
    "beyond an end, clipped": (
        _at(1.6, 3 * R, 0.0),
        _toward(_at(1.6, 3 * R, 0.0), C, (0.0, 0.9, 0.9)),
    ),
    "beside, facing up": (_at(0.7, 4 * R, 1.3) - [0.0, 0.0, 0.5], np.array([0.0, 0.0, 1.0])),
    "grazing": (_at(0.5, 3 * R, 0.0), np.cross(_toward(_at(0.5, 3 * R, 0.0), C), B - A) + 0.01),
    "far, clipped": (C + 1e3 * np.array([0.3, -0.8, 0.5]), np.array([0.5, 0.3, -0.3])),
    "far, tilted": (C + 1e6 * np.array([-0.6, 0.2, 0.7]), np.array([0.6, -0.2, -0.6])),
    "far, along the axis": (C + 2e3 * (B - A) + np.array([0.0, 0.0, 0.4]), A - B),
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("light", [LIGHT, CAPPED], ids=["open", "capped"])
def test_the_tube_matches_the_surface_integral(case, light):
    p, n = CASES[case]
    want = _oracle(light, p, n)
    got = _E(light, p, n)
    assert want > 0
    assert got == pytest.approx(want, rel=1e-9, abs=1e-13 * _scale(light, p))


def _mp_side(e_: TubeEmitter, p, n, dps: int = 20) -> float:
    """The side's integral by mpmath (receivers away from the surface: no grading needed)."""
    mpmath.mp.dps = dps
    a, b = np.asarray(e_.a, float), np.asarray(e_.b, float)
    r, L = mpmath.mpf(float(e_.radius)), float(e_.radiance)
    p, n = np.asarray(p, float), np.asarray(n, float) / np.linalg.norm(n)
    l = float(np.linalg.norm(b - a))
    e = (b - a) / l
    w = p - a
    zp = float(w @ e)
    rh = (w - zp * e) / np.linalg.norm(w - zp * e)
    th = np.cross(e, rh)
    rho = mpmath.mpf(float(np.linalg.norm(w - zp * e)))
    nr, nt, nu = (mpmath.mpf(float(n @ x)) for x in (rh, th, e))
    beta = mpmath.acos(r / rho)

    def f(ph, z):
        x = [r * mpmath.cos(ph) - rho, r * mpmath.sin(ph), z - zp]  # x - p in (rh, th, e)
        R2 = x[0] ** 2 + x[1] ** 2 + x[2] ** 2
        cos_p = x[0] * nr + x[1] * nt + x[2] * nu
        return max(rho * mpmath.cos(ph) - r, 0) * max(cos_p, 0) / R2**2

    def inner(ph):
        z1, z2 = mpmath.mpf(0), mpmath.mpf(l)
        h0 = (r * mpmath.cos(ph) - rho) * nr + r * mpmath.sin(ph) * nt - zp * nu
        if nu != 0:
            zc = -h0 / nu
            z1, z2 = (max(z1, zc), z2) if nu > 0 else (z1, min(z2, zc))
        if z1 >= z2:
            return mpmath.mpf(0)
        return mpmath.quad(lambda z: f(ph, z), [z1, z2])

    cuts = _roots(
        lambda x: float((r * mpmath.cos(x) - rho) * nr + r * mpmath.sin(x) * nt - zp * nu),
        float(-beta),
        float(beta),
    )
    cuts = sorted(
        set(cuts)
        | set(
            _roots(
                lambda x: float(
                    (r * mpmath.cos(x) - rho) * nr + r * mpmath.sin(x) * nt + (l - zp) * nu
                ),
                float(-beta),
                float(beta),
            )
        )
    )
    return float(L * r * mpmath.quad(inner, [mpmath.mpf(c) for c in cuts]))


@pytest.mark.parametrize("case", ["clipped tilt", "beyond an end, clipped"])
def test_the_quadrature_and_the_tube_match_a_20_digit_integral(case):
    p, n = CASES[case]
    want = _mp_side(LIGHT, p, n)
    assert _oracle(LIGHT, p, n) == pytest.approx(want, rel=1e-12)
    assert _E(LIGHT, p, n) == pytest.approx(want, rel=1e-11)


def test_the_near_and_far_branches_agree_where_they_meet():
    """Receivers just inside and outside `_FAR_RADII` half-diagonals: the contour form and
    the Gauss-Legendre rule, two different computations, agree to rounding."""
    from attenfit._truth import _tube

    rng = np.random.default_rng(3)
    half = math.hypot(float(LIGHT.length) / 2, R)
    dirs = rng.normal(size=(64, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    p = C + _tube._FAR_RADII * half * dirs
    n = -dirs + 0.6 * rng.normal(size=(64, 3))
    inside = np.asarray(irradiance(LIGHT, p * (1 - 1e-9) + C * 1e-9, n))
    outside = np.asarray(irradiance(LIGHT, p * (1 + 1e-9) - C * 1e-9, n))
    scale = np.asarray([_scale(LIGHT, q) for q in p])
    assert np.all(np.abs(inside - outside) <= 1e-12 * scale + 1e-8 * inside)
    assert np.count_nonzero(inside) > 40


def test_at_contact_facing_the_axis_it_is_the_infinite_cylinders_view_factor():
    """A receiver `eps r` from the side, mid-length, facing the axis: the view factor to an
    infinitely long cylinder, `r / rho` (Howell's catalogue, C-61 limit), to the end effects
    (rays within `eps r / (l/2)` of the tangent plane, ~1e-19 here)."""
    for eps in (1e-9, 1e-6):
        p = _at(0.5, R * (1 + eps), 2.0)
        n = _toward(_at(0.5, 2 * R, 2.0), C)
        want = math.pi * float(LIGHT.radiance) / (1 + eps)
        assert _E(LIGHT, p, n) == pytest.approx(want, rel=1e-12)


def test_receivers_inside_get_nan_and_those_that_cannot_see_it_get_nothing():
    assert math.isnan(_E(LIGHT, _at(0.5, 0.5 * R, 0.0), [0.0, 0.0, 1.0]))
    assert math.isnan(_E(CAPPED, _at(1.0, 0.0, 0.0), [0.0, 0.0, 1.0]))  # on an end disk
    beyond = _at(1.5, 0.5 * R, 0.0)  # within the radius, beyond an end: only a cap is seen
    assert _E(LIGHT, beyond, A - B) == 0.0
    assert _E(CAPPED, beyond, A - B) > 0
    assert _E(LIGHT, _at(0.5, 3 * R, 0.0), _at(0.5, 3 * R, 0.0) - C) < 1e-30  # facing away


def test_far_away_it_is_its_point_light():
    rng = np.random.default_rng(4)
    for light in (LIGHT, CAPPED):
        for _ in range(20):
            d = 10 ** rng.uniform(3, 12)
            direction = rng.normal(size=3)
            direction /= np.linalg.norm(direction)
            p = C + d * direction
            nrm = -direction + 0.3 * rng.normal(size=3)
            dist, weight = light.point_light(p[None], nrm[None])
            want = float(weight[0]) / float(dist[0]) ** 2
            assert _E(light, p, nrm) == pytest.approx(want, rel=10 * (1.1 / d) + 1e-12)


def test_float32_agrees_with_float64_from_contact_to_1e12_sizes():
    light = TubeEmitter([0.0, 0.0, -0.5], [0.0, 0.0, 0.5], 0.25, 3.0, caps=True)
    rng = np.random.default_rng(7)
    d = 10 ** rng.uniform(-4, 12, 300)
    t = rng.uniform(0, 2 * math.pi, 300)
    z = rng.uniform(-0.6, 0.6, 300) * np.maximum(d, 1)  # beside the side, some beyond an end
    p = np.stack([(0.25 + d) * np.cos(t), (0.25 + d) * np.sin(t), z], axis=1).astype(np.float32)
    n = -p / np.linalg.norm(p, axis=1, keepdims=True) + 0.4 * rng.normal(size=(300, 3))
    n = n.astype(np.float32)
    E64 = np.asarray(irradiance(light, p.astype(np.float64), n.astype(np.float64)))
    E32 = np.asarray(irradiance(light, p, n))
    assert E32.dtype == np.float32 and np.all(np.isfinite(E32))
    scale = 3.0 * (1 + 4 / (math.pi * 0.25)) / np.sum(p.astype(np.float64) ** 2, axis=1)
    scale = np.minimum(scale, 3.0 / 0.25**2)
    assert np.all(np.abs(E32 - E64) <= 1e-5 * scale)


def test_gradients_are_finite_at_contact_grazing_and_far():
    p = jnp.asarray(np.stack([c[0] for c in CASES.values()]), float)
    n = jnp.asarray(np.stack([c[1] for c in CASES.values()]), float)
    gp, gn = jax.grad(lambda p, n: jnp.sum(irradiance(CAPPED, p, n)), argnums=(0, 1))(p, n)
    assert np.all(np.isfinite(gp)) and np.all(np.isfinite(gn))


def test_the_tube_round_trips_and_refuses_bad_geometry():
    for light in (LIGHT, CAPPED):
        again = emitter_from_dict(light.to_dict())
        assert isinstance(again, TubeEmitter) and again.to_dict() == light.to_dict()
    assert float(LIGHT.radiance) == pytest.approx(2.0 / (math.pi * R * R), rel=1e-15)
    with pytest.raises(BadValueError, match="needs a length"):
        TubeEmitter([0, 0, 1], [0, 0, 1], 0.1)
    with pytest.raises(BadValueError, match="radius"):
        TubeEmitter([0, 0, 0], [0, 0, 1], -0.1)


# ----------------------------------------------------------------------------- datasets
def test_the_datasets_take_the_tube():
    """The facing sweep beside its middle, a floor it touches, random receivers: every
    receiver outside the solid cylinder, every value finite, and float32 near float64."""
    import attenfit as af

    tube = af.TubeEmitter([-0.6, 0.0, 0.0], [0.6, 0.0, 0.0], 0.013, 2.0)
    sweep = af.facing_sweep(tube, 0.02, 10.0, 32, dtype="float64")
    want = [_oracle(tube, p, n) for p, n in zip(sweep.points[::8], sweep.normals[::8], strict=True)]
    np.testing.assert_allclose(sweep.E[::8], want, rtol=1e-9)
    floor = af.plane_receivers(tube, 0.013, 2.0, 24, dtype="float64")
    assert np.all(np.isfinite(floor.E)) and floor.E.max() > 0
    rand = af.random_receivers(tube, 64, 0.02, 5.0, seed=1, dtype="float32")
    assert rand.E.dtype == np.float32 and np.all(np.isfinite(rand.E))
    E64 = np.asarray(
        irradiance(tube, rand.points.astype(np.float64), rand.normals.astype(np.float64))
    )
    dist, _ = tube.point_light(rand.points.astype(np.float64), rand.normals.astype(np.float64))
    scale = float(tube.intensity) * 2 * 1.2 / (math.pi * 0.013) / np.asarray(dist) ** 2
    assert np.all(np.abs(rand.E - E64) <= 1e-5 * np.minimum(scale, 2.0 / 0.013**2))


def test_a_tube_wholly_below_the_horizon_gives_exactly_nothing():
    """Random receivers (half of their normals near the horizon): wherever every point of the
    tube lies below the receiver's plane (a dense sample of its surface), E is exactly 0, not
    rounding (Mitsuba's witness can then only agree)."""
    import attenfit as af

    tube = af.TubeEmitter([-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], 0.1)
    ds = af.random_receivers(tube, 256, 0.1001, 100.0, seed=11, dtype="float64")
    phi, z = np.meshgrid(np.linspace(0, 2 * np.pi, 361), np.linspace(-0.5, 0.5, 101))
    surf = np.stack([z, 0.1 * np.cos(phi), 0.1 * np.sin(phi)], -1).reshape(-1, 3)
    h = np.einsum("sk,nk->ns", surf, ds.normals) - np.sum(ds.points * ds.normals, axis=1)[:, None]
    below = h.max(axis=1) < -1e-3
    assert below.sum() > 20
    assert np.all(ds.E[below] == 0.0)
