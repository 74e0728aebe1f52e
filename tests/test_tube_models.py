"""The tube's area models against the formulas they cite transcribed here (Karis 2013's line
integral, checked itself against quadrature; Frostbite 2014's tube listing), against the
exact irradiance (`attenfit.TubeEmitter`) where they should be close, their shader forms,
exports, and the point-light model of a tube."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest
from _frame_forms import form_and_model

import attenfit as af
from attenfit import area
from attenfit._curves import FrostbiteTube, KarisTube, LambertLine
from attenfit._shaders import area_compiled_cost
from attenfit._shaders._area_export import area_source
from attenfit._truth import model_inputs

A = np.array([-0.6, 0.3, 2.5])
B = np.array([0.6, 0.3, 2.5])
R = 0.013
TUBE = af.TubeEmitter(A, B, R, intensity=3.0)
MODELS = [KarisTube(), FrostbiteTube(), LambertLine()]
L_RAD = 3.0 / (math.pi * R * R)  # the radiance, I / (pi r^2)


def _receivers(n: int, seed: int, spread: float = 0.8, facing: bool = False):
    rng = np.random.default_rng(seed)
    c = (A + B) / 2
    p = c + rng.normal(size=(n, 3)) * spread
    off = p - c
    off[:, 1:] *= np.maximum(1, 3 * R / np.linalg.norm(off[:, 1:], axis=1))[:, None]  # outside it
    p = c + off
    nrm = c - p if facing else rng.normal(size=(n, 3))
    return p, nrm / np.linalg.norm(nrm, axis=1, keepdims=True)


# ----------------------------------------------------------------------------- transcriptions
def karis_line_irradiance(n, l0, l1):
    """Karis 2013, "Real Shading in Unreal Engine 4" (SIGGRAPH course notes), tube lights:
    the irradiance of a line segment, `(n.L0/|L0| + n.L1/|L1|) / (|L0| |L1| + L0.L1)`, clamped
    at 0 (what `int_0^1 n.L(t) / |L(t)|^3 dt` is where the segment is above the horizon)."""
    a, b = np.linalg.norm(l0), np.linalg.norm(l1)
    return max((np.dot(n, l0) / a + np.dot(n, l1) / b) / (a * b + np.dot(l0, l1)), 0.0)


def frostbite_tube_illuminance(world_pos, world_normal, light_pos, light_left, width, radius):
    """Lagarde & de Rousiers 2014, "Moving Frostbite to PBR" §4.7.4, the tube light's
    illuminance listing (a rectangle facing the receiver plus the sphere at the closest point
    of the segment), line by line in float64."""

    def normalize(x):
        return x / np.linalg.norm(x)

    def sat(x):
        return min(max(x, 0.0), 1.0)

    def closest_on_line(a, b, c):
        ab = b - a
        return a + np.dot(c - a, ab) / np.dot(ab, ab) * ab

    def closest_on_segment(a, b, c):
        ab = b - a
        return a + sat(np.dot(c - a, ab) / np.dot(ab, ab)) * ab

    def solid_angle(p0, p1, p2, p3):
        v = [q - world_pos for q in (p0, p1, p2, p3)]
        nn = [normalize(np.cross(v[i], v[(i + 1) % 4])) for i in range(4)]
        g = [math.acos(np.clip(np.dot(-nn[i], nn[(i + 1) % 4]), -1, 1)) for i in range(4)]
        return sum(g) - 2 * math.pi

    p0_ = light_pos - light_left * (0.5 * width)
    p1_ = light_pos + light_left * (0.5 * width)
    forward = normalize(closest_on_line(p0_, p1_, world_pos) - world_pos)
    up = np.cross(light_left, forward)
    p0 = light_pos - light_left * (0.5 * width) + radius * up
    p1 = light_pos - light_left * (0.5 * width) - radius * up
    p2 = light_pos + light_left * (0.5 * width) - radius * up
    p3 = light_pos + light_left * (0.5 * width) + radius * up
    sa = solid_angle(p0, p1, p2, p3)
    cos = [sat(np.dot(normalize(q - world_pos), world_normal)) for q in (p0, p1, p2, p3, light_pos)]
    illuminance = sa * 0.2 * sum(cos)
    sphere_unorm = closest_on_segment(p0_, p1_, world_pos) - world_pos
    sphere_l = normalize(sphere_unorm)
    sqr_d = np.dot(sphere_unorm, sphere_unorm)
    return illuminance + math.pi * sat(np.dot(sphere_l, world_normal)) * (radius * radius / sqr_d)


# ----------------------------------------------------------------------------- tests
def test_karis_formula_is_the_line_integral():
    """The transcription itself against the midpoint rule, where the segment is above the
    horizon (there the clamp does not act)."""
    rng = np.random.default_rng(1)
    t = (np.arange(20000) + 0.5) / 20000
    for _ in range(20):
        p, n = rng.normal(size=3), rng.normal(size=3)
        n /= np.linalg.norm(n)
        l0, l1 = A - p, B - p
        lt = l0[None] + t[:, None] * (l1 - l0)[None]
        integrand = (lt @ n) / np.linalg.norm(lt, axis=1) ** 3
        if np.all(integrand > 0):
            assert karis_line_irradiance(n, l0, l1) == pytest.approx(integrand.mean(), rel=1e-6)


def test_karis_tube_is_the_line_of_the_tubes_broadside_intensity():
    p, n = _receivers(200, 2)
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(KarisTube(), TUBE, p, n))
    for i in range(len(p)):
        k = karis_line_irradiance(n[i], A - p[i], B - p[i])
        want = 2 * R * L_RAD * np.linalg.norm(B - A) * k  # E = (2 r L) l k
        assert got[i] == pytest.approx(want, rel=1e-9, abs=1e-12), i


def test_frostbite_tube_is_its_listing():
    p, n = _receivers(200, 3)
    left = (B - A) / np.linalg.norm(B - A)
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(FrostbiteTube(), TUBE, p, n))
    for i in range(len(p)):
        e = frostbite_tube_illuminance(p[i], n[i], (A + B) / 2, left, np.linalg.norm(B - A), R)
        assert got[i] == pytest.approx(L_RAD * e, rel=1e-9, abs=1e-12), i


def test_lambert_line_is_the_lines_integral_by_quadrature():
    """The closed form against the midpoint rule of `2 r L rho max(0, n.L) / |L|^4` along the
    axis (the horizon clipped by the max), at receivers of any orientation."""
    p, n = _receivers(60, 7)
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(LambertLine(), TUBE, p, n))
    t = (np.arange(200000) + 0.5) / 200000
    axis = (B - A) / np.linalg.norm(B - A)
    for i in range(len(p)):
        lt = A[None] + t[:, None] * (B - A)[None] - p[i][None]
        rho = np.linalg.norm(np.cross(lt[0], axis))
        dist = np.linalg.norm(lt, axis=1)
        f = 2 * R * L_RAD * rho * np.maximum(lt @ n[i], 0) / dist**4
        want = f.mean() * np.linalg.norm(B - A)
        assert got[i] == pytest.approx(want, rel=1e-5, abs=1e-9 * L_RAD * R), i


def test_lambert_line_tends_to_the_truth_of_a_thin_tube():
    """Receivers of any orientation at 20 to 200 radii from the axis: within `r / rho` of
    the truth's facing value (what it omits, the side's width, is of order r / distance)."""
    rng = np.random.default_rng(8)
    c = (A + B) / 2
    k = 300
    rho = np.exp(rng.uniform(np.log(20 * R), np.log(200 * R), k))
    phi = rng.uniform(0, 2 * np.pi, k)
    p = c + np.stack([rng.uniform(-0.8, 0.8, k), rho * np.cos(phi), rho * np.sin(phi)], -1)
    n = rng.normal(size=(k, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    with jax.enable_x64(True):
        exact = np.asarray(af.irradiance(TUBE, p, n))
        facing = np.asarray(af.irradiance(TUBE, p, TUBE.closest_point(p) - p))
        got = np.asarray(area.area_irradiance(LambertLine(), TUBE, p, n))
    assert np.all(np.abs(got - exact) / facing < R / rho)


def test_broadside_and_far_the_models_approach_the_truth():
    """Facing receivers off the tube's middle, far from it (the line limit): the line tends
    to the truth; Frostbite's form to the truth plus its sphere (the end caps, which this
    tube has not): a relative excess of `pi r^2 / (2 r l) = pi r / (2 l)`."""
    c = (A + B) / 2
    p = c + np.array([[0.0, 0.0, -d] for d in (0.3, 6.0, 500.0)])
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    with jax.enable_x64(True):
        exact = np.asarray(af.irradiance(TUBE, p, n))
        karis = np.asarray(area.area_irradiance(KarisTube(), TUBE, p, n))
        fb = np.asarray(area.area_irradiance(FrostbiteTube(), TUBE, p, n))
    assert abs(karis[0] / exact[0] - 1) > 0.1 and np.all(np.abs(karis[1:] / exact[1:] - 1) < 1e-3)
    excess = math.pi * R / (2 * np.linalg.norm(B - A))
    assert fb[-1] / exact[-1] - 1 == pytest.approx(excess, rel=0.01)


def test_the_point_light_model_of_a_tube_is_its_projected_area():
    """`PointLight()` at the segment's closest point, times the side's projected-area
    factor `g = 2 l sin(psi) / (pi r)` (`attenfit.area_inputs`)."""
    p, n = _receivers(100, 4)
    with jax.enable_x64(True):
        got = np.asarray(area.area_irradiance(area.PointLight(), TUBE, p, n))
    ab = B - A
    t = np.clip((p - A) @ ab / (ab @ ab), 0, 1)
    dv = A + t[:, None] * ab - p
    d = np.linalg.norm(dv, axis=1)
    lhat = dv / d[:, None]
    g = 2 * np.linalg.norm(np.cross(lhat, ab), axis=1) / (math.pi * R)
    want = 3.0 * g * np.maximum(np.sum(n * lhat, 1), 0) / d**2
    np.testing.assert_allclose(got, want, rtol=1e-10)


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
def test_the_shader_form_is_the_model(model):
    p, n = _receivers(500, 5)
    form, ref = form_and_model(model, TUBE, p, n)
    scale = np.max(np.abs(ref))  # literals baked as float32
    assert np.max(np.abs(form - ref)) < 1e-6 * scale


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
def test_exports_and_compiled_cost(model):
    for lang in ("glsl", "hlsl", "wgsl", "c", "cuda"):
        text = area_source(model, lang, "attenfit_tube")
        assert "attenfit_tube" in text and "hl" in text
    assert area_compiled_cost(model).cost > 10


@pytest.mark.parametrize("model", MODELS, ids=lambda m: m.name)
@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_values_and_gradients_are_finite(model, dtype):
    with jax.enable_x64(dtype == jnp.float64):
        p, n = _receivers(64, 6)
        npd = np.float64 if dtype == jnp.float64 else np.float32
        x = [jnp.asarray(v, dtype) for v in model_inputs(model, TUBE, p.astype(npd), n.astype(npd))]
        v = model(*x)
        assert v.dtype == dtype and np.all(np.isfinite(np.asarray(v)))
        assert np.all(np.asarray(v) >= 0)
        grads = jax.grad(lambda z: jnp.sum(model(*x[:2], z, *x[3:])))(x[2])
        assert np.all(np.isfinite(np.asarray(grads)))


def test_shape_worst_case_on_a_wall_beside_a_tube():
    """Beyond the tube's ends its side is seen edge-on and the truth fades; the isotropic
    line does not (its worst case far along the axis), Frostbite's sphere less so."""
    from attenfit._judge import SHAPE_CONFIGS, shape_worst_case

    wall = next(c for c in SHAPE_CONFIGS if c.key == "tube_one")
    karis = shape_worst_case(KarisTube(), wall, grid=9, seeds=1, levels=1)
    frost = shape_worst_case(FrostbiteTube(), wall, grid=9, seeds=1, levels=1)
    assert karis.error > 1 and karis.point[0] > 1  # past the end (x in units of l)
    assert frost.error < karis.error


def test_a_tube_scene_escalates_to_the_tube_and_sphere_models():
    from attenfit._scenes._escalate import _models_for

    names = {m.name for m in _models_for({"tube"})}
    assert {"karis_tube", "frostbite_tube", "snyder_sphere"} <= names
    assert "clipped_rect" not in names
