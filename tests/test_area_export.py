"""`attenfit export` of the area models: every registered model, in every language, checked by
real compilers and against the JAX model.

* C: every model exported (parameters baked in, and as arguments), compiled with the system
  `cc` into one shared library and called on receivers around a sphere and a disk: it must
  agree with the JAX model (`model(d, cos_r, cos_e, r, cos_n, g)`, float64) within what
  float32 and the engine's clamps in the shader form allow (below).
* GLSL: validated with `glslangValidator` (desktop 4.50 and ES 3.00); HLSL compiled to
  SPIR-V by `glslangValidator -D` and checked by `spirv-val`; WGSL validated with `naga` and
  `tint`. A validator that is missing makes its test skip with a reason naming it.
* The header (source, formula, inputs, output), the CLI verb and its refusals.
"""

from __future__ import annotations

import ctypes
import json
import math
import re
import shutil
import subprocess
from typing import ClassVar

import numpy as np
import pytest
from _tools import check_hlsl as _check_hlsl
from _tools import check_wgsl as _check_wgsl
from _tools import need as _need
from _tools import run as _run

import attenfit as af
from attenfit import area
from attenfit import export as ex
from attenfit._shaders._text import comment_safe
from attenfit.cli import main

LANGS = ("glsl", "hlsl", "wgsl", "c", "cuda")
#: the library's area models, and the point-light model of a family with a parameter `r`
#: (named like the input `r`: the export renames it)
MODELS = [
    area.get_area_model(n)()
    for n in area.list_area_models()
    if area.get_area_model(n).input_names == area.AREA_INPUTS  # rect, tube: their own tests
]
MODELS += [area.PointLight(af.Yuksel(r=0.05)), area.VectorDisk(clip="clamp")]
NAMES = [f"{m.name}_{k}" for k, m in enumerate(MODELS)]
R = 0.3
UNITS = ("length", "1", "1", "length (the unit of d)", "1", "1")  # of d, cos_r, cos_e, r, cos_n, g


def _receivers(emitter, seed: int, d_min: float) -> np.ndarray:
    """The six inputs (rows in `AREA_INPUTS` order) of random receivers around `emitter`."""
    ds = af.random_receivers(emitter, 2000, d_min, 30 * R, seed=seed)
    x = area.area_inputs(emitter, ds.points, ds.normals)
    return np.stack([np.broadcast_to(np.asarray(v, np.float64), np.shape(x.d)) for v in x])


SPHERE = _receivers(af.SphereEmitter([0.0, 0.0, 0.0], R), 1, 1.01 * R)
DISK = _receivers(af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], R), 2, 0.05 * R)


def _inputs_for(model) -> np.ndarray:
    return DISK if model.light == "disk" else SPHERE


# ----------------------------------------------------------------------------- the text
@pytest.mark.parametrize("lang", LANGS)
@pytest.mark.parametrize("model", MODELS, ids=NAMES)
def test_every_area_model_exports_in_every_language(model, lang):
    src = ex.export(model, lang)
    fname = f"attenfit_{model.name}"
    if lang == "wgsl":
        sig = f"fn {fname}(d: f32, cos_r: f32, cos_e: f32, r: f32, cos_n: f32, g: f32) -> f32 {{"
    else:
        prefix = "__device__ " if lang == "cuda" else ""
        sig = (
            f"{prefix}float {fname}(float d, float cos_r, float cos_e, float r, float cos_n, "
            "float g) {"
        )
    assert sig in src
    assert f"// source  : {comment_safe(model.source)}" in src
    assert f"// formula : {comment_safe(model.formula)}" in src
    assert f"// model   : {model.name} (an area model; lights: {model.light})" in src
    for x, unit in zip(area.AREA_INPUTS, UNITS, strict=True):  # each input, with its unit
        assert re.search(rf"^// (inputs  :|         ) {x} +\S.*; {re.escape(unit)}", src, re.M), x
    assert "// output  : E / I in 1/length^2" in src
    assert "length (the unit of d)" in src  # the radius's unit
    assert src == ex.function_source(model, lang, fname)[0]  # the API's two doors agree


FRAME_MODELS = [n for n in area.list_area_models() if n not in {m.name for m in MODELS}]


@pytest.mark.parametrize("name", FRAME_MODELS)
def test_a_frame_models_header_says_what_its_inputs_are(name):
    """The rect and tube models read the receiver in the light's frame, no `d`: their header
    says what each input is (the model class's `input_text`), and names no `d`."""
    cls = area.get_area_model(name)
    assert "d" not in cls.input_names
    src = ex.export(name, "glsl")
    for x in cls.input_names:
        assert re.search(rf"^// (inputs  :|         ) {x} +\S.*; (length|1)$", src, re.M), x
    assert "the unit of d" not in src and "distance from the receiver" not in src
    if "r" in cls.input_names:  # a tube's radius
        assert re.search(r"^// +r +the tube's radius \(across its axis\); length$", src, re.M)


@pytest.mark.parametrize("name", FRAME_MODELS)
def test_a_frame_models_output_line_names_its_own_intensity(name):
    """The header's `output` line states the `I` the model divides by in the light's own
    size names (the class's `output_text`): a rectangle has no `r`, so no `pi r^2`."""
    cls = area.get_area_model(name)
    (line,) = [x for x in ex.export(name, "glsl").splitlines() if x.startswith("// output  :")]
    assert line.startswith("// output  : E / I in 1/length^2 (I: ")
    if cls.light == "rect":
        assert "I = w h L = 4 hw hh L" in line and "pi r^2" not in line
    else:
        assert "I = pi r^2 L, r the tube's radius" in line


def test_the_stated_intensities_are_the_far_field_ones():
    """The `I` each frame header states is the far-field law (E = L A_projected / D^2 for a
    Lambertian emitter of radiance L): far along a rectangle's normal E / I = 1 / D^2 with
    I = w h L; far beside a thin tube (broadside, projected area 2 r l) E / I = 2 r l /
    (pi r^2 D^2) with I = pi r^2 L."""
    hw, hh, hl, r, D = 0.3, 0.2, 0.5, 0.01, 1e3
    rect = area.get_area_model("clipped_rect")()
    e = float(rect.irradiance(0.0, 0.0, D, 0.0, 0.0, -1.0, hw, hh))
    assert e * D**2 == pytest.approx(1.0, rel=1e-6)  # I = w h L
    tube = area.get_area_model("lambert_line")()
    e = float(tube.irradiance(0.0, D, 0.0, 0.0, -1.0, 0.0, hl, r))
    assert e * D**2 == pytest.approx(2 * r * (2 * hl) / (math.pi * r**2), rel=1e-6)


def test_the_header_lists_parameters_and_their_values():
    src = ex.export("hdrp_sphere", "glsl", params={"e": 0.75})
    assert "// params  : a0 = 0.5359050" in src and ", e = 0.75 (baked in)" in src
    assert "const float e = 0.75;" in src
    unif = ex.export(area.UnrealWrap(k=1.25), "c", uniforms=True)
    assert "// params  : k = 1.25 (arguments after g)" in unif
    assert "float cos_n, float g, float k) {" in unif
    clash = ex.export(area.PointLight(af.Yuksel(r=0.05)), "hlsl")
    assert "// params  : r = 0.05 (written r_param) (baked in)" in clash
    assert "const float r_param = 0.05f;" in clash
    assert f"f = yuksel: {comment_safe(af.Yuksel.formula)}" in clash
    assert "// params  : none" in ex.export("vector_disk", "wgsl")


def test_a_fit_of_an_area_model_is_exported_with_its_error():
    class Result:  # duck-typed FitResult
        model = area.GodotWrap(k=0.7)
        metrics: ClassVar = {"max_rel_error": 0.25}
        loss = 0.01
        converged = True

    src = ex.export(Result(), "c")
    assert "const float k = 0.7f;" in src
    assert "// fit     : max_rel_error = 0.25, loss = 0.01, converged = True" in src
    over = ex.export(Result(), "c", params={"k": 0.5})
    assert "const float k = 0.5f;" in over and "max_rel_error" not in over


@pytest.mark.parametrize(
    ("args", "kwargs", "exc", "message"),
    [
        (("vector_disk",), {"form": "stable"}, af.BadValueError, "has no stable form"),
        (("unreal_wrap",), {"family": "x"}, af.BadValueError, "picks one fit of a fit file"),
        (("unreal_wrap",), {"params": {"q": 1.0}}, af.UnknownNameError, "no parameter 'q'"),
        (("unreal_wrap",), {"params": {"k": 1e39}}, af.BadValueError, "not a finite float32"),
        ((area.UnrealWrap(k=np.asarray([1.0, 2.0])),), {}, af.BadValueError, "not a batch"),
        ((area.PointLight(af.Spline()),), {}, af.BadValueError, "(family 'spline' has none)"),
        (("no_such",), {}, af.UnknownNameError, "area models: point_light, snyder_sphere"),
    ],
)
def test_bad_area_exports_raise_one_line_errors(args, kwargs, exc, message):
    with pytest.raises(exc, match=re.escape(message)) as info:
        ex.export(*args, **kwargs)
    assert "\n" not in str(info.value)


# ----------------------------------------------------------------------------- C against JAX
@pytest.fixture(scope="module")
def c_library(tmp_path_factory):
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH: cannot check the C export")
    src = ["#include <math.h>\n"]
    for k, model in enumerate(MODELS):
        src.append(ex.export(model, "c", name=f"baked_{k}"))
        src.append(ex.export(model, "c", name=f"args_{k}", uniforms=True))
        n = len(model.params())
        args = "".join(f", p[{i}]" for i in range(n))
        row = "x[i], x[n + i], x[2 * n + i], x[3 * n + i], x[4 * n + i], x[5 * n + i]"
        src.append(
            f"void many_baked_{k}(const float *x, float *out, int n, const float *p) "
            f"{{ for (int i = 0; i < n; ++i) out[i] = baked_{k}({row}); }}\n"
            f"void many_args_{k}(const float *x, float *out, int n, const float *p) "
            f"{{ for (int i = 0; i < n; ++i) out[i] = args_{k}({row}{args}); }}\n"
        )
    folder = tmp_path_factory.mktemp("c_area_export")
    (folder / "area.c").write_text("\n".join(src))
    lib = folder / "libarea.so"
    cmd = [cc, "-std=c99", "-O2", "-ffp-contract=off", "-fPIC", "-shared", "-Wall", "-Werror",
           "-Wno-unused-parameter", "-o", str(lib), str(folder / "area.c"), "-lm"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return ctypes.CDLL(str(lib))


def _call(lib, symbol: str, x: np.ndarray, params: np.ndarray) -> np.ndarray:
    x = np.ascontiguousarray(x, np.float32)
    out = np.empty(x.shape[1], np.float32)
    p = np.ascontiguousarray(params if params.size else np.zeros(1), np.float32)
    fp = ctypes.POINTER(ctypes.c_float)
    getattr(lib, symbol)(x.ctypes.data_as(fp), out.ctypes.data_as(fp), ctypes.c_int(out.size),
                         p.ctypes.data_as(fp))  # fmt: skip
    return out


#: How far the shader form may be from the JAX model, relative to the facing value 1/max(d, r)^2:
#: the engine's clamps (cosTheta to +-0.999, sin^2 to 0.9999; test_area_forms.py measures
#: them against the reference in float64), plus float32 rounding. Elsewhere: float32 alone
#: (measured: at most 1.2e-6, the clipped sphere's acos and atan; the unguarded vector disk
#: also cancels near the disk's rim, so it is held to float32 from 2 r, above the horizon).
CLAMPED = {"snyder_sphere": 1e-3, "frostbite_disk": 1e-3, "vector_disk": 1e-2}
F32 = 1e-5


def _tolerance(model) -> float:
    if getattr(model, "clip", "cap") == "clamp":  # no cap, no clamps: float32 alone
        return F32
    return CLAMPED.get(model.name, F32)


@pytest.mark.parametrize("k", range(len(MODELS)), ids=NAMES)
def test_c_export_matches_the_jax_model(c_library, k):
    model = MODELS[k]
    x = _inputs_for(model)
    with np.errstate(all="ignore"):
        want = np.asarray(model(*x), np.float64)  # float64: conftest enables x64
    facing = 1 / np.maximum(x[0], x[3]) ** 2
    params = np.asarray([float(np.asarray(v)) for v in model.params().values()], np.float32)
    for symbol in (f"many_baked_{k}", f"many_args_{k}"):
        got = _call(c_library, symbol, x, params).astype(np.float64)
        assert np.all(np.isfinite(got)), (symbol, x[:, ~np.isfinite(got)][:, :3])
        err = np.abs(got - want) / facing
        assert err.max() < _tolerance(model), (model, symbol, err.max())
        # where no clamp engages and the disk is not grazed, float32 alone
        loose = np.abs(x[1]) > 0.99
        if model.name == "vector_disk":
            w = np.sqrt(np.maximum(1 - x[4] ** 2, 0))
            loose |= (x[0] * x[1] < x[3] * w) | (x[0] < 2 * x[3])
        assert err[~loose].max() < F32, (model, symbol, err[~loose].max())


# ----------------------------------------------------------------------------- validators
def _sources(lang: str) -> tuple[str, str]:
    """Every model baked and with uniforms in one unit, and an expression calling them all."""
    parts, calls = [], []
    for k, model in enumerate(MODELS):
        for kind, uniforms in (("baked", False), ("unif", True)):
            parts.append(ex.export(model, lang, name=f"{kind}_{k}", uniforms=uniforms))
            extra = len(model.params()) if uniforms and lang in ("c", "cuda") else 0
            calls.append(f"{kind}_{k}(v, 0.5, 0.5, 0.1, 0.5, 0.5{', 0.7' * extra})")
    return "\n".join(parts), " + ".join(calls)


@pytest.mark.parametrize("version", ["450", "300 es"])
def test_glsl_validates(tmp_path, version):
    tool = _need("glslangValidator")
    es = "es" in version
    head = f"#version {version}\n" + ("precision highp float;\n" if es else "")
    io = (
        "in float v;\nout vec4 o;\n"
        if es
        else "layout(location = 0) in float v;\nlayout(location = 0) out vec4 o;\n"
    )
    body, calls = _sources("glsl")
    (tmp_path / "area.frag").write_text(
        head + io + body + f"void main() {{ o = vec4({calls}); }}\n"
    )
    _run([tool, "area.frag"], tmp_path)


def test_hlsl_compiles_to_valid_spirv(tmp_path):
    _check_hlsl(tmp_path, "area", *_sources("hlsl"))


@pytest.mark.parametrize("tool", ["naga", "tint"])
def test_wgsl_validates(tmp_path, tool):
    _check_wgsl(tmp_path, tool, "area", *_sources("wgsl"))


def test_cuda_compiles_with_nvrtc():
    from attenfit._shaders._compilers import _ptx, compilers

    if not compilers().get("nvrtc"):
        pytest.skip("NVRTC is not installed (the [shader] extra): this compile did not run")
    body, calls = _sources("cuda")
    kernel = f"__global__ void k(const float *x, float *o) {{ float v = x[0]; o[0] = {calls}; }}\n"
    ptx = _ptx(body + kernel).decode()
    assert ".entry" in ptx and "sqrt" in ptx  # the kernel, with the models' roots inlined


# ----------------------------------------------------------------------------- the CLI verb
def test_cli_exports_an_area_model(tmp_path, capsys):
    assert main(["export", "vector_disk", "--lang", "c"]) == 0
    assert capsys.readouterr().out == ex.export("vector_disk", "c")
    target = tmp_path / "wrap.hlsl"
    argv = ["export", "unreal_wrap", "--lang", "hlsl", "--param", "k=1.5", "--name", "wrap"]
    assert main([*argv, "--out", str(target)]) == 0
    assert target.read_text() == ex.export("unreal_wrap", "hlsl", params={"k": 1.5}, name="wrap")
    assert "float wrap(float d, float cos_r" in target.read_text()
    assert main([*argv, "--out", str(target)]) == 2  # exists, no --force
    capsys.readouterr()
    assert main(["export", "mrp_sphere", "--out", str(target), "--force"]) == 0
    assert "attenfit_mrp_sphere" in target.read_text()


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["export", "vector_disk", "--form", "stable"],
            "area model 'vector_disk' has no stable form (form 'stable', --form stable, is a "
            "family's guarded JAX form): export its shader form",
        ),
        (
            ["export", "vector_disk", "--family", "yuksel"],
            "family='yuksel' (--family) picks one fit of a fit file; 'vector_disk' is an area "
            "model, not a fit file",
        ),
        (
            ["export", "unreal_wrap", "--param", "q=1"],
            "area model 'unreal_wrap' has no parameter 'q'; it has ['k']",
        ),
    ],
)
def test_cli_refuses_what_means_nothing_for_an_area_model(argv, message, capsys):
    assert main(argv) == 2
    assert capsys.readouterr().err == f"attenfit: error: {message}\n"


def test_cli_refuses_an_unknown_model_naming_the_known_ones(capsys):
    assert main(["export", "no_such_model"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith("attenfit: error: unknown family 'no_such_model' (nor area model); ")
    for name in [*af.list_families(), *area.list_area_models()]:
        assert name in err


def test_cli_families_lists_the_area_models(capsys):
    assert main(["families", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in listing["area_models"]] == area.list_area_models()
    vd = listing["area_models"][area.list_area_models().index("vector_disk")]
    assert vd["source"] == area.VectorDisk.source and vd["light"] == "disk"
    assert main(["families"]) == 0
    out = capsys.readouterr().out
    assert out.index("inverse_square") < out.index("Area models") < out.index("vector_disk")
    assert "unreal_wrap (lights: sphere)\n" in out and "  params : k=1\n" in out
