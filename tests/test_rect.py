"""The one-sided Lambertian rectangle's exact irradiance (`attenfit.RectEmitter`), against
independent computations: Howell's closed-form view factor of a parallel rectangle, and the
double integral over the rectangle clipped to the receiver's hemisphere, by graded
Gauss-Legendre panels and, at one receiver, by mpmath to 20 digits."""

from __future__ import annotations

import itertools
import math

import jax
import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
from _splits import graded_splits

from attenfit import BadValueError
from attenfit._truth import RectEmitter, emitter_from_dict, irradiance

W, H = 1.0, 0.5
LIGHT = RectEmitter([0.2, -0.1, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], W, H, 3.0)


def _howell_corner(a: float, b: float, c: float) -> float:
    """View factor from a differential area to a parallel a x b rectangle at distance c, the
    element under one corner (Howell's catalogue, configuration B-3)."""
    A, B = a / c, b / c
    sa, sb = math.sqrt(1 + A * A), math.sqrt(1 + B * B)
    return (A / sa * math.atan(B / sa) + B / sb * math.atan(A / sb)) / (2 * math.pi)


def _howell_parallel(x: float, y: float, z: float) -> float:
    """Irradiance / L under a W x H rectangle centred at 0, at (x, y) a distance z below it,
    facing it: four corner-aligned sub-rectangles, signed."""
    total = 0.0
    for dx, sx in ((W / 2 - x, 1), (W / 2 + x, 1)):
        for dy, sy in ((H / 2 - y, 1), (H / 2 + y, 1)):
            sign = math.copysign(1, dx) * math.copysign(1, dy) * sx * sy
            total += sign * _howell_corner(abs(dx), abs(dy), z)
    return math.pi * total


def _splits(lo, hi, at, z) -> list:
    return graded_splits(lo, hi, at, z, 10, 12)


def _mp_irradiance(e: RectEmitter, p, n, dps: int = 20) -> float:
    """E = L iint z n.(x - p) / |x - p|^4 dA over the rectangle where n.(x - p) >= 0."""
    mpmath.mp.dps = dps
    c, m = np.asarray(e.center, float), np.asarray(e.normal, float)
    u, v = np.asarray(e.tangent, float), np.cross(m, np.asarray(e.tangent, float))
    p, n = np.asarray(p, float), np.asarray(n, float) / np.linalg.norm(n)
    L = float(e.intensity) / (float(e.width) * float(e.height))
    hw, hh = float(e.width) / 2, float(e.height) / 2
    z = mpmath.mpf(float(np.dot(m, p - c)))
    if z <= 0:
        return 0.0
    s0, t0 = (mpmath.mpf(float(np.dot(p - c, a))) for a in (u, v))
    al, be, ga = (mpmath.mpf(float(x)) for x in (np.dot(n, c - p), np.dot(n, u), np.dot(n, v)))

    def t_range(s):
        lo, hi = mpmath.mpf(-hh), mpmath.mpf(hh)
        rest = al + be * s
        if ga > 0:
            lo = max(lo, -rest / ga)
        elif ga < 0:
            hi = min(hi, -rest / ga)
        elif rest < 0:
            return None
        return (lo, hi) if lo < hi else None

    def inner(s):
        rng = t_range(s)
        if rng is None:
            return mpmath.mpf(0)
        pts = _splits(rng[0], rng[1], t0, z)

        def f(t):
            r2 = (s - s0) ** 2 + (t - t0) ** 2 + z * z
            return z * (al + be * s + ga * t) / (r2 * r2)

        return mpmath.quad(f, pts)

    cuts = set(_splits(mpmath.mpf(-hw), mpmath.mpf(hw), s0, z))
    if be != 0:
        for t in (-hh, hh):
            s = -(al + ga * t) / be
            if -hw < s < hw:
                cuts.add(s)
    return float(L * mpmath.quad(inner, sorted(cuts)))


_GL_X, _GL_W = np.polynomial.legendre.leggauss(96)


def _gl(lo: float, hi: float, at: float, z: float) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and weights of 96-point Gauss-Legendre panels on [lo, hi], graded
    geometrically toward `at` (where the integrand peaks over a width z)."""
    cuts = [float(x) for x in _splits(lo, hi, at, z)]
    xs, ws = [], []
    for a, b in itertools.pairwise(cuts):
        xs.append((b - a) / 2 * _GL_X + (a + b) / 2)
        ws.append((b - a) / 2 * _GL_W)
    return np.concatenate(xs), np.concatenate(ws)


def _quad_irradiance(e: RectEmitter, p, n) -> float:
    """The same double integral as `_mp_irradiance` by graded Gauss-Legendre panels in
    float64 (the clip line bounds the inner integral exactly, so every panel is smooth)."""
    c, m = np.asarray(e.center, float), np.asarray(e.normal, float)
    u = np.asarray(e.tangent, float)
    v = np.cross(m, u)
    p, n = np.asarray(p, float), np.asarray(n, float) / np.linalg.norm(n)
    L = float(e.intensity) / (float(e.width) * float(e.height))
    hw, hh = float(e.width) / 2, float(e.height) / 2
    z = float(np.dot(m, p - c))
    if z <= 0:
        return 0.0
    s0, t0 = float(np.dot(p - c, u)), float(np.dot(p - c, v))
    al, be, ga = float(np.dot(n, c - p)), float(np.dot(n, u)), float(np.dot(n, v))
    cuts = [-hw, hw, *[-(al + ga * t) / be for t in (-hh, hh) if be != 0]]
    total = 0.0
    cuts = sorted(x for x in set(cuts) if -hw <= x <= hw)
    for a, b in itertools.pairwise(cuts):
        ss, ws = _gl(a, b, min(max(s0, a), b), z)
        for s, w in zip(ss, ws, strict=True):
            lo, hi, rest = -hh, hh, al + be * s
            if ga > 0:
                lo = max(lo, -rest / ga)
            elif ga < 0:
                hi = min(hi, -rest / ga)
            elif rest < 0:
                continue
            if lo >= hi:
                continue
            tt, wt = _gl(lo, hi, min(max(t0, lo), hi), z)
            r2 = (s - s0) ** 2 + (tt - t0) ** 2 + z * z
            total += w * np.sum(wt * z * (al + be * s + ga * tt) / (r2 * r2))
    return L * total


def _E(e, p, n, dtype=np.float64):
    return float(irradiance(e, np.asarray([p], dtype), np.asarray([n], dtype))[0])


def _scale(e, p) -> float:
    """`I / d^2`, the irradiance of a point light of the rectangle's intensity facing the
    receiver: the scale absolute errors are measured against. Where the irradiance is a tiny
    part of it (grazing receivers, a light seen edge-on), Lambert's sum of order-one edge
    terms and Howell's signed sum of four corner rectangles lose digits to it."""
    d = np.asarray(p, float) - np.asarray(e.center, float)
    return float(e.intensity) / float(d @ d)


# ----------------------------------------------------------------------------- closed forms
@pytest.mark.parametrize("z", [1e-9, 1e-3, 0.3, 1.0, 7.0, 1e3, 1e6])
@pytest.mark.parametrize("xy", [(0.0, 0.0), (0.3, 0.1), (0.45, -0.3)])
def test_parallel_facing_receivers_match_howell(z, xy):
    e = RectEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], W, H)
    want = _howell_parallel(*xy, z) / (W * H)
    p = [xy[0], xy[1], -z]
    got = _E(e, p, [0.0, 0.0, 1.0])
    assert got == pytest.approx(want, rel=1e-12, abs=1e-13 * _scale(e, p))


# ----------------------------------------------------------------------------- clipped
CASES = {
    # receiver below the light, its normal tilted so that its plane cuts the rectangle
    "clipped tilt": ([0.3, 0.0, 0.8], [0.9, 0.1, 0.4]),
    "clipped grazing": ([0.0, 0.05, 0.95], [0.05, 1.0, 0.02]),
    "beside, looking up": ([1.2, 0.3, 0.2], [-0.4, 0.2, 1.0]),
    "near contact, clipped": ([0.25, -0.05, 1.0 - 1e-7], [0.6, 0.0, 0.8]),
    "far, tilted": ([3e5, -2e5, -4e5], [-0.3, 0.2, 0.9]),
    "far, clipped": ([2e3, 0.0, 0.9995], [0.0, 1.0, 0.0]),
    "beside, facing up, grazing": ([1.7, -1.9, 1.0 - 1e-3], [0.0, 0.0, 1.0]),
    "beside, facing up, at contact": ([1.7, -1.9, 1.0 - 1e-9], [0.0, 0.0, 1.0]),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_clipped_and_tilted_receivers_match_graded_quadrature(case):
    p, n = CASES[case]
    want = _quad_irradiance(LIGHT, p, n)
    got = _E(LIGHT, p, n)
    assert want > 0
    assert got == pytest.approx(want, rel=1e-12, abs=1e-13 * _scale(LIGHT, p))


def test_a_clipped_receiver_matches_a_20_digit_integral():
    """The quadrature above, checked itself at one clipped receiver by mpmath."""
    p, n = CASES["clipped tilt"]
    want = _mp_irradiance(LIGHT, p, n)
    assert _quad_irradiance(LIGHT, p, n) == pytest.approx(want, rel=1e-13)
    assert _E(LIGHT, p, n) == pytest.approx(want, rel=1e-12)


def test_receivers_behind_the_light_or_facing_away_get_nothing():
    assert _E(LIGHT, [0.2, -0.1, 1.5], [0.0, 0.0, -1.0]) == 0.0  # behind the lit side
    assert _E(LIGHT, [0.2, -0.1, 1.0], [0.0, 0.0, 1.0]) == 0.0  # in its plane
    assert _E(LIGHT, [0.2, -0.1, 0.0], [0.0, 0.0, -1.0]) == 0.0  # facing away
    # the whole rectangle exactly on the receiver's horizon
    assert _E(LIGHT, [5.0, -0.1, 1.0 - 1e-3], [0.0, 0.0, -1.0]) == 0.0


def test_far_away_it_is_a_one_sided_disk_point_light():
    rng = np.random.default_rng(4)
    for _ in range(20):
        d = 10 ** rng.uniform(3, 12)
        direction = rng.normal(size=3)
        direction[2] = -abs(direction[2])
        p = np.asarray(LIGHT.center) + d * direction / np.linalg.norm(direction)
        n = -direction + 0.3 * rng.normal(size=3)
        dist, weight = LIGHT.point_light(p[None], n[None])
        want = float(weight[0]) / float(dist[0]) ** 2
        assert _E(LIGHT, p, n) == pytest.approx(want, rel=3 * (W / d) ** 2 + 1e-13)


# ----------------------------------------------------------------------------- precision
def test_float32_agrees_with_float64_from_contact_to_1e12_sizes():
    """Receivers (x, y, -z) under a light at the origin (float32 holds them exactly as they
    are given), z from 1e-6 to 1e12 sizes; float32 is judged on the float32 receivers."""
    light = RectEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], W, H, 3.0)
    rng = np.random.default_rng(7)
    z = 10 ** rng.uniform(-6, 12, 200)
    xy = rng.uniform(-0.4, 0.4, (200, 2)) * np.maximum(z, 1)[:, None]
    p = np.concatenate([xy, -z[:, None]], axis=1).astype(np.float32)
    n = np.stack([rng.normal(0, 0.3, 200), rng.normal(0, 0.3, 200), np.ones(200)], axis=1)
    n = n.astype(np.float32)
    E64 = np.asarray(irradiance(light, p.astype(np.float64), n.astype(np.float64)))
    E32 = np.asarray(irradiance(light, p, n))
    assert E32.dtype == np.float32 and np.all(np.isfinite(E32))
    scale = 3.0 / np.sum(p.astype(np.float64) ** 2, axis=1)
    assert np.all(np.abs(E32 - E64) <= 1e-5 * scale)


def test_gradients_are_finite_at_contact_grazing_and_far():
    def E(p, n):
        return irradiance(LIGHT, p[None], n[None])[0]

    for p, n in [*CASES.values(), ([0.2, -0.1, 1.0 - 1e-12], [0.0, 0.0, 1.0])]:
        gp, gn = jax.grad(E, argnums=(0, 1))(jnp.asarray(p, float), jnp.asarray(n, float))
        assert np.all(np.isfinite(gp)) and np.all(np.isfinite(gn))


# ----------------------------------------------------------------------------- the emitter
def test_the_rectangle_round_trips_and_refuses_bad_geometry():
    again = emitter_from_dict(LIGHT.to_dict())
    assert isinstance(again, RectEmitter) and again.to_dict() == LIGHT.to_dict()
    assert float(LIGHT.radiance) == pytest.approx(3.0 / (W * H), rel=1e-15)
    with pytest.raises(BadValueError, match="along the normal"):
        RectEmitter([0, 0, 0], [0, 0, 1], [0, 0, 2], 1.0, 1.0)
    with pytest.raises(BadValueError, match="width"):
        RectEmitter([0, 0, 0], [0, 0, 1], [1, 0, 0], -1.0, 1.0)
