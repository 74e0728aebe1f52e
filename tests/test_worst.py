"""The worst-case judge (`attenfit._judge.worst_case`): its search against brute force, cases
with a known answer, bands that start at contact, float64 whatever the caller's x64.

Reference values come from outside the code under test: the sphere's clipped cone written
here from docs/ground-truth.md §2 (and at n.l = 0 in closed form, evaluated with mpmath),
the facing curves' closed forms, and brute-force grids of receivers built here in physical
terms (positions and normals), judged with the report's own error measure.
"""

from __future__ import annotations

import math

import jax
import mpmath
import numpy as np
import pytest

from attenfit._curves import InverseSquare, YukselAdhoc, get_area_model
from attenfit._errors import BadTypeError, BadValueError
from attenfit._judge import WorstCase, receiver_error, typical_error, worst_case
from attenfit._judge._receivers import CONTACT, Z_MIN, pieces
from attenfit._report._metrics import receiver_errors
from attenfit._truth import DiskEmitter, SphereEmitter, irradiance

R = 0.1
SPHERE = SphereEmitter([0.0, 0.0, 0.0], R)
DISK = DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], R)  # faces -z, as the report's
SMALL = {"gap": (41,), "floor": (17, 17), "sphere": (9, 13), "disk": (7, 7, 9, 5)}


def grazing_error(sin_a: float) -> float:
    """A point light's error at n.l = 0 by a sphere of angular radius a, relative to the
    facing irradiance: K(0, sin a) / (pi sin^2 a) = (a - sin a cos a) / (pi sin^2 a)."""
    with mpmath.workdps(30):
        s = mpmath.mpf(sin_a)
        a = mpmath.asin(s)
        return float((a - s * mpmath.cos(a)) / (mpmath.pi * s * s))


def cone(c: np.ndarray, s: float) -> np.ndarray:
    """Snyder's clipped cone K(cos t, sin a) / (pi sin^2 a) (docs/ground-truth.md §2)."""
    ca = math.sqrt(1 - s * s)
    g = np.sqrt(np.clip(s * s - c * c, 0, None))
    k = s * s * c * np.arctan2(g, -ca * c) - g * ca + np.arctan2(g, ca)
    return np.where(c >= s, c, np.where(c <= -s, 0.0, k / (math.pi * s * s)))


def sphere_receivers(gap: np.ndarray, theta: np.ndarray):
    """Receivers gap (in r) from the sphere's surface on the +x axis, normals at angle theta
    from the direction to the centre (in the xz plane): world points and normals."""
    G, T = np.meshgrid(gap, theta, indexing="ij")
    p = np.stack([(1 + G) * R, 0 * G, 0 * G], -1)
    n = np.stack([-np.cos(T), 0 * T, np.sin(T)], -1)
    return p.reshape(-1, 3), n.reshape(-1, 3)


def disk_receivers(gap, psi_frac, theta, phi):
    """Receivers in front of DISK (it faces -z): a gap from its surface, on the stadium round
    it (psi_frac in [-1, 1]: < 0 over its face, rho = 1 + psi_frac; >= 0 round its rim, psi
    a fraction of the way to Z_MIN in front of its plane), normals at angle theta from the
    direction to its centre, azimuth phi about it."""
    G, U, T, P = np.meshgrid(gap, psi_frac, theta, phi, indexing="ij")
    psi_max = np.arccos(np.minimum(1.0, Z_MIN / G))
    psi = np.clip(U, 0, 1) * psi_max
    rho = np.where(U < 0, 1 + U, 1 + G * np.sin(psi))
    z = np.where(U < 0, G, G * np.cos(psi))
    p = np.stack([rho, 0 * rho, -z], -1)  # in front of a disk facing -z
    d = np.linalg.norm(p, axis=-1, keepdims=True)
    l = -p / d
    e2 = np.array([0.0, 1.0, 0.0])
    e1 = np.cross(e2, l)
    e1 /= np.linalg.norm(e1, axis=-1, keepdims=True)
    n = (
        np.cos(T)[..., None] * l
        + (np.sin(T) * np.cos(P))[..., None] * e1
        + (np.sin(T) * np.sin(P))[..., None] * e2
    )
    return (R * p).reshape(-1, 3), n.reshape(-1, 3)


# ----------------------------------------------------------------------------- known answers
@pytest.mark.parametrize("band, sin_a, d_over_r", [("near", 0.5, 2.0), ("far", 1 / 11, 11.0)])
def test_point_light_by_a_sphere_is_worst_at_grazing_where_the_truth_is_clipped(
    band, sin_a, d_over_r
):
    w = worst_case(InverseSquare(), SPHERE, band, grid=SMALL, typical_n=256)
    # wholly above the horizon inverse square is exact: the facing and floor receivers
    assert w.per_set["facing"] < 1e-14 and w.per_set["floor"] < 1e-14
    # so the worst is where the sphere straddles the horizon, nearest the light, at n.l = 0
    assert w.receivers == "any"
    assert w.d_over_r == pytest.approx(d_over_r, rel=1e-9)
    assert abs(w.n_dot_l) < 1e-6 and w.orientation() == "grazing"
    assert w.error == pytest.approx(grazing_error(sin_a), rel=1e-9)
    assert w.signed < 0  # the point light is black there, the truth is not
    # n.l = 0 is the largest over every normal at that distance: an independent fine scan
    c = np.cos(np.linspace(0, np.pi, 200_001))
    scan = np.abs(np.maximum(c, 0) - cone(c, sin_a))
    assert scan.max() == pytest.approx(grazing_error(sin_a), rel=1e-9)
    assert 0 < w.typical < w.error


def test_facing_curves_at_contact():
    """Bands start at contact: yuksel_adhoc (r' = r) on the sphere's facing receivers is
    1/(d^2 + r^2/2) against 1/d^2, worst at d = r: -1/3; inverse square on the disk's axis
    is 1/z^2 against 1/(z^2 + r^2): 1/z^2 (in r) at the contact gap."""
    w = worst_case(YukselAdhoc(r=R), SPHERE, "contact", receivers="facing", typical_n=0)
    assert w.gap_over_r == pytest.approx(CONTACT, abs=1e-15)
    assert w.signed == pytest.approx(-1 / 3, rel=1e-8)
    w = worst_case(InverseSquare(), DISK, "contact", receivers="facing", typical_n=0)
    assert w.z_over_r == pytest.approx(CONTACT, rel=1e-9)
    assert w.signed == pytest.approx(1 / CONTACT**2, rel=1e-6)


@pytest.mark.parametrize("light", ["sphere", "disk"])
@pytest.mark.parametrize("rset", ["facing", "floor", "any"])
def test_bands_start_at_contact(light, rset):
    import jax.numpy as jnp

    from attenfit._judge._receivers import geometry

    lowest = []
    for piece in pieces(light, rset, "contact"):
        x = np.zeros((1, piece.ndim))
        p, _ = geometry(light, rset, piece.coords(jnp.asarray(x)))
        p = np.asarray(p)[0]
        gap = np.linalg.norm(p) - 1 if light == "sphere" else np.hypot(p[2], max(p[0] - 1, 0))
        lowest.append(gap)
    assert min(lowest) == pytest.approx(CONTACT, abs=1e-15)


# ----------------------------------------------------------------------------- brute force
def test_search_matches_brute_force_on_a_sphere():
    """godot_wrap near a sphere: its worst receiver is inside the band, tilted past the
    horizon. The search from a 9 x 13 grid reaches the maximum of a 401 x 1201 grid of
    receivers built here, and no receiver on a finer grid round it does better."""
    model = get_area_model("godot_wrap")()
    w = worst_case(model, SPHERE, "contact", receivers="any", grid=SMALL, typical_n=0)
    gap = np.linspace(CONTACT, 1.0, 401)
    theta = np.linspace(0, np.pi, 1201)
    e = np.abs(receiver_error(model, SPHERE, *sphere_receivers(gap, theta)))
    brute = np.nanmax(e)
    # the brute grid's cells are r/400 by pi/1200: its maximum is below the supremum by
    # up to a curvature times the half-cell squared; the search converges to 1e-12 of the
    # box, so it must reach the brute maximum (to rounding)
    assert w.error >= brute - 1e-12
    assert w.error > w.grid_max  # the local search moved
    # never above the supremum: the reported receiver re-judged, and a fine grid round it
    again = receiver_error(model, SPHERE, w.position[None], w.normal[None])[0]
    assert again == pytest.approx(w.signed, rel=1e-12)
    g0, t0 = w.gap_over_r, math.acos(np.clip(w.n_dot_l, -1, 1))
    near = np.abs(
        receiver_error(
            model,
            SPHERE,
            *sphere_receivers(
                np.clip(g0 + np.linspace(-1e-3, 1e-3, 41), CONTACT, 1),
                t0 + np.linspace(-1e-3, 1e-3, 41),
            ),
        )
    )
    assert np.nanmax(near) <= w.error * (1 + 1e-12)


def test_search_matches_brute_force_on_a_disk():
    """vector_disk r to 10 r from a disk: its worst receiver lies against the disk's plane
    past the rim (the limit where the truth and the facing reference vanish together),
    grazing. A search from a 7 x 7 x 9 x 5 grid against 334,125 receivers built here."""
    model = get_area_model("vector_disk")()
    w = worst_case(model, DISK, "near", receivers="any", grid=SMALL, typical_n=0)
    gap = np.geomspace(1, 10, 15)
    frac = np.concatenate([np.linspace(-1, 0, 9)[:-1], np.linspace(0, 1, 17)])
    theta = np.linspace(0, np.pi, 81)
    phi = np.linspace(0, np.pi, 11)
    e = np.abs(receiver_error(model, DISK, *disk_receivers(gap, frac, theta, phi)))
    brute = np.nanmax(e)
    # the exact irradiance of a receiver whose horizon cuts the disk near its plane rounds
    # to about 1e-7 of the facing reference there (attenfit._judge._worst.REF_MIN)
    assert w.error >= brute - 1e-7
    assert w.receivers == "any" and w.gap_over_r == pytest.approx(1.0, rel=1e-6)
    again = receiver_error(model, DISK, w.position[None], w.normal[None])[0]
    assert again == pytest.approx(w.signed, abs=1e-7)
    # a fine grid round the found receiver (in these coordinates) does no better
    g0 = w.gap_over_r
    psi0 = math.atan2(w.rho_over_r - 1, w.z_over_r) / math.acos(min(1.0, Z_MIN / g0))
    t0 = math.acos(np.clip(w.n_dot_l, -1, 1))
    ny = abs(w.normal[1])  # the azimuth about l: sin(theta) sin(phi) = |n.y| (mirror image)
    p0 = math.asin(np.clip(ny / max(math.sin(t0), 1e-300), -1, 1))
    h = np.linspace(-1e-4, 1e-4, 9)
    near = np.abs(
        receiver_error(
            model,
            DISK,
            *disk_receivers(
                np.clip(g0 * (1 + h), 1, 10),
                np.clip(psi0 + h, 0, 1),
                t0 + h,
                np.clip(np.array([p0, np.pi - p0])[:, None] + h, 0, np.pi).ravel(),
            ),
        )
    )
    assert np.nanmax(near) <= w.error + 1e-7


# ----------------------------------------------------------------------------- the measure
def test_the_error_is_the_reports():
    """On random receivers of any orientation, the error is the report's (`_metrics.
    receiver_errors`): the point light's `I g f(d) max(0, n.l)` from `point_light`, against
    the truth, relative to the truth at a receiver there facing the light's centre."""
    rng = np.random.default_rng(3)
    for em in (SPHERE, DISK):
        dirs = rng.normal(size=(200, 3))
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        p = (R * (1.05 + 3 * rng.uniform(size=200)))[:, None] * dirs
        n = rng.normal(size=(200, 3))
        d, weight = (np.asarray(a) for a in em.point_light(p, n))
        E_true = np.asarray(irradiance(em, p, n))
        ref = np.asarray(irradiance(em, p, -p))
        E_model = weight / d**2
        report = receiver_errors(E_model, E_true, ref, d, d - R, R)["overall"]
        ours = receiver_error(InverseSquare(), em, p, n, receivers="any")
        assert np.nanmax(np.abs(ours)) == pytest.approx(report["max_abs"], rel=1e-12)
        lit = ref > 0
        want = (E_model[lit] - E_true[lit]) / ref[lit]
        np.testing.assert_allclose(ours[lit], want, rtol=1e-12, atol=1e-15)


def test_float64_whatever_the_callers_x64():
    with jax.enable_x64(False):
        sphere32 = SphereEmitter([0.0, 0.0, 0.0], R)
        w = worst_case(InverseSquare(), sphere32, "near", receivers="any", grid=SMALL,
                       typical_n=0)  # fmt: skip
        t = typical_error(InverseSquare(), sphere32, "near", receivers="any", n=64)
    assert isinstance(w, WorstCase) and isinstance(w.error, float)
    assert w.error == pytest.approx(grazing_error(0.5), rel=1e-12)  # float32: ~1e-7
    assert w.position.dtype == np.float64 and 0 < t < w.error


def test_bad_arguments_are_named():
    with pytest.raises(BadValueError, match="band"):
        worst_case(InverseSquare(), SPHERE, "middle")
    with pytest.raises(BadValueError, match="receivers"):
        worst_case(InverseSquare(), SPHERE, "near", receivers="random")
    with pytest.raises(BadTypeError, match="model"):
        worst_case(lambda d: 1 / d**2, SPHERE, "near")
    with pytest.raises(BadTypeError, match="emitter"):
        worst_case(InverseSquare(), "sphere", "near")
    # a window is judged only within half its range, as the report judges it
    from attenfit._curves import UnrealWindow

    with pytest.raises(BadValueError, match="range/2"):
        worst_case(UnrealWindow(r_max=10 * R), SPHERE, "near")
    with pytest.raises(BadValueError, match="two-sided"):
        worst_case(InverseSquare(), DiskEmitter([0, 0, 0], [0, 0, 1], R, two_sided=True), "near")
