"""The shader forms: what each prints, that it agrees with the JAX reference where both are
meant to hold, that each engine form is the engine's code, and how precise it is in float16.

The engine transcriptions here are written from the engines' own code (file and function
named on each), independently of the forms written on the model classes (`shader_form`).
"""

from __future__ import annotations

import math
import platform
import shutil
import subprocess

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import attenfit
from attenfit import export as ex
from attenfit._shaders import evaluate_form, scalar_params
from attenfit._shaders._precision import precision

BUILTIN = {getattr(attenfit.families, c).name for c in attenfit.families.__all__}
FAMILIES = [n for n in attenfit.list_families() if n in BUILTIN]
WITH_FORM = [n for n in FAMILIES if attenfit.get_family(n).has_shader_form()]


def test_every_builtin_family_but_the_spline_has_a_shader_form():
    assert set(FAMILIES) - set(WITH_FORM) == {"spline"}  # Tomb Raider: no formula published
    src = ex.export("spline", "glsl")
    assert "this family has no shader form" in src


def _domain(fam) -> np.ndarray:
    """The family's normal domain: 1 mm to 1 km, short of the last 10% of its range (where
    1 - x^m cancels: the window forms lose p eps / (1 - x^m), p = 8 for Unreal's exponent)."""
    d = np.geomspace(1e-3, 1e3, 400)
    rng = fam.range_distance()
    if rng is not None:
        d = d[d < 0.9 * float(rng)]
    return d.astype(np.float32)


@pytest.mark.parametrize("name", WITH_FORM)
def test_shader_form_agrees_with_the_reference_in_float32(name):
    """To float32 rounding over the normal domain; they part ways at the extremes (below)."""
    fam = attenfit.get_family(name)()
    d = _domain(fam)
    got = evaluate_form(fam.shader_form(), d, scalar_params(fam), np.float32).astype(np.float64)
    with jax.enable_x64(True):
        want = np.asarray(fam(jnp.asarray(d, jnp.float64)))
    rel = np.abs(got - want) / want
    assert rel.max() < 2e-6, (name, d[rel.argmax()], rel.max())


def test_where_the_forms_part_ways():
    """The shader forms have no guards: what the stable form keeps, they do not."""
    inv = attenfit.get_family("inverse_square")().shader_form()
    big = np.float32(1e20)  # d*d overflows float32: 1/inf = 0, the reference gives 1e-40
    assert evaluate_form(inv, np.array([big]), {}, np.float32)[0] == 0
    win = attenfit.get_family("frostbite_window")()
    near = (10.0 * (1 - np.geomspace(1e-7, 1e-5, 50))).astype(np.float32)  # 1 - x^4 cancels
    got = evaluate_form(win.shader_form(), near, scalar_params(win), np.float32)
    with jax.enable_x64(True):
        want = np.asarray(win(jnp.asarray(near, jnp.float64)))
    assert np.max(np.abs(got / want - 1)) > 0.05


# ----------------------------------------------------------------------------- the engines
def _sat(x):
    return np.clip(x, 0.0, 1.0)


def _engine(name: str, d: np.ndarray, p: dict) -> np.ndarray:
    """Each engine's code, transcribed from its source, in float64."""
    if name == "yuksel":  # Blender eevee_light_lib.glsl::light_point_light
        d_sqr, r_sqr = d * d, p["r"] ** 2
        return 2.0 / (d_sqr + r_sqr + d * np.sqrt(d_sqr + r_sqr))
    if name == "frostbite_window":  # Filament light_punctual.fs
        falloff = 1 / p["r_max"] ** 2  # LightManager.cpp::setFalloff: squaredFallOffInv
        distance_square = d * d
        factor = distance_square * falloff
        smooth = _sat(1.0 - factor * factor)
        attenuation = smooth * smooth  # getSquareFalloffAttenuation
        return attenuation * 1.0 / np.maximum(distance_square, p["r_min"] ** 2)
    if name == "godot":  # scene_forward_lights_inc.glsl::get_omni_attenuation
        nd = d * (1 / p["r_max"])
        nd *= nd
        nd *= nd
        nd = np.maximum(1.0 - nd, 0.0)
        nd *= nd
        return nd * np.power(np.maximum(d, 0.0001), -p["a"])
    if name == "cryengine_linear":  # shadeLib.cfi::GetPhysicalLightAttenuation, / b^2
        b, radius = p["r_min"], p["r_max"]
        fade = _sat((radius - d) * ((1 / radius) / 0.2))
        denom = 1 + np.maximum(d - b, 0) / b
        return fade * fade / (denom * denom) / (b * b)
    if name == "threejs":  # lights_pars_begin.glsl.js::getDistanceAttenuation
        falloff = 1.0 / np.maximum(np.power(d, p["decay"]), 0.01)
        x = d / p["cutoff"]
        return falloff * _sat(1.0 - (x * x) * (x * x)) ** 2  # pow2(saturate(1 - pow4(x)))
    if name == "gltf_range":  # glTF-Sample-Viewer punctual.glsl::getRangeAttenuation
        return np.maximum(np.minimum(1.0 - np.power(d / p["range"], 4.0), 1.0), 0.0) / np.power(
            d, 2.0
        )
    if name == "unreal_window":  # GetLocalLightAttenuation x CapsuleLightIntegrate falloff
        dist_sqr = d * d
        mask = _sat(1 - (dist_sqr * (1 / p["r_max"]) ** 2) ** 2) ** 2
        return mask * (1 / (dist_sqr + p["eps"]))
    if name == "unreal_epsilon":
        return 1 / (d * d + p["eps"])
    if name == "unreal_exponent":  # DynamicLightingCommon.ush::RadialAttenuation
        v = d / p["r_max"]
        return p["scale"] * np.power(1 - _sat(v * v), p["p"])
    if name == "spot_frostbite":  # Filament getAngleAttenuation; setSpotLightCone's scale
        cos_outer = math.cos(p["umbra"])
        scale = 1 / max(math.cos(p["penumbra"]) - cos_outer, 0.001)
        t = _sat(d * scale + (-cos_outer * scale))
        return t * t
    if name == "spot_threejs":  # GLSL smoothstep(coneCos, penumbraCos, angleCos)
        e0, e1 = math.cos(p["umbra"]), math.cos(p["penumbra"])
        t = _sat((d - e0) / max(e1 - e0, 0.001))
        return t * t * (3 - 2 * t)
    raise KeyError(name)


ENGINES = ["yuksel", "frostbite_window", "godot", "cryengine_linear", "threejs", "gltf_range",
           "unreal_window", "unreal_epsilon", "unreal_exponent"]  # fmt: skip


@pytest.mark.parametrize("name", [*ENGINES, "spot_frostbite", "spot_threejs"])
def test_engine_form_is_the_engines_code(name):
    spot = name.startswith("spot_")
    fam = (
        attenfit.directional.SpotFrostbite() if name == "spot_frostbite" else attenfit.directional.SpotThreeJS()
    ) if spot else attenfit.get_family(name)()  # fmt: skip
    sf = fam.shader_form()
    assert sf.engine, name
    d = np.linspace(-1, 1, 801) if spot else np.geomspace(1e-3, 11.0, 801)
    p = scalar_params(fam)
    got = evaluate_form(sf, d, p, np.float64)
    want = _engine(name, d, {k: float(np.float32(v)) for k, v in p.items()})
    # the shader's literals (0.2, 0.01, 0.001) are float32, the transcription's float64
    np.testing.assert_allclose(got, want, rtol=1e-7, atol=1e-300)


def test_engine_forms_cite_file_and_function():
    for name in ENGINES:
        sf = attenfit.get_family(name)().shader_form()
        assert "::" in sf.source or ".fs" in sf.source, (name, sf.source)


# ----------------------------------------------------------------------------- C output
def test_c_shader_forms_match_jax_float32(tmp_path):
    """Every shader form compiled by `cc` agrees with the JAX float32 reference in its domain."""
    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler (cc or gcc) on PATH")
    import ctypes

    src = ["#include <math.h>\n"]
    for k, name in enumerate(WITH_FORM):
        src.append(ex.export(name, "c", name=f"f{k}"))
        src.append(
            f"void many_{k}(const float *d, float *o, int n) {{ for (int i = 0; i < n; ++i) o[i] = f{k}(d[i]); }}\n"
        )
    (tmp_path / "forms.c").write_text("\n".join(src))
    fma = ["-march=native"] if platform.machine() in ("x86_64", "AMD64") else []
    out = tmp_path / "libforms.so"
    proc = subprocess.run([cc, "-std=c99", "-O2", *fma, "-fPIC", "-shared", "-Wall", "-Werror",
                           "-o", str(out), str(tmp_path / "forms.c"), "-lm"],
                          capture_output=True, text=True)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    lib = ctypes.CDLL(str(out))
    fp = ctypes.POINTER(ctypes.c_float)
    for k, name in enumerate(WITH_FORM):
        fam = attenfit.get_family(name)()
        d = _domain(fam)
        got = np.empty_like(d)
        getattr(lib, f"many_{k}")(d.ctypes.data_as(fp), got.ctypes.data_as(fp), d.size)
        with jax.enable_x64(False):
            want = np.asarray(fam(jnp.asarray(d)), np.float64)
        rel = np.abs(got - want) / want
        assert rel.max() < 2e-6, (name, d[rel.argmax()], rel.max())


# ----------------------------------------------------------------------------- float16
def test_inverse_square_in_float16_fails_where_the_closed_form_says():
    p = precision(attenfit.get_family("inverse_square")(), "float16")
    # 1/d^2 exceeds float16's largest 65504 below d = 65504^-1/2 = 3.9 mm
    assert 3.7e-3 < p.overflow[1] < 1 / math.sqrt(65504)
    # d*d overflows beyond sqrt(65504) = 255.9 m, so 1/(d*d) is 0 there
    assert math.sqrt(65504) < p.zero[0] < 262
    # 1/d^2 leaves the normal range (2^-14) beyond d = 2^7 = 128 m
    assert 128 <= p.subnormal[0] < 131
    assert p.band[0] < 4e-3 and 250 < p.band[1] < 256


def test_float32_band_and_window_tails():
    fam = attenfit.get_family("unreal_window")()
    p32, p16 = precision(fam, "float32"), precision(fam, "float16")
    assert p32.band[1] > 9.9 and p32.zero is None
    assert p16.band[1] < 9.7 and p16.inaccurate is not None  # 1 - x^4 in 11 bits
