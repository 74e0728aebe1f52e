"""The exact clipped disk (`clipped_disk`, attenfit/_curves/_clipped_disk.py) against
references it does not share code with:

* brute-force quadrature over the disk's area with mpmath (polar coordinates, the horizon's
  crossings of each circle as breakpoints): `E / I = (1/(pi r^2)) int max(0, n.(x - p))
  m.(p - x) / |x - p|^4 dA`, the definition of the irradiance (docs/ground-truth.md §1);
* the on-axis closed form `E / I = 1/(z^2 + r^2)` (Howell's catalogue B-12) and the
  parallel-plane form of Howell B-14;
* the truth module's disk (`attenfit.irradiance`: the vector form above the horizon and the
  Stokes contour in its own frame, with Gauss-Legendre arcs) on random receivers;
* its shader form (`evaluate_area_form`) against the model, and its worst case per band.
"""

from __future__ import annotations

import math

import jax.numpy as jnp
import mpmath
import numpy as np
import pytest

import attenfit as af
from attenfit import area
from attenfit._curves import AREA_FORM_INPUTS
from attenfit._judge import worst_case
from attenfit._shaders import area_compiled_cost, area_function_source, evaluate_area_form

R = 0.3
DISK = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], R)  # faces -z
MODEL = area.get_area_model("clipped_disk")()


def brute_force(p, n, dps: int = 20) -> float:
    """E / I of DISK at point p with unit normal n, by mpmath quadrature over its area."""
    with mpmath.workdps(dps):
        P = [mpmath.mpf(float(v)) for v in p]
        N = [mpmath.mpf(float(v)) for v in n]
        r = mpmath.mpf(R)

        def integrand(rr, ph):
            a = [rr * mpmath.cos(ph) - P[0], rr * mpmath.sin(ph) - P[1], -P[2]]
            a2 = a[0] ** 2 + a[1] ** 2 + a[2] ** 2
            up = N[0] * a[0] + N[1] * a[1] + N[2] * a[2]
            return max(up, 0) * a[2] / a2**2 * rr  # m.(p - x) = -p_z = a_z (m = -z)

        def ring(rr):
            A, B = N[0] * rr, N[1] * rr
            C = N[0] * P[0] + N[1] * P[1] + N[2] * P[2]
            cuts = [-mpmath.pi, mpmath.pi]
            rho = mpmath.sqrt(A * A + B * B)
            if rho > abs(C):
                base, half = mpmath.atan2(B, A), mpmath.acos(C / rho)
                ends = (base + half, base - half)
                cuts += [(t + mpmath.pi) % (2 * mpmath.pi) - mpmath.pi for t in ends]
            return mpmath.quad(lambda ph: integrand(rr, ph), sorted(cuts))

        return float(mpmath.quad(ring, [0, r]) / (mpmath.pi * r * r))


def _unit(v):
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


#: receivers in front of the disk (z < 0): cut by the horizon, grazing, near the rim, far
CASES = [
    ([0.1, 0.0, -0.2], _unit([1.0, 0.2, 0.3])),
    ([0.5, 0.1, -0.05], _unit([-0.3, 0.1, 0.1])),
    ([0.0, 0.0, -0.6], _unit([1.0, 0.0, 0.0])),
    ([0.31, 0.0, -0.01], _unit([0.2, -0.5, -0.4])),
    ([3.0, 1.0, -2.0], _unit([0.5, 0.0, 1.0])),
    ([0.2, 0.2, -0.9], _unit([0.0, 0.0, 1.0])),  # facing the disk: wholly above the horizon
]


@pytest.mark.parametrize("case", range(len(CASES)))
def test_agrees_with_brute_force_quadrature(case):
    p, n = CASES[case]
    want = brute_force(p, n)
    x = area.area_inputs(DISK, np.asarray([p]), np.asarray([n]))
    got = float(np.asarray(MODEL(*x))[0])
    facing = 1 / (float(np.asarray(x.d)[0]) ** 2 + R * R)
    assert abs(got - want) <= 1e-6 * facing, (got, want)  # the quadrature's own accuracy


def test_on_the_axis_and_under_a_parallel_plane_it_is_howells():
    z = np.geomspace(1e-3, 1e3, 13) * R
    x = area.area_inputs(DISK, np.stack([0 * z, 0 * z, -z], -1), np.asarray([0.0, 0.0, 1.0]))
    got = np.asarray(MODEL(*x))
    np.testing.assert_allclose(got, 1 / (z * z + R * R), rtol=1e-12)  # Howell B-12
    # Howell B-14, a receiver parallel to the disk at height h and offset s: the form factor
    # F = (1 - (h^2 + s^2 - r^2) / S) / 2, S = sqrt((h^2 + s^2 + r^2)^2 - 4 s^2 r^2), and
    # E = pi L F with L = I / (pi r^2)
    h, s = 0.2, np.linspace(0, 3, 11)
    S = np.sqrt((h * h + s * s + R * R) ** 2 - 4 * s * s * R * R)
    want = (1 - (h * h + s * s - R * R) / S) / (2 * R * R)
    x = area.area_inputs(DISK, np.stack([s, 0 * s, -h + 0 * s], -1), np.asarray([0.0, 0.0, 1.0]))
    np.testing.assert_allclose(np.asarray(MODEL(*x)), want, rtol=1e-10)


@pytest.mark.parametrize("d_range", [(1e-3, 1.0), (1.0, 10.0), (10.0, 1000.0)])
def test_agrees_with_the_truth_module_on_random_receivers(d_range):
    ds = af.random_receivers(DISK, 4000, d_range[0] * R, d_range[1] * R, seed=11)
    x = area.area_inputs(DISK, ds.points, ds.normals)
    truth = np.asarray(af.irradiance(DISK, ds.points, ds.normals))
    facing = 1 / (np.asarray(x.d) ** 2 + R * R)
    assert np.max(np.abs(np.asarray(MODEL(*x)) - truth) / facing) < 1e-9
    e32 = np.asarray(MODEL(*(jnp.asarray(v, jnp.float32) for v in x)), np.float64)
    assert np.max(np.abs(e32 - truth) / facing) < 2e-4  # float32: eps d / r where clipped


def test_zero_behind_and_below_the_horizon():
    p = np.asarray([[0.1, 0.0, 0.5], [0.1, 0.0, -0.5]])  # behind; in front, facing away
    n = np.asarray([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    x = area.area_inputs(DISK, p, n)
    assert np.all(np.asarray(MODEL(*x)) == 0)


def test_the_shader_form_is_the_model():
    ds = af.random_receivers(DISK, 3000, 1e-3 * R, 300 * R, seed=5)
    x = area.area_inputs(DISK, ds.points, ds.normals)
    given = {k: np.asarray(getattr(x, k)) for k in AREA_FORM_INPUTS} | {"r": R}
    want = np.asarray(MODEL(*x))
    facing = 1 / (np.asarray(x.d) ** 2 + R * R)
    # float64 but for literals and the radius rounded to float32 (what a shader bakes in)
    f64 = evaluate_area_form(MODEL, given, np.float64)
    assert np.max(np.abs(f64 - want) / facing) < 2e-6
    f32 = evaluate_area_form(MODEL, given, np.float32).astype(np.float64)
    assert np.all(np.isfinite(f32))
    assert np.max(np.abs(f32 - want) / facing) < 1e-4
    for lang in ("glsl", "hlsl", "wgsl", "c"):
        assert "float clipped_disk" in area_function_source(MODEL, lang, "clipped_disk", R) or (
            "fn clipped_disk" in area_function_source(MODEL, lang, "clipped_disk", R)
        )


def test_it_meets_every_tolerance_in_every_band_at_its_worst_case():
    """The judge's worst case, with a coarse grid (the report's grid is finer): far below 1%.
    Where it lies: receivers 1e-10 r in front of the disk's plane, where E is of order
    1e-13 L and the truth's and the model's contours both lose digits to cancellation."""
    small = {"gap": (41,), "floor": (17, 17), "sphere": (9, 13), "disk": (7, 7, 9, 5)}
    for band in ("contact", "near", "far"):
        w = worst_case(MODEL, af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.1), band,
                       grid=small, seeds=4, typical_n=0)  # fmt: skip
        assert w.error < 1e-3, (band, w.error, w.where())


def test_its_cost_is_measured_and_larger_than_the_vector_disks():
    cost = area_compiled_cost(MODEL).cost
    assert math.isfinite(cost)
    assert cost > area_compiled_cost(area.get_area_model("vector_disk")()).cost
