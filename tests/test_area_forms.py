"""The shader forms of the area models: each agrees with its JAX model (attenfit's reference,
itself checked against the engines' code and the exact irradiance in test_area_models.py)
on random receivers, and compiles with the real compilers where they are installed."""

from __future__ import annotations

import numpy as np
import pytest

import attenfit as af
from attenfit import area
from attenfit._shaders import area_compiled_cost, area_function_source, evaluate_area_form
from attenfit._shaders._compilers import missing

R = 0.3
SPHERE_MODELS = ["snyder_sphere", "unreal_wrap", "godot_wrap", "hdrp_sphere", "mrp_sphere"]
DISK_MODELS = ["frostbite_disk", "vector_disk"]
#: where the engine's clamps part from the reference (cosTheta to +-0.999, sin^2 to 0.9999)
TOL = {"snyder_sphere": 1e-3, "frostbite_disk": 1e-3, "vector_disk": 1e-2}


def _inputs(emitter, seed, d_min):
    ds = af.random_receivers(emitter, 3000, d_min, 30 * R, seed=seed)
    x = area.area_inputs(emitter, ds.points, ds.normals)
    given = {k: np.asarray(getattr(x, k)) for k in area.AREA_FORM_INPUTS}
    return x, {**given, "r": R}


@pytest.fixture(scope="module")
def sphere_inputs():
    return _inputs(af.SphereEmitter([0.0, 0.0, 0.0], R), 1, 1.01 * R)


@pytest.fixture(scope="module")
def disk_inputs():
    return _inputs(af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], R), 2, 0.05 * R)


def _check(model, x, given):
    ref = np.asarray(model(*x))
    form = evaluate_area_form(model, given, np.float64)
    facing = 1 / np.maximum(np.asarray(x.d), R) ** 2
    err = np.abs(form - ref) / facing
    assert np.all(np.isfinite(form))
    assert err.max() < TOL.get(model.name, 1e-6), model.name
    return err


@pytest.mark.parametrize("name", SPHERE_MODELS)
def test_sphere_forms_agree_with_their_models(name, sphere_inputs):
    params = {"unreal_wrap": {"k": 1.4}, "godot_wrap": {"k": 0.7}}.get(name, {})
    _check(area.get_area_model(name)(**params), *sphere_inputs)


@pytest.mark.parametrize("name", DISK_MODELS)
def test_disk_forms_agree_with_their_models(name, disk_inputs):
    err = _check(area.get_area_model(name)(), *disk_inputs)
    if name == "vector_disk":  # exact, unclamped, wherever the disk is above the horizon
        x, _ = disk_inputs
        w = np.sqrt(np.maximum(1 - np.asarray(x.cos_n) ** 2, 0))
        above = np.asarray(x.d * x.cos_r) >= R * w
        assert err[above].max() < 1e-6  # the unguarded form cancels near the rim


def test_the_clamped_vector_disk_has_its_own_form(disk_inputs):
    """clip="clamp" is max(0, n.F) where the horizon cuts the disk: no cap, no clamps."""
    model = area.VectorDisk(clip="clamp")
    x, given = disk_inputs
    err = _check(model, x, given)
    assert err.max() < 1e-6
    names = [n for n, _ in model.shader_form().lets]
    assert "e_vec" in names and not any(n.startswith("cap_") for n in names)
    assert any(n.startswith("cap_") for n, _ in area.VectorDisk().shader_form().lets)


def test_point_light_form_is_the_family_form_times_the_clamped_cosine(sphere_inputs):
    x, given = sphere_inputs
    fam = af.Yuksel(r=0.4)
    _check(area.PointLight(fam), x, given)
    form = area.PointLight(fam).shader_form()
    assert form.params == ("r",) and form.inputs == area.AREA_FORM_INPUTS


def test_every_registered_model_has_a_form_in_every_language():
    for name in area.list_area_models():
        model = area.get_area_model(name)()
        if model.input_names != area.AREA_INPUTS:  # rect, tube: test_rect_models.py
            continue
        for lang in ("glsl", "hlsl", "wgsl", "c", "cuda"):
            text = area_function_source(model, lang, "attenfit_area", R)
            assert "attenfit_area" in text and "cos_r" in text


@pytest.mark.skipif(missing("spirv") is not None, reason="glslangValidator/spirv-opt missing")
def test_forms_compile_to_spirv_and_the_exact_sphere_costs_more_than_a_wrap():
    costs = {
        n: area_compiled_cost(area.get_area_model(n)()).cost
        for n in ("snyder_sphere", "unreal_wrap", "point_light")
    }
    assert all(c > 0 for c in costs.values())
    # acos and atan in the clipped branch against a quadratic
    assert costs["snyder_sphere"] > costs["unreal_wrap"] > costs["point_light"]
