"""The area-light models: each against a transcription of its engine's code (written here,
independently of attenfit), against attenfit's exact irradiance and Mitsuba, with finite
values and gradients at the extremes.

Transcriptions: Frostbite's `illuminanceSphereOrDisk` and its sphere and disk evaluations
(Lagarde & de Rousiers 2014, section 4.7.2.4, as the course notes print them); Unity HDRP
`AreaLighting.hlsl::DiffuseSphereLightIrradiance` (the fitted polynomial, and the Frostbite
branch) and its vector-form-factor usage; Godot 4 `scene_forward_lights_inc.glsl` (size_A,
`light_compute`'s N.L). Unreal's `SphereHorizonCosWrap` may only be described (Epic's
EULA): it is checked against its documented conditions (a Hermite spline with value 0 and
slope 0 at -sin a, value sin a and slope 1 at sin a).
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import attenfit as af
from attenfit import area

R = 0.3
#: the models of spheres, disks and the point light (rectangles and tubes: test_rect_models.py,
#: test_tube_models.py)
IDS = [n for n in area.list_area_models() if area.get_area_model(n).input_names == area.AREA_INPUTS]
ALL = [area.get_area_model(n)() for n in IDS]


# ----------------------------------------------------------------------------- transcriptions
def frostbite_illuminance(cos_theta: float, sin_sigma_sqr: float) -> float:
    """Frostbite 2014 section 4.7.2.4, illuminanceSphereOrDisk, line by line (float64)."""
    sin_theta = math.sqrt(1.0 - cos_theta * cos_theta)
    if cos_theta * cos_theta > sin_sigma_sqr:
        illuminance = math.pi * sin_sigma_sqr * min(max(cos_theta, 0.0), 1.0)
    else:
        x = math.sqrt(1.0 / sin_sigma_sqr - 1.0)
        y = -x * (cos_theta / sin_theta)
        sin_theta_sqrt_y = sin_theta * math.sqrt(1.0 - y * y)
        illuminance = (cos_theta * math.acos(y) - x * sin_theta_sqrt_y) * sin_sigma_sqr + math.atan(
            sin_theta_sqrt_y / x
        )
    return max(illuminance, 0.0)


def frostbite_sphere(d: float, cos_theta: float, r: float) -> float:
    """The sphere evaluation: clamps, then E = L illuminance, L = I/(pi r^2), I = 1."""
    cos_theta = min(max(cos_theta, -0.999), 0.999)
    sin_sigma_sqr = min(r * r / (d * d), 0.9999)
    return frostbite_illuminance(cos_theta, sin_sigma_sqr) / (math.pi * r * r)


def frostbite_disk(d: float, cos_theta: float, cos_plane: float, r: float) -> float:
    """The disk evaluation, times saturate(dot(planeNormal, -L))."""
    sqr = r * r
    sin_sigma_sqr = sqr / (sqr + max(sqr, d * d))
    e = frostbite_illuminance(cos_theta, sin_sigma_sqr) * min(max(cos_plane, 0.0), 1.0)
    return e / (math.pi * r * r)


def hdrp_polynomial(sin_sq_sigma: float, cos_omega: float) -> float:
    """DiffuseSphereLightIrradiance under APPROXIMATE_SPHERE_LIGHT_NUMERICALLY."""
    x, y = sin_sq_sigma, cos_omega
    v = x * (0.9245867471551246 + y) * (0.5 + (-0.9245867471551246 + y) * (
        0.5359050373687144 + x * (-1.0054221851257754 + x * (1.8199061187417047 - x * 1.3172081704209504))
    ))  # fmt: skip
    return min(max(v, 0.0), 1.0)


def hdrp_frostbite_branch(sin_sq_sigma: float, cos_omega: float) -> float:
    """DiffuseSphereLightIrradiance's #else branch ("Moving Frostbite ..., page 47, optimized")."""
    cos_sq_omega = cos_omega * cos_omega
    if cos_sq_omega > sin_sq_sigma:
        return min(max(sin_sq_sigma * cos_omega, 0.0), 1.0)
    cot_sq_sigma = 1 / sin_sq_sigma - 1
    tan_sq_sigma = 1 / cot_sq_sigma
    sin_sq_omega = 1 - cos_sq_omega
    w = sin_sq_omega * tan_sq_sigma
    x = -cos_omega / math.sqrt(w)
    y = math.sqrt(sin_sq_omega * tan_sq_sigma - cos_sq_omega)
    z = y * cot_sq_sigma
    a = cos_omega * math.acos(x) - z
    b = math.atan(y)
    return min(max((a * sin_sq_sigma + b) / math.pi, 0.0), 1.0)


def godot_lambert(d: float, cos_nl: float, size: float) -> float:
    """Godot 4: size_A from light_process_omni, NdotL and cNdotL from light_compute, over d^2."""
    t = size / max(0.001, d)
    size_a = max(0.0, 1.0 - 1 / math.sqrt(1 + t * t))
    ndotl = min(size_a + cos_nl, 1.0)
    return max(ndotl, 0.0) / (d * d)


def _grid():
    """(d, cos) pairs for a sphere of radius R: contact to far, every regime of the horizon."""
    out = []
    for d in (R * 1.0001, R * 1.1, R * 1.5, R * 3, R * 10, R * 100):
        s = R / d
        for c in (
            -0.99,
            -s * 0.999,
            -0.5 * s,
            -0.1 * s,
            0.0,
            0.3 * s,
            0.9 * s,
            s * 1.001,
            0.5,
            0.99,
        ):
            out.append((d, min(max(c, -1.0), 1.0)))
    return out


@pytest.mark.parametrize(("d", "c"), _grid())
def test_snyder_sphere_is_frostbites_illuminance(d, c):
    ours = float(area.SnyderSphere()(d, c, 1.0, R))
    theirs = frostbite_sphere(d, c, R)
    # Frostbite's clamps (|cos| <= 0.999, sin^2 <= 0.9999) and its acos near the regime
    # boundaries cost it digits there; elsewhere the two agree to rounding
    tol = 2e-2 if (abs(c) > 0.999 or (R / d) ** 2 > 0.9999) else 1e-6
    assert ours == pytest.approx(theirs, rel=tol, abs=1e-9 / d**2)
    hdrp = hdrp_frostbite_branch((R / d) ** 2, c) / (R * R)
    assert ours == pytest.approx(hdrp, rel=1e-6, abs=1e-9 / d**2)


@pytest.mark.parametrize(
    ("d", "c", "ce"),
    [(0.1, 1.0, 1.0), (0.5, 0.7, 0.9), (2.0, 0.1, 0.8), (1.0, -0.2, 0.95), (30.0, 0.0, 1.0)],
)
def test_frostbite_disk_is_its_code(d, c, ce):
    ours = float(area.FrostbiteDisk()(d, c, ce, R))
    assert ours == pytest.approx(frostbite_disk(d, c, ce, R), rel=1e-9, abs=1e-15)


def test_frostbite_disk_matches_the_oracle_table():
    """docs/ground-truth.md §3.7 (r = 1): exact coaxially for h >= r, -50% at h = 0.1 r facing."""
    m = area.FrostbiteDisk()
    for h, theta, value in [(0.1, 0, 0.5), (1, 120, 7.352055e-03), (10, 90, 2.096871e-04)]:
        assert float(m(h, math.cos(math.radians(theta)), 1.0, 1.0)) == pytest.approx(
            value, rel=1e-6
        )


@pytest.mark.parametrize(("d", "c"), _grid())
def test_hdrp_sphere_is_its_polynomial(d, c):
    x = (R / d) ** 2
    assert float(area.HdrpSphere()(d, c, 1.0, R)) == pytest.approx(
        hdrp_polynomial(x, c) / (R * R), rel=1e-12, abs=1e-15
    )


@pytest.mark.parametrize(("d", "c"), _grid())
def test_godot_wrap_is_its_code(d, c):
    assert float(area.GodotWrap()(d, c, 1.0, R)) == pytest.approx(godot_lambert(d, c, R), rel=1e-12)


def test_unreal_wrap_meets_its_documented_conditions():
    """Value 0 and slope 0 at -sin a; value sin a and slope 1 at sin a; N.L above; 0 below."""
    d = 2.5 * R
    s = R / d
    m = area.UnrealWrap()

    def w(c):
        return m(d, c, 1.0, R) * d * d

    dw = jax.grad(lambda c: w(c))
    assert float(w(-s)) == pytest.approx(0.0, abs=1e-15)
    assert float(dw(-s + 1e-9)) == pytest.approx(0.0, abs=1e-8)
    assert float(w(s)) == pytest.approx(s, rel=1e-12)
    assert float(dw(s - 1e-9)) == pytest.approx(1.0, rel=1e-8)
    assert float(w(0.8)) == pytest.approx(0.8, rel=1e-12)
    assert float(w(-0.9)) == 0.0


def test_mrp_sphere_is_solid_angle_times_the_nearest_cosine():
    """Omega L max(0, cos(max(theta - alpha, 0))), written with angles (numpy)."""
    for d, c in _grid():
        alpha = math.asin(R / d)
        theta = math.acos(c)
        omega = 2 * math.pi * (1 - math.cos(alpha))
        expect = omega / (math.pi * R * R) * max(0.0, math.cos(max(theta - alpha, 0.0)))
        assert float(area.MrpSphere()(d, c, 1.0, R)) == pytest.approx(expect, rel=1e-9, abs=1e-15)


def test_point_light_is_the_family_times_g_times_the_clamped_cosine():
    fam = af.Yuksel(r=0.2)
    m = area.PointLight(fam)
    d = np.array([0.1, 1.0, 3.0])
    c = np.array([0.5, -0.2, 1.0])
    ce = np.array([0.9, 0.5, -0.1])
    expect = np.maximum(ce, 0) * np.asarray(fam(d)) * np.maximum(c, 0)
    np.testing.assert_allclose(np.asarray(m(d, c, ce, R)), expect, rtol=1e-14)
    assert m.param_names() == ("r",) and m.replace(r=0.3).family.r == 0.3


# ----------------------------------------------------------------------------- exact truth
def _inputs(emitter, ds):
    return area.area_inputs(emitter, ds.points, ds.normals)


def test_snyder_sphere_is_exact_on_random_receivers():
    sphere = af.SphereEmitter([0.1, -0.2, 0.3], R)
    ds = af.random_receivers(sphere, 600, R * 1.001, 300 * R, seed=4)
    x = _inputs(sphere, ds)
    E = np.asarray(area.SnyderSphere()(*x))
    facing = 1 / np.asarray(x.d) ** 2
    np.testing.assert_allclose(E, ds.E, rtol=1e-10, atol=1e-14 * facing.max())
    assert np.all(np.abs(E - ds.E) <= 1e-12 * facing)


def test_vector_disk_is_exact_above_the_horizon():
    disk = af.DiskEmitter([0.0, 0.1, 0.4], [0.2, -0.3, -1.0], R)
    ds = af.random_receivers(disk, 256, 1e-3, 100 * R, seed=6)
    x = _inputs(disk, ds)
    d, c, cn = (np.asarray(v) for v in (x.d, x.cos_r, x.cos_n))
    above = d * c >= R * np.sqrt(1 - cn * cn)
    for clip in ("cap", "clamp"):
        E = np.asarray(area.VectorDisk(clip=clip)(*x))
        np.testing.assert_allclose(E[above], ds.E[above], rtol=1e-10, atol=0)
        assert np.all(E[ds.E == 0] == 0) or clip == "cap"


def test_vector_disk_is_howell_b14_for_a_parallel_receiver():
    """Offset, facing the disk: F = (1 - (Z - 2R^2)/sqrt(Z^2 - 4R^2))/2, H = z/s, R = r/s."""
    for s, z in [(0.5, 0.001), (0.5, 1.0), (2.0, 0.5), (100.0, 1.0)]:
        H, Rr = z / s, 1.0 / s
        Z = 1 + H * H + Rr * Rr
        F = 0.5 * (1 - (Z - 2 * Rr * Rr) / math.sqrt(Z * Z - 4 * Rr * Rr))
        d = math.hypot(s, z)
        got = float(area.VectorDisk()(d, z / d, z / d, 1.0, 1.0))
        assert got == pytest.approx(F, rel=1e-9)  # E/I = pi L F / I = F / r^2, r = 1


def test_vector_disk_cap_is_hdrps_sphere_of_the_form_factor():
    """Clipped: HDRP's DiffuseSphereLightIrradiance (Frostbite branch) of |F| and F.n/|F|."""
    disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 1.0)
    for p, n in [
        ([1.5, 0, -1.0], [0.3, 0, 1.0]),
        ([0.5, 0, -0.2], [-1.0, 0, 0.4]),
        ([3.0, 1.0, -0.5], [-0.2, 1.0, -0.3]),
    ]:
        x = area.area_inputs(disk, np.array([p]), np.array([n]))
        d, ce = float(x.d[0]), float(x.cos_e[0])
        z, s = d * ce, d * math.sqrt(1 - ce * ce)
        a = z * z + s * s + 1
        S = math.sqrt(a * a - 4 * s * s)
        Q = S + (z * z + 1 - s * s)
        f_par, f_perp = Q / (S * (S + a)), 2 * z * s / (S * (S + a))
        nn = np.asarray(n) / np.linalg.norm(n)
        e_par = np.array([0, 0, 1.0])  # -m
        e_perp = -np.array([p[0], p[1], 0.0]) / s  # toward the axis, in the disk's plane
        F = f_par * e_par + f_perp * e_perp
        f = float(np.linalg.norm(F))
        expect = hdrp_frostbite_branch(f, float(F @ nn / f))  # E/I = form factor / r^2
        assert float(area.VectorDisk()(*x)[0]) == pytest.approx(expect, rel=1e-6)


def test_area_inputs_give_the_point_light_weight():
    rng = np.random.default_rng(1)
    points = rng.normal(size=(64, 3)) * 2.0
    normals = rng.normal(size=(64, 3))
    for em in (
        af.SphereEmitter([0, 0, 1.0], R),
        af.DiskEmitter([0, 0, 1.0], [0, 0.3, -1], R, two_sided=True),
        af.CapsuleEmitter([-0.5, 0, 1], [0.5, 0, 1], R),
    ):
        x = area.area_inputs(em, points, normals)
        d, w = em.point_light(points, normals)
        np.testing.assert_allclose(np.asarray(x.d), np.asarray(d), rtol=1e-14)
        weight = np.asarray(x.g) * np.maximum(np.asarray(x.cos_r), 0)
        np.testing.assert_allclose(weight, np.asarray(w), rtol=1e-12, atol=1e-15)
        predicted = area.area_irradiance(area.PointLight(af.InverseSquare()), em, points, normals)
        np.testing.assert_allclose(
            np.asarray(predicted), np.asarray(w) / np.asarray(d) ** 2, rtol=1e-12
        )


# ----------------------------------------------------------------------------- stability
EXTREMES = [0.0, 1e-9 * R, 0.25 * R, R, R * (1 + 1e-12), 2 * R, 1e3 * R, 1e9 * R]
COSINES = [-1.0, -0.5, -1e-9, 0.0, 1e-9, 0.5, 1.0]


@pytest.mark.parametrize("model", ALL, ids=IDS)
@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_values_are_finite_and_nonnegative_at_the_extremes(model, dtype):
    d, c = np.meshgrid(np.asarray(EXTREMES), np.asarray(COSINES), indexing="ij")
    for ce in (1.0, 0.5, 1e-9):
        x = (
            jnp.asarray(d, dtype),
            jnp.asarray(c, dtype),
            jnp.full(d.shape, ce, dtype),
            jnp.full(d.shape, R, dtype),
        )
        E = model(*x)
        assert E.dtype == dtype
        ok = np.isfinite(np.asarray(E)) | (np.asarray(d) == 0) & (model.name == "point_light")
        assert np.all(ok), model.name
        assert np.all(np.asarray(E)[np.isfinite(np.asarray(E))] >= 0)


@pytest.mark.parametrize("model", ALL, ids=IDS)
def test_gradients_are_finite_on_the_regime_boundaries(model):
    """d/d(d), d/d(cos_r) and d/d(parameters) at contact, at +-sin a, grazing and far away."""
    pts = []
    for d in (R, 1.5 * R, 10 * R, 1e9 * R):
        s = R / d
        pts += [(d, c) for c in (-s, -0.5 * s, 0.0, s, 1.0, -1.0)]
    D, C = (jnp.asarray(v, jnp.float64) for v in zip(*pts, strict=True))

    def f(m, d_, c_):
        return m(d_, c_, 0.8, R)

    grads = jax.jit(jax.vmap(jax.grad(f, argnums=(0, 1, 2)), in_axes=(None, 0, 0)))(model, D, C)
    for g in jax.tree_util.tree_leaves(grads):
        if hasattr(g, "dtype") and jnp.issubdtype(g.dtype, jnp.floating):
            assert np.all(np.isfinite(np.asarray(g))), model.name


def test_float32_agrees_with_float64():
    d = np.geomspace(R * 1.01, 1e6 * R, 8)
    c = np.linspace(-1, 1, 7)
    D, Cc = np.meshgrid(d, c, indexing="ij")
    for model in ALL:
        e64 = np.asarray(model(D, Cc, np.ones_like(D), np.full_like(D, R)))
        e32 = np.asarray(
            model(
                *(jnp.asarray(v, jnp.float32) for v in (D, Cc, np.ones_like(D), np.full_like(D, R)))
            )
        )
        facing = 1 / D**2
        assert np.all(np.abs(e32 - e64) <= 1e-4 * facing), model.name


def test_jit_vmap_and_batching():
    m = area.SnyderSphere()
    d = jnp.linspace(0.4, 3.0, 8)
    c = jnp.linspace(-0.2, 1.0, 8)
    one = jnp.ones(8)
    direct = m(d, c, one, 0.3 * one)
    mapped = jax.vmap(lambda a, b: m(a, b, 1.0, 0.3))(d, c)
    np.testing.assert_allclose(np.asarray(direct), np.asarray(mapped), rtol=1e-14)
    stacked = area.AreaInputs(d, c, one, 0.3 * one, c, one).stack()
    np.testing.assert_allclose(np.asarray(m.evaluate(stacked)), np.asarray(direct), rtol=1e-14)


# ----------------------------------------------------------------------------- API
def test_registry_and_descriptions():
    assert IDS[0] == "point_light"
    assert {"snyder_sphere", "frostbite_disk", "vector_disk", "unreal_wrap", "godot_wrap",
            "hdrp_sphere", "mrp_sphere"} <= set(IDS)  # fmt: skip
    for m in ALL:
        desc = m.describe()
        assert desc["source"] and desc["formula"] and desc["light"] in ("sphere", "disk", "any")
    with pytest.raises(af.UnknownNameError, match="unknown area model"):
        area.get_area_model("nope")


def test_bad_parameters_are_refused():
    with pytest.raises(af.BadValueError, match="'k' must be > 0"):
        area.UnrealWrap(k=-1.0)
    with pytest.raises(af.BadValueError, match="clip must be one of"):
        area.VectorDisk(clip="zero")
    with pytest.raises(af.BadTypeError, match="Family instance"):
        area.PointLight("inverse_square")
    with pytest.raises(af.UnknownNameError, match="has no parameter"):
        area.GodotWrap().replace(size=2.0)


# ----------------------------------------------------------------------------- Mitsuba
def test_exact_models_agree_with_mitsuba_within_standard_errors():
    """Snyder's sphere and the vector disk (random receivers that see the whole disk, where it
    is exact) against Mitsuba renders of random receivers (scalar_rgb, 1024 spp): |z| <= 4 at every receiver (32 comparisons: a
    family-wise false alarm below 0.2%)."""
    pytest.importorskip("mitsuba")
    from data_gen.render import render_dataset

    sphere = af.SphereEmitter([0.1, -0.2, 0.3], 0.5)
    disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.5)
    pool = af.random_receivers(disk, 256, 0.02, 5.0, seed=12)
    x = _inputs(disk, pool)
    d, c, cn, ce = (np.asarray(v) for v in (x.d, x.cos_r, x.cos_n, x.cos_e))
    above = np.nonzero((ce > 0) & (d * c >= 0.5 * np.sqrt(1 - cn * cn)))[0][:16]
    disk_set = af.Dataset(disk, pool.points[above], pool.normals[above], pool.E[above], 0.0)
    cases = [
        (area.SnyderSphere(), af.random_receivers(sphere, 16, 0.55, 5.0, seed=11)),
        (area.VectorDisk(), disk_set),
    ]
    for model, exact in cases:
        mts = render_dataset(exact, spp=1024, seed=3, variant="scalar_rgb")
        E = np.asarray(area.area_irradiance(model, exact.emitter, exact.points, exact.normals))
        judged = mts.stderr > 0
        z = (E[judged] - mts.E[judged]) / mts.stderr[judged]
        assert judged.sum() >= 4 and np.abs(z).max() <= 4.0, (model.name, z)
