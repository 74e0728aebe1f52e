"""Families: independent references per family, properties, scaling, shapes, awkward inputs,
the registry and the `families` CLI verb."""

from __future__ import annotations

import json
import math

import jax
import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
from _families_common import CASE_IDS, CASES, scalar_fn, scaled_params
from hypothesis import given
from hypothesis import strategies as st
from scipy.interpolate import PchipInterpolator

import attenfit
from attenfit import parts
from attenfit.cli import main

NAMES = attenfit.list_families()
D = np.concatenate([[0.0, 1e-4, 0.01, 0.05, 0.1], np.geomspace(0.13, 30.0, 37)])


def f64(fam, d):
    return np.asarray(fam(jnp.asarray(d, dtype=jnp.float64)))


def sat(x):
    return np.clip(x, 0.0, 1.0)


# ----------------------------------------------------------------------------- the table
def test_registry_has_exactly_the_design_table():
    table = {
        "inverse_square": (),
        "unreal_epsilon": ("eps",),
        "clamped": ("r_min",),
        "yuksel": ("r",),
        "yuksel_adhoc": ("r",),
        "disk_facing": ("r",),
        "polynomial": ("kc", "kl", "kq"),
        "madams_sphere": ("r",),
        "madams_cutoff": ("r", "cutoff"),
        "madams_tan": ("r", "d_max"),
        "madams_rational": ("r", "d_max"),
        "unreal_window": ("eps", "r_max"),
        "frostbite_window": ("r_min", "r_max"),
        "godot": ("a", "r_max"),
        "cryengine_linear": ("r_min", "r_max"),
        "just_cause_2": ("scale", "r_max"),
        "unreal_exponent": ("scale", "r_max", "p"),
        "threejs": ("decay", "cutoff"),
        "gltf_range": ("range",),
        "spline": ("knot_values",),
    }
    for name, params in table.items():
        assert attenfit.get_family(name).param_names() == params
    assert set(table) <= set(NAMES)


@pytest.mark.parametrize("name", NAMES)
def test_declarations_are_consistent(name):
    cls = attenfit.get_family(name)
    fam = cls()
    assert cls.name == name and cls.formula and cls.source and cls.__doc__
    assert set(cls.default_free) <= set(cls.param_names())
    assert set(cls.length_params) <= set(cls.param_names())
    assert set(cls.units) <= set(cls.param_names())
    assert cls.window in ("smooth", "hard", "none")
    if cls.range_param is not None:
        assert cls.range_param in cls.param_names() and cls.window != "none"
    assert (fam.range_distance() is None) == (cls.window == "none")
    assert not (cls.singular and not np.isinf(f64(fam, 0.0)))
    json.dumps(cls.describe())


def test_defaults_documented():
    assert attenfit.Yuksel().r == 0.1
    assert attenfit.UnrealEpsilon().eps == 1e-4
    assert attenfit.FrostbiteWindow().r_min == 0.01 and attenfit.FrostbiteWindow().r_max == 10
    assert attenfit.CryEngineLinear().r_min == 0.05 and attenfit.CryEngineLinear().squared
    assert attenfit.Godot().a == 1
    assert attenfit.ThreeJS().decay == 2 and attenfit.ThreeJS().cutoff == 10
    assert attenfit.MadamsCutoff.constraint("cutoff") == "unit"
    assert all(attenfit.Polynomial.constraint(p) == "nonnegative" for p in ("kc", "kl", "kq"))


# ----------------------------------------------------------------------------- references
def test_inverse_square_reference():
    np.testing.assert_allclose(f64(attenfit.InverseSquare(), D[1:]), 1 / D[1:] ** 2, rtol=1e-15)


def test_unreal_epsilon_in_unreal_units():
    # CapsuleLightIntegrate.ush: 1/(d_cm^2 + 1) in 1/cm^2, converted to 1/m^2.
    d_cm = 100 * D
    ref = 1e4 / (d_cm**2 + 1)
    np.testing.assert_allclose(f64(attenfit.UnrealEpsilon(), D), ref, rtol=1e-14)


def test_clamped_reference():
    ref = 1 / np.maximum(D, 0.3) ** 2
    np.testing.assert_allclose(f64(attenfit.Clamped(r_min=0.3), D), ref, rtol=1e-15)


def test_yuksel_against_mpmath_eq7_and_groundtruth_table():
    mpmath.mp.dps = 50
    r = 0.37
    d = np.concatenate([D, r * np.geomspace(10, 1e8, 15)])
    ref = [
        float(2 / mpmath.mpf(r) ** 2 * (1 - x / mpmath.sqrt(x * x + mpmath.mpf(r) ** 2)))
        for x in map(mpmath.mpf, d)
    ]
    np.testing.assert_allclose(f64(attenfit.Yuksel(r=r), d), ref, rtol=2e-15)
    # shared/reference/groundtruth.md §4, r = 1: Yuksel f(d).
    table = {
        0: 2.0,
        0.001: 1.998000001,
        0.1: 1.80099256196,
        0.5: 1.105572809,
        1: 0.585786437627,
        2: 0.211145618,
        5: 0.0388386486182,
        10: 0.00992561958002,
        100: 9.99925006249e-5,
        1000: 9.99999250001e-7,
    }
    got = f64(attenfit.Yuksel(r=1.0), list(table))
    np.testing.assert_allclose(got, list(table.values()), rtol=1e-9)


def test_yuksel_float32_beats_the_naive_form():
    """The naive eq. 7 in float32 is ~5% off at d = 1e3 r and exactly 0 beyond 1e4 r."""
    r = np.float32(1.0)
    d = np.asarray([1e3, 3e4, 1e6], dtype=np.float32)
    naive = 2 / r**2 * (1 - d / np.sqrt(d * d + r * r))
    exact = np.asarray(
        [
            float(2 / (x * x + 1 + x * mpmath.sqrt(x * x + 1)))
            for x in map(mpmath.mpf, d.astype(float))
        ]
    )
    assert abs(naive[0] / exact[0] - 1) > 0.04 and naive[1] == 0 and naive[2] == 0
    ours = np.asarray(attenfit.Yuksel(r=1.0)(jnp.asarray(d)))
    assert ours.dtype == np.float32
    np.testing.assert_allclose(ours, exact, rtol=1e-6)


def test_yuksel_adhoc_and_disk_against_groundtruth_table():
    d = [0, 0.001, 0.1, 0.5, 1, 2, 5, 10, 100, 1000]
    adhoc = [
        2.0,
        1.99999600001,
        1.96078431373,
        1.33333333333,
        0.666666666667,
        0.222222222222,
        0.0392156862745,
        0.00995024875622,
        9.999500025e-5,
        9.999995e-7,
    ]
    disk = [
        1.0,
        0.999999000001,
        0.990099009901,
        0.8,
        0.5,
        0.2,
        0.0384615384615,
        0.00990099009901,
        9.99900009999e-5,
        9.99999000001e-7,
    ]
    np.testing.assert_allclose(f64(attenfit.YukselAdhoc(r=1.0), d), adhoc, rtol=1e-10)
    np.testing.assert_allclose(f64(attenfit.DiskFacing(r=1.0), d), disk, rtol=1e-10)


def test_disk_facing_against_quadrature():
    from scipy.integrate import quad

    r, h = 0.3, 0.45
    L = 1 / (math.pi * r * r)  # unit intensity (Yuksel's normalisation)
    # E = int_0^r L cos(theta) cos(theta') / dist^2 dA, both cosines h/dist on the axis.
    E, _ = quad(lambda rho: L * h * h / (h * h + rho * rho) ** 2 * 2 * math.pi * rho, 0, r)
    assert f64(attenfit.DiskFacing(r=r), h) == pytest.approx(E, rel=1e-12)


@given(st.floats(-5, 2), st.floats(-4, 4))
def test_yuksel_eq8_between_eq7_and_inverse_square(log_r, log_x):
    """Yuksel 2020, section 3: eq. 8 is bounded by eq. 7 and inverse square."""
    r = 10.0**log_r
    d = jnp.asarray([r * 10.0**log_x])
    f7 = float(scalar_fn("yuksel")({"r": jnp.float64(r)}, d)[0])
    f8 = float(scalar_fn("yuksel_adhoc")({"r": jnp.float64(r)}, d)[0])
    inv = float(1 / d[0] ** 2)
    assert min(f7, inv) * (1 - 1e-12) <= f8 <= max(f7, inv) * (1 + 1e-12)


def test_polynomial_opengl_and_madams():
    kc, kl, kq = 0.5, 0.25, 2.0
    np.testing.assert_allclose(
        f64(attenfit.Polynomial(kc=kc, kl=kl, kq=kq), D), 1 / (kc + kl * D + kq * D * D), rtol=1e-15
    )
    r = 0.2  # Madams 2011: kc = 1, kl = 2/r, kq = 1/r^2 in surface distance = 1/(d/r + 1)^2
    got = f64(attenfit.Polynomial(kc=1.0, kl=2 / r, kq=1 / r**2), D)
    np.testing.assert_allclose(got, 1 / (D / r + 1) ** 2, rtol=1e-14)
    assert np.isinf(f64(attenfit.Polynomial(kc=0.0), 0.0))


def _madams_glsl(distance, r, cutoff=0.0):
    """Madams 2011's GLSL `DirectIllumination` attenuation, transcribed (1 at the surface)."""
    d = np.maximum(distance - r, 0)
    denom = d / r + 1
    att = 1 / (denom * denom)
    att = (att - cutoff) / (1 - cutoff)
    return np.maximum(att, 0)


def test_madams_sphere_against_the_post():
    r = 0.25
    np.testing.assert_allclose(
        f64(attenfit.MadamsSphere(r=r), D) * r * r, _madams_glsl(D, r), rtol=1e-14
    )


def test_madams_cutoff_against_the_post_and_its_d_max():
    r, c = 0.25, 0.005
    np.testing.assert_allclose(
        f64(attenfit.MadamsCutoff(r=r, cutoff=c), D) * r * r,
        _madams_glsl(D, r, c),
        rtol=1e-12,
        atol=1e-15,
    )
    d_max = r * (math.sqrt(1 / c) - 1)  # Madams: d_max = r (sqrt(Li/Ic) - 1), surface distance
    fam = attenfit.MadamsCutoff(r=r, cutoff=c)
    assert float(fam.range_distance()) == pytest.approx(r + d_max, rel=1e-14)
    inside, outside = f64(fam, [(r + d_max) * (1 - 1e-9), (r + d_max) * (1 + 1e-9)])
    assert 0 < inside < 1e-6 / r**2 and outside == 0


def test_madams_tan_against_the_post():
    r, d_max = 0.2, 2.1 * math.pi / 2  # the post's 2.1 tan(...) is 2 d_max/pi for this d_max
    d_s = np.maximum(D - r, 0)
    warped = 2.1 * np.tan(np.pi * d_s / (2 * d_max))
    ref = np.where(d_s < d_max, 1 / (warped + r) ** 2, 0)
    np.testing.assert_allclose(f64(attenfit.MadamsTan(r=r, d_max=d_max), D), ref, rtol=1e-12)


def test_madams_rational_against_the_post():
    r, d_max = 0.2, 3.0
    d_s = np.maximum(D - r, 0)
    with np.errstate(divide="ignore"):
        warped = d_s / (1 - (d_s / d_max) ** 2)
    ref = np.where(d_s < d_max, 1 / (warped + r) ** 2, 0)
    np.testing.assert_allclose(f64(attenfit.MadamsRational(r=r, d_max=d_max), D), ref, rtol=1e-12)


def test_unreal_window_in_unreal_units():
    # GetLocalLightAttenuation's mask times CapsuleLightIntegrate's 1/(d^2 + 1), in cm.
    r_max = 3.0
    d_cm, inv_r2 = 100 * D, 1 / (100 * r_max) ** 2
    ref = 1e4 * sat(1 - (d_cm**2 * inv_r2) ** 2) ** 2 / (d_cm**2 + 1)
    got = f64(attenfit.UnrealWindow(r_max=r_max), D)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-300)


def test_frostbite_window_listing():
    # Lagarde & de Rousiers 2014: smoothDistanceAtt(d^2, 1/r^2) / max(d^2, 0.01^2).
    r_max = 3.0
    smooth = sat(1 - (D**2 / r_max**2) ** 2) ** 2
    ref = smooth / np.maximum(D**2, 0.01**2)
    np.testing.assert_allclose(f64(attenfit.FrostbiteWindow(r_max=r_max), D), ref, rtol=1e-12)


def test_godot_get_omni_attenuation():
    def godot(distance, inv_range, decay):  # scene_forward_lights_inc.glsl, transcribed
        nd = distance * inv_range
        nd *= nd
        nd *= nd
        nd = np.maximum(1.0 - nd, 0.0)
        nd *= nd
        return nd * np.power(np.maximum(distance, 0.0001), -decay)

    d = np.concatenate([[0, 1e-5, 5e-5], D])
    np.testing.assert_allclose(
        f64(attenfit.Godot(a=1.3, r_max=5.0), d), godot(d, 1 / 5.0, 1.3), rtol=1e-12
    )


def test_cryengine_shadelib():
    def cry(d, inv_radius, bulb):  # shadeLib.cfi GetPhysicalLightAttenuation, transcribed
        fade = sat((1 / inv_radius - d) * inv_radius / 0.2)
        denom = 1 + np.maximum(d - bulb, 0) / bulb
        return fade * fade / (denom * denom)

    b, r_max = 0.05, 4.0
    np.testing.assert_allclose(
        f64(attenfit.CryEngineLinear(r_max=r_max), D) * b * b,
        cry(D, 1 / r_max, b),
        rtol=1e-12,
        atol=1e-300,
    )
    # RTR4's plain linear tail between 0.8 r_max and r_max.
    plain = sat((r_max - D) / (0.2 * r_max)) / np.maximum(D, b) ** 2
    np.testing.assert_allclose(
        f64(attenfit.CryEngineLinear(r_max=r_max, squared=False), D), plain, rtol=1e-12
    )


def test_just_cause_2_and_unreal_exponent():
    r_max = 4.0
    x = D / r_max
    np.testing.assert_allclose(
        f64(attenfit.JustCause2(scale=3.0, r_max=r_max), D),
        3 * np.maximum(1 - x**2, 0) ** 2,
        rtol=1e-12,
        atol=1e-300,
    )
    # DynamicLightingCommon.ush RadialAttenuation: (1 - saturate(dot(v, v)))^E, v = toLight / r.
    ref = 2.0 * (1 - sat(x * x)) ** 8.0
    np.testing.assert_allclose(
        f64(attenfit.UnrealExponent(scale=2.0, r_max=r_max), D), ref, rtol=1e-12, atol=1e-300
    )


def test_threejs_get_distance_attenuation():
    def three(d, cutoff, decay):  # LightUtils.js getDistanceAttenuation, transcribed
        falloff = 1.0 / np.maximum(np.power(d, decay), 0.01)
        if cutoff > 0:
            falloff *= sat(1 - (d / cutoff) ** 4) ** 2
        return falloff

    for decay in (2.0, 1.5):
        got = f64(attenfit.ThreeJS(decay=decay, cutoff=6.0), D)
        np.testing.assert_allclose(got, three(D, 6.0, decay), rtol=1e-12, atol=1e-300)


def test_gltf_range_spec():
    rng = 5.0
    d = D[1:]
    ref = np.maximum(np.minimum(1 - (d / rng) ** 4, 1), 0) / d**2  # KHR_lights_punctual
    np.testing.assert_allclose(f64(attenfit.GltfRange(range=rng), d), ref, rtol=1e-12, atol=1e-300)


def test_spline_against_scipy_pchip():
    values = np.array([3.0, 2.5, 2.5, 0.0, -1.0, -5.0])
    fam = attenfit.Spline(knot_values=values)
    knots = np.asarray(fam.knots)
    d = np.geomspace(knots[0] * 1.01, knots[-1] * 0.99, 60)
    ref = np.exp(PchipInterpolator(np.log(knots), values)(np.log(d)))
    np.testing.assert_allclose(f64(fam, d), ref, rtol=1e-13)
    # Extrapolation: constant below the first knot, inverse square beyond the last.
    np.testing.assert_allclose(f64(fam, [0.0, knots[0] / 2]), np.exp(values[0]), rtol=1e-15)
    far = knots[-1] * np.array([1.0, 3.0, 1e6])
    np.testing.assert_allclose(
        f64(fam, far), np.exp(values[-1]) * (knots[-1] / far) ** 2, rtol=1e-13
    )


@given(st.lists(st.floats(0, 3), min_size=5, max_size=5), st.floats(-5, 3), st.floats(-5, 3))
def test_spline_monotone_for_non_increasing_knots(steps, e1, e2):
    values = 4.0 - np.concatenate([[0.0], np.cumsum(steps)])
    d = jnp.asarray(sorted([10.0**e1, 10.0**e2]))
    f = scalar_fn("spline")({"knot_values": jnp.asarray(values)}, d)
    assert float(f[1]) <= float(f[0]) * (1 + 1e-12)


# ----------------------------------------------------------------------------- properties
def _params(name, s):
    return {k: jnp.asarray(v) for k, v in scaled_params(attenfit.get_family(name), s).items()}


@pytest.mark.parametrize(("name", "static"), CASES, ids=CASE_IDS)
@given(log_r=st.floats(-6, 3), e1=st.floats(-8, 8), e2=st.floats(-8, 8))
def test_nonnegative_and_monotone(name, static, log_r, e1, e2):
    s = 10.0**log_r / 0.1
    d = jnp.asarray(sorted([10.0**log_r * 10.0**e1, 10.0**log_r * 10.0**e2]))
    f = np.asarray(scalar_fn(name, static)(_params(name, s), d))
    assert not np.isnan(f).any() and (f >= 0).all()
    if attenfit.get_family(name).monotone:
        assert f[1] <= f[0] * (1 + 1e-12), (d, f)


def _length_scale(cls, params):
    scales = [
        float(np.max(np.asarray(v))) ** (1 / cls.length_power(k))
        for k, v in params.items()
        if cls.length_power(k) > 0
    ]
    return max(scales, default=1.0)


TENDS = [n for n in NAMES if attenfit.get_family(n).tends_to_inverse_square]


def test_physically_motivated_ones_declare_it():
    expected = {
        "yuksel",
        "yuksel_adhoc",
        "disk_facing",
        "madams_sphere",
        "clamped",
        "unreal_epsilon",
    }
    assert expected <= set(TENDS)


@pytest.mark.parametrize("name", TENDS)
@given(log_r=st.floats(-6, 3), e=st.floats(1.5, 8))
def test_tends_to_inverse_square(name, log_r, e):
    cls = attenfit.get_family(name)
    params = _params(name, 10.0**log_r / 0.1)
    length = _length_scale(cls, params)
    d = length * 10.0**e
    f = float(scalar_fn(name)(params, jnp.asarray([d]))[0])
    assert abs(f * d * d - 1) <= 1.5 * (length / d) ** 2 + 1e-12


COVARIANT = [(n, s) for n, s in CASES if attenfit.get_family(n).scale_covariant]


@pytest.mark.parametrize(("name", "static"), COVARIANT, ids=[n + str(s) for n, s in COVARIANT])
@given(log_s=st.floats(-6, 6), e=st.floats(-4, 3))
def test_scale_law(name, static, log_s, e):
    """d -> s d and each parameter p -> s^(its length power) p gives f -> f / s^2."""
    s = 10.0**log_s
    base = _params(name, 1.0)
    scaled = _params(name, s)
    d = jnp.asarray([0.1 * 10.0**e, 0.0])
    f = np.asarray(scalar_fn(name, static)(base, d))
    fs = np.asarray(scalar_fn(name, static)(scaled, d * s))
    if np.isinf(f[1]):
        assert np.isinf(fs[1])
        f, fs = f[:1], fs[:1]
    np.testing.assert_allclose(
        fs * s * s, f, rtol=1e-9, atol=1e-12 * np.max(f[np.isfinite(f)], initial=1.0)
    )


# ----------------------------------------------------------------------------- shapes
AWKWARD = np.array([-1.0, -np.inf, np.inf, np.nan, 0.0, 1e-3])


@pytest.mark.parametrize(("name", "static"), CASES, ids=CASE_IDS)
def test_shapes_dtypes_and_awkward_inputs(name, static):
    """Batched d and batched parameters broadcast like scalars; Python numbers and integer
    arrays give the default float; negative d reads as 0, +inf gives 0, NaN gives NaN."""
    cls = attenfit.get_family(name)
    fam = cls(**dict(static))
    d = np.concatenate([AWKWARD, np.linspace(0.05, 12.0, 18)]).reshape(2, 3, 4)
    whole = f64(fam, d)
    assert whole.shape == (2, 3, 4) and whole.dtype == np.float64
    scalars = [np.asarray(fam(float(x))) for x in d.ravel()]  # Python floats: shape ()
    assert all(v.dtype == np.float64 and v.shape == () for v in scalars)
    np.testing.assert_allclose(whole.ravel(), scalars, rtol=1e-13)
    got = whole.ravel()[: len(AWKWARD)]
    at0 = got[4]
    np.testing.assert_array_equal(got[:2], [at0, at0])
    assert got[2] == 0 and np.isnan(got[3])
    # Parameters with a leading batch axis, matched by d (the layout fit_many vmaps over).
    factors = np.array([0.5, 1.0, 2.0, 1.5, 0.75, 1.25])
    batched = {
        k: np.stack([np.asarray(v) * f ** max(cls.length_power(k), 0) for f in factors])
        for k, v in cls.defaults().items()
    }
    dd = np.array([0.07, 1.3, 9.0, 0.0, 4.0, 2.5])
    got = f64(cls(**batched, **dict(static)), dd)
    assert got.shape == (6,)

    def row(i):  # Python floats like the defaults (same trace as above: no recompile)
        return {k: float(v[i]) if v.ndim == 1 else v[i] for k, v in batched.items()}

    one_by_one = [float(cls(**row(i), **dict(static))(float(dd[i]))) for i in range(len(dd))]
    np.testing.assert_allclose(got, one_by_one, rtol=1e-13)


def test_any_float_dtype_in_same_out():
    for dtype in (jnp.float16, jnp.bfloat16, jnp.float32, jnp.float64):
        for fam in (attenfit.Yuksel(), attenfit.FrostbiteWindow(), attenfit.Spline()):
            assert fam(jnp.asarray([0.5, 2.0], dtype=dtype)).dtype == dtype
        assert fam(np.arange(3)).dtype == jnp.float64  # integers: the default float
    # float64 parameters do not widen a float32 d.
    assert attenfit.Yuksel(r=np.float64(0.2))(jnp.float32(1.0)).dtype == jnp.float32


# ----------------------------------------------------------------------------- registry
def test_registry_errors_and_a_custom_family():
    with pytest.raises(attenfit.UnknownNameError, match="unknown family 'nope'"):
        attenfit.get_family("nope")
    with pytest.raises(attenfit.BadValueError, match=r"parameter 'r' must be > 0, got -1.0"):
        attenfit.Yuksel(r=-1.0)
    with pytest.raises(attenfit.BadValueError, match="strictly between 0 and 1"):
        attenfit.MadamsCutoff(cutoff=1.5)
    with pytest.raises(attenfit.UnknownNameError):
        attenfit.Yuksel().replace(radius=1.0)

    class YukselWindowed(attenfit.Family):
        """The docs/families.md recipe: Yuksel's base times the Unreal/Frostbite window."""

        r: float = 0.1
        r_max: float = 10.0
        name = "yuksel"
        formula = "yuksel(d, r) * (1 - (d/r_max)^4)+^2"
        source = "this test"
        default_free = ("r",)
        shader_form = attenfit.no_shader_form

        def __call__(self, d):
            d, r, r_max = parts.promote(d, self.r, self.r_max)
            d = parts.distance(d)
            return parts.yuksel(d, r) * parts.smooth_window(d, r_max)

    with pytest.raises(attenfit.BadValueError, match="registered already"):
        attenfit.register_family(YukselWindowed)
    fam = YukselWindowed(r_max=2.0)
    np.testing.assert_allclose(
        f64(fam, [0.5, 2.0]), [f64(attenfit.Yuksel(), 0.5) * (1 - 0.25**4) ** 2, 0.0]
    )


def test_cli_families_table_and_json(capsys):
    assert main(["families"]) == 0
    out = capsys.readouterr().out
    for name in NAMES:
        assert name in out
    assert "Yuksel 2020" in out and "KHR_lights_punctual" in out
    assert "params : r=0.1\n" in out and "knot_values=[4.605, 4.595, 3.912," in out
    assert main(["families", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    rows = listing["families"]
    assert [r["name"] for r in rows] == NAMES
    assert [r["name"] for r in listing["area_models"]] == attenfit.list_area_models()
    yk = rows[NAMES.index("yuksel")]
    assert yk["params"] == {"r": {"default": 0.1, "constraint": "positive"}}
    assert yk["default_free"] == ["r"]


def test_family_from_function():
    def windowed_yuksel(d, r, r_max):
        """Yuksel's curve times the Unreal/Frostbite window."""
        d, r, r_max = parts.promote(d, r, r_max)
        d = parts.distance(d)
        return parts.yuksel(d, r) * parts.smooth_window(d, r_max)

    cls = attenfit.family_from_function(
        windowed_yuksel,
        name="windowed_yuksel",
        defaults={"r": 0.1, "r_max": 10.0},
        formula="2/(s (s + d)) (1 - (d/r_max)^4)+^2",
        source="this test",
        default_free=("r",),
        length_params=("r", "r_max"),
        range_param="r_max",
        window="smooth",
    )
    assert issubclass(cls, attenfit.Family) and "windowed_yuksel" not in NAMES
    assert cls.param_names() == ("r", "r_max") and cls.default_free == ("r",)
    fam = cls(r=0.2)
    want = f64(attenfit.Yuksel(r=0.2), 1.0) * (1 - 0.1**4) ** 2
    assert float(fam(1.0)) == pytest.approx(float(want), rel=1e-14)
    g = jax.grad(lambda m: m(jnp.float64(1.0)))(fam)
    assert np.isfinite(float(g.r)) and float(g.r_max) > 0
    with pytest.raises(attenfit.UnknownNameError, match="unknown properties"):
        attenfit.family_from_function(
            windowed_yuksel, name="x", defaults={}, formula="", source="", colour=1
        )
