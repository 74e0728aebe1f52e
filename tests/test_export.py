"""`attenfit.export`: shader and C source generated from the jaxpr, checked by real compilers.

* C: every registered family is exported (parameters baked in, and as arguments), compiled
  with the system `cc` into one shared library, and evaluated on the stability grid of
  distances; it must agree with JAX's float32 evaluation of the same family to a few ulps.
* GLSL: validated with `glslangValidator` (desktop 4.50 and ES 3.00).
* HLSL: compiled to SPIR-V by `glslangValidator -D` and checked by `spirv-val` when present.
* WGSL: validated with `naga` (naga-cli) and Google's `tint` when present.
A validator that is missing makes its test skip with a reason naming it.
"""

from __future__ import annotations

import ctypes
import json
import platform
import re
import shutil
import subprocess
from typing import ClassVar

import jax
import jax.numpy as jnp
import mpmath
import numpy as np
import pytest
from _tools import check_hlsl as _check_hlsl
from _tools import check_wgsl as _check_wgsl
from _tools import need as _need
from _tools import run as _run

import attenfit
from attenfit import export as ex
from attenfit._shaders import trace

# the library's families (other test modules may register their own test families)
BUILTIN = {getattr(attenfit.families, c).name for c in attenfit.families.__all__}
FAMILIES = [n for n in attenfit.list_families() if n in BUILTIN]
LANGS = ("glsl", "hlsl", "wgsl", "c")

# DESIGN/issue 2's stability grid (d in metres), plus a dense sweep and each window's range.
GRID = [0.0, 1e-30, 1e-12, 1e-6, 1e-3, 0.1, 1.0, 1e3, 1e6, 1e12]


def _grid(family) -> np.ndarray:
    d = [*GRID, *np.geomspace(1e-6, 1e6, 241)]
    for p in family.length_params:
        v = float(np.asarray(getattr(family, p)))
        d += [v, v * (1 - 1e-3), v * (1 + 1e-3), v * 0.5, v * 0.999999]
    return np.asarray(d, np.float32)


def _variants(cls):
    """Default parameters, and every length parameter scaled by 1e-3 and by 1e3."""
    base = cls()
    out = [base]
    if cls.length_params:
        for s in (1e-3, 1e3):
            out.append(
                base.replace(
                    **{p: float(np.asarray(getattr(base, p))) * s for p in cls.length_params}
                )
            )
    return out


def _ulps(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance in float32 units in the last place (0 where both are the same inf or NaN)."""

    def ordered(x):
        i = np.asarray(x, np.float32).view(np.int32).astype(np.int64)
        return np.where(i < 0, -(i & 0x7FFFFFFF), i)

    same = (a == b) | (np.isnan(a) & np.isnan(b))
    return np.where(same, 0, np.abs(ordered(a) - ordered(b)))


def _jax_f32(family, d: np.ndarray) -> np.ndarray:
    fam32 = jax.tree.map(
        lambda x: (
            jnp.asarray(x, jnp.float32)
            if isinstance(x, float)
            or (hasattr(x, "dtype") and jnp.issubdtype(x.dtype, jnp.floating))
            else x
        ),
        family,
    )
    return np.asarray(_eval(fam32, jnp.asarray(d, jnp.float32)))


@jax.jit
def _eval(family, d):
    return family(d)


# ----------------------------------------------------------------------------- C: compile once
@pytest.fixture(scope="module")
def c_library(tmp_path_factory):
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler (cc, gcc or clang) on PATH: cannot check the C export")
    src = ["#include <math.h>\n"]
    for k, name in enumerate(FAMILIES):
        fam = attenfit.get_family(name)()
        src.append(ex.export(fam, "c", name=f"baked_{k}", form="stable"))
        src.append(ex.export(fam, "c", name=f"args_{k}", uniforms=True, form="stable"))
        n_args = sum(len(v) for v in trace(fam).params.values())
        args = "".join(f", p[{i}]" for i in range(n_args))
        src.append(
            f"void many_baked_{k}(const float *d, float *out, int n) "
            f"{{ for (int i = 0; i < n; ++i) out[i] = baked_{k}(d[i]); }}\n"
            f"void many_args_{k}(const float *d, float *out, int n, const float *p) "
            f"{{ for (int i = 0; i < n; ++i) out[i] = args_{k}(d[i]{args}); }}\n"
        )
    folder = tmp_path_factory.mktemp("cexport")
    (folder / "families.c").write_text("\n".join(src))
    lib = folder / "libfamilies.so"
    # XLA's CPU backend fuses multiply-adds where the host has FMA: let cc do the same.
    fma = ["-march=native"] if platform.machine() in ("x86_64", "AMD64") else []
    cmd = [cc, "-std=c99", "-O2", *fma, "-ffp-contract=fast", "-fPIC", "-shared", "-Wall",
           "-Werror", "-o", str(lib), str(folder / "families.c"), "-lm"]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    return ctypes.CDLL(str(lib))


def _call(lib, symbol: str, d: np.ndarray, params: np.ndarray | None = None) -> np.ndarray:
    d = np.ascontiguousarray(d, np.float32)
    out = np.empty_like(d)
    fp = ctypes.POINTER(ctypes.c_float)
    args = [d.ctypes.data_as(fp), out.ctypes.data_as(fp), ctypes.c_int(d.size)]
    if params is not None:
        params = np.ascontiguousarray(params, np.float32)
        args.append(params.ctypes.data_as(fp))
    getattr(lib, symbol)(*args)
    return out


# The C follows the jaxpr operation by operation. XLA then departs from the jaxpr by a few
# ulps: its CPU backend has its own tan/exp/log/pow polynomials (libm's differ), and its
# algebraic simplifier rewrites (a/b)/c into a/(b*c) and x/sqrt(y) into x*rsqrt(y). Measured
# here: most points agree bit for bit, the worst differ by 11 ulps (about 1e-6 relative).
MAX_ULPS = 16
MEDIAN_ULPS = 4  # and typically: half the grid within this


@pytest.mark.parametrize("name", FAMILIES)
def test_c_export_matches_jax_float32(c_library, name):
    k = FAMILIES.index(name)
    cls = attenfit.get_family(name)
    for variant_no, fam in enumerate(_variants(cls)):
        d = _grid(fam)
        want = _jax_f32(fam, d)
        if variant_no == 0:
            got = _call(c_library, f"many_baked_{k}", d)
            ulps = _ulps(got, want)
            assert ulps.max() <= MAX_ULPS, (
                f"{name} baked: {ulps.max()} ulps at d={d[ulps.argmax()]!r}: "
                f"C {got[ulps.argmax()]!r} vs JAX {want[ulps.argmax()]!r}"
            )
            assert np.median(ulps) <= MEDIAN_ULPS, (name, np.median(ulps))
        p = (
            np.concatenate([np.asarray(v, np.float32).reshape(-1) for v in fam.params().values()])
            if fam.params()
            else np.zeros(1, np.float32)
        )
        got = _call(c_library, f"many_args_{k}", d, p)
        ulps = _ulps(got, want)
        assert ulps.max() <= MAX_ULPS, (
            f"{name} {fam.params()}: {ulps.max()} ulps at d={d[ulps.argmax()]!r}: "
            f"C {got[ulps.argmax()]!r} vs JAX {want[ulps.argmax()]!r}"
        )
        assert np.median(ulps) <= MEDIAN_ULPS, (name, fam.params(), np.median(ulps))
        # the honestly singular families return +inf at d = 0; nothing returns NaN
        assert not np.isnan(got).any(), name


def test_c_export_of_yuksel_is_the_stable_form(c_library):
    """Far away, the export keeps Yuksel's eq. 7 accurate where the textbook form cancels."""
    k = FAMILIES.index("yuksel")
    d = np.asarray([1e2, 1e3, 1e4, 1e5], np.float32)  # r = 0.1: d/r up to 1e6
    got = _call(c_library, f"many_baked_{k}", d).astype(np.float64)
    r = float(np.float32(attenfit.get_family("yuksel")().r))
    with mpmath.workdps(60):  # the textbook form, evaluated with enough digits not to cancel
        exact = [float(2 / mpmath.mpf(r) ** 2 * (1 - x / mpmath.sqrt(x**2 + mpmath.mpf(r) ** 2)))
                 for x in map(mpmath.mpf, d.astype(float))]  # fmt: skip
    np.testing.assert_allclose(got, exact, rtol=2e-6)
    # the textbook form in float32 is what the export must not be: it loses everything here
    d32, r32 = d, np.float32(r)
    naive = np.float32(2) / (r32 * r32) * (np.float32(1) - d32 / np.sqrt(d32 * d32 + r32 * r32))
    assert np.all(np.abs(naive / np.asarray(exact) - 1) > 1e-2)


# ----------------------------------------------------------------------------- the text itself
def test_float32_literals_round_trip():
    rng = np.random.default_rng(0)
    values = np.concatenate([
        [0.0, -0.0, 1.0, 0.1, 1e-4, 9.99e-5, 1e7, 3.4028235e38, 1.4e-45, 1.17549435e-38, np.pi],
        (10.0 ** rng.uniform(-40, 38, 500)) * rng.choice([-1, 1], 500),
    ]).astype(np.float32)  # fmt: skip
    for v in values:
        text = ex.float32_literal(v)
        assert np.float32(text) == v and ("." in text), (v, text)
        assert np.signbit(np.float32(text)) == np.signbit(v)
    assert ex.float32_literal(0.1) == "0.1"
    assert ex.float32_literal(1e-30) == "1.0e-30"


def test_inverse_square_exports_one_multiply_and_one_division():
    src = ex.export("inverse_square", "c")
    body = src[src.index("{") :]
    assert body.count(" * ") == 1 and body.count(" / ") == 1, src
    assert "sqrtf" not in body


def test_yuksel_glsl_has_one_sqrt_and_the_stable_form():
    src = ex.export("yuksel", "glsl", form="stable")
    body = src[src.index("{") :]
    assert body.count("sqrt(") == 1
    assert "2.0 /" in body  # 2/(s(s+d)), not 2/r^2 (1 - d/s)
    assert "Yuksel" in src  # the citation in the header


def test_yuksel_shader_form_is_eevees_expression():
    src = ex.export("yuksel", "glsl", params={"r": 0.05})
    body = src[src.index("{") :]
    assert "return 2.0 / (d_sqr + r_sqr + d * sqrt(d_sqr + r_sqr));" in body
    assert "eevee_light_lib.glsl::light_point_light" in src  # the engine cited
    assert "?" not in body and "uintBitsToFloat" not in body  # no guards


def test_header_cites_source_formula_and_parameters():
    fam = attenfit.get_family("unreal_window")()
    src = ex.export(fam, "hlsl")
    assert f"source  : {fam.source}" in src
    assert f"formula : {fam.formula}" in src
    assert f"r_max = {ex.float32_literal(fam.r_max)}" in src


def test_baked_parameters_appear_as_round_tripping_literals():
    fam = attenfit.get_family("yuksel")(r=0.123456789)
    src = ex.export(fam, "wgsl")
    lit = re.search(r"let r: f32 = ([0-9.e+-]+)f;", src).group(1)
    assert np.float32(lit) == np.float32(0.123456789)


def test_uniform_declarations_per_language():
    fam = "unreal_window"
    assert "uniform float attenfit_unreal_window_r_max;" in ex.export(fam, "glsl", uniforms=True)
    assert "cbuffer attenfit_unreal_window_params" in ex.export(fam, "hlsl", uniforms=True)
    w = ex.export(fam, "wgsl", uniforms=True)
    assert "var<uniform> attenfit_unreal_window_params" in w and "r_max: f32," in w
    assert "float attenfit_unreal_window(float d, float eps, float r_max)" in ex.export(
        fam, "c", uniforms=True
    )


def test_fit_dict_and_file_are_accepted(tmp_path):
    fit = {"family": "yuksel", "params": {"r": 0.25}, "metrics": {"max_rel_error": 0.0123},
           "loss": 1e-5, "converged": True}  # fmt: skip
    path = tmp_path / "fit.json"
    path.write_text(json.dumps(fit))
    for source in (fit, str(path), path):
        src = ex.export(source, "glsl")
        assert "float r = 0.25;" in src
        assert "max_rel_error = 0.0123" in src
    overridden = ex.export(fit, "glsl", params={"r": 0.5})
    assert "float r = 0.5;" in overridden and "max_rel_error" not in overridden


def test_fitresult_like_objects_are_accepted():
    class Result:  # duck-typed FitResult
        model = attenfit.get_family("clamped")(r_min=0.2)
        metrics: ClassVar = {"max_rel_error": 0.5}
        loss = 0.1
        converged = True

    src = ex.export(Result(), "c")
    assert "r_min = 0.2f" in src and "max_rel_error = 0.5" in src


@pytest.mark.parametrize(
    ("args", "kwargs", "exc", "message"),
    [
        (("yuksel", "fortran"), {}, attenfit.UnknownNameError, "unknown language 'fortran'"),
        (("yuksel",), {"form": "fast"}, attenfit.UnknownNameError, "unknown form 'fast'"),
        (
            ("no_such_family",),
            {},
            attenfit.UnknownNameError,
            "unknown family 'no_such_family' (nor area model)",
        ),
        (("yuksel",), {"name": "2bad"}, attenfit.BadValueError, "function name '2bad'"),
        (("yuksel",), {"params": {"q": 1.0}}, attenfit.UnknownNameError, "no parameter 'q'"),
        ((42,), {}, attenfit.BadTypeError, "export takes a Family"),
        (("yuksel",), {"params": {"r": [0.1, 0.2]}}, attenfit.BadValueError, "not a batch"),
        (({"params": {}},), {}, attenfit.DataFileError, "names no family"),
    ],
)
def test_bad_arguments_raise_one_line_errors(args, kwargs, exc, message):
    with pytest.raises(exc, match=re.escape(message)):
        ex.export(*args, **kwargs)


def test_unsupported_primitive_is_named():
    class Erf(attenfit.Family):
        name = "erf_test"
        formula = "erf(d)"
        source = "test"
        default_free = ()
        shader_form = attenfit.no_shader_form

        def __call__(self, d):
            return jax.scipy.special.erf(jnp.asarray(d))

    with pytest.raises(ex.UnsupportedPrimitiveError, match="'erf'"):
        ex.export(Erf(), "glsl")


def test_missing_fit_file_is_a_data_file_error(tmp_path):
    with pytest.raises(attenfit.DataFileError, match="does not exist"):
        ex.export(str(tmp_path / "nope.json"))
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(attenfit.DataFileError, match="not valid JSON"):
        ex.export(bad)


# ----------------------------------------------------------------------------- validators
def _sources(lang: str) -> str:
    """Every family in both forms, baked and with uniforms, as one translation unit."""
    parts = []
    for k, name in enumerate(FAMILIES):
        for form in ex.FORMS:
            parts.append(ex.export(name, lang, name=f"baked_{form}_{k}", form=form))
            parts.append(ex.export(name, lang, name=f"unif_{form}_{k}", uniforms=True, form=form))
    return "\n".join(parts)


def _calls(lang: str) -> str:
    if lang == "c":
        return ""
    return " + ".join(
        f"baked_{f}_{k}(v) + unif_{f}_{k}(v)" for k in range(len(FAMILIES)) for f in ex.FORMS
    )


@pytest.mark.parametrize("version", ["450", "300 es"])
def test_glsl_validates(tmp_path, version):
    tool = _need("glslangValidator")
    prelude = (
        f"#version {version}\nprecision highp float;\n"
        if "es" in version
        else f"#version {version}\n"
    )
    io = (
        "in float v;\nout vec4 o;\n"
        if "es" in version
        else "layout(location = 0) in float v;\nlayout(location = 0) out vec4 o;\n"
    )
    src = prelude + io + _sources("glsl") + f"void main() {{ o = vec4({_calls('glsl')}); }}\n"
    (tmp_path / "all.frag").write_text(src)
    _run([tool, "all.frag"], tmp_path)


def test_glsl_validator_catches_errors(tmp_path):
    """The validation is not vacuous: a wrong call is refused."""
    tool = _need("glslangValidator")
    (tmp_path / "bad.frag").write_text(
        "#version 450\nfloat f(float d) { return atan2(d, d); }\nvoid main() {}\n"
    )
    proc = subprocess.run([tool, "bad.frag"], capture_output=True, text=True, cwd=tmp_path)
    assert proc.returncode != 0


def test_hlsl_compiles_to_valid_spirv(tmp_path):
    _check_hlsl(tmp_path, "all", _sources("hlsl"), _calls("hlsl"))


@pytest.mark.parametrize("tool", ["naga", "tint"])
def test_wgsl_validates(tmp_path, tool):
    _check_wgsl(tmp_path, tool, "all", _sources("wgsl"), _calls("wgsl"))


# ----------------------------------------------------------------------------- the CLI verb
def test_cli_export_prints_and_writes(tmp_path, capsys):
    from attenfit.cli import main

    assert main(["export", "yuksel", "--lang", "c", "--param", "r=0.25"]) == 0
    out = capsys.readouterr().out
    assert out == ex.export("yuksel", "c", params={"r": 0.25})
    target = tmp_path / "y.glsl"
    assert main(["export", "yuksel", "--uniforms", "--out", str(target)]) == 0
    assert target.read_text() == ex.export("yuksel", "glsl", uniforms=True)
    assert main(["export", "yuksel", "--out", str(target)]) == 2  # exists, no --force
    err = capsys.readouterr().err
    assert f"attenfit: error: output file '{target}' exists; use --force to overwrite it" in err
    assert main(["export", "clamped", "--out", str(target), "--force"]) == 0
    assert "attenfit_clamped" in target.read_text()


def test_cli_export_of_a_fit_file(tmp_path, capsys):
    from attenfit.cli import main

    fits = [
        {"family": "yuksel", "params": {"r": 0.2}, "metrics": {"max_rel_error": 0.03}},
        {"family": "clamped", "params": {"r_min": 0.3}, "metrics": {"max_rel_error": 0.5}},
    ]
    path = tmp_path / "fits.json"
    path.write_text(json.dumps(fits))
    assert main(["export", str(path), "--family", "clamped", "--lang", "wgsl"]) == 0
    out = capsys.readouterr().out
    assert "let r_min: f32 = 0.3f;" in out and "max_rel_error = 0.5" in out
    assert main(["export", str(tmp_path), "--family", "yuksel"]) == 0  # the --out folder
    assert "float r = 0.2;" in capsys.readouterr().out
    assert main(["export", str(path)]) == 2
    assert capsys.readouterr().err == (
        f"attenfit: error: fit file '{path}' holds 2 fits (yuksel, clamped); name one "
        "(family=..., or --family on the command line)\n"
    )


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (
            ["export", "yuksel", "--lang", "fortran"],
            "--lang must be one of glsl, hlsl, wgsl, c, cuda, got 'fortran'",
        ),
        (["export", "yuksel", "--param", "r"], "--param must be NAME=NUMBER, got 'r'"),
        (
            ["export", "yuksel", "--param", "q=1"],
            "family 'yuksel' has no parameter 'q'; it has ['r']",
        ),
        (["export", "yuksel", "--name", "a-b"], "function name 'a-b' is not an ASCII identifier"),
    ],
)
def test_cli_export_errors(argv, message, capsys):
    from attenfit.cli import main

    assert main(argv) == 2
    assert capsys.readouterr().err == f"attenfit: error: {message}\n"


def test_a_real_fit_result_is_exported_with_its_error():
    d = np.geomspace(0.01, 2.0, 64)
    target = 1 / (d * d + 0.1**2)  # the facing disk of radius 0.1 (closed form)
    res = attenfit.fit(attenfit.get_family("yuksel")(), d, target)
    src = ex.export(res, "c")
    r = float(np.float32(res.params["r"]))
    assert f"const float r = {ex.float32_literal(r)}f;" in src
    assert f"max_rel_error = {res.metrics['max_rel_error']:.3g}" in src
    assert f"converged = {res.converged}" in src
    again = ex.export(res.to_dict(), "c")  # what `attenfit fit --out` writes
    assert again[again.index("{") :] == src[src.index("{") :]
