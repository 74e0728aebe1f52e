"""A (fitted) family as a self-contained GLSL, HLSL, WGSL or C function.

The function is generated from the expression the JAX code evaluates, not from a template
per family: `attenfit._shaders._trace.trace` reads the jaxpr of `family(d)` for a float32 scalar `d`
and this module prints one statement per scalar equation. The shader therefore computes
the same numerically stable form as the library (Yuksel's `2/(s(s+d))`, not the cancelling
`2/r^2 (1 - d/s)`; the same guards at 0 and at the range), in float32.

Parameters are baked in as float32 literals that round-trip exactly (the shortest decimal
that reads back as the same float32), or, with `uniforms=True`, read from uniforms (GLSL
`uniform`, an HLSL `cbuffer`, a WGSL uniform-buffer struct) or, in C, passed as extra
arguments. A header comment cites the family's source and formula and, for a fit, its
error.

Notes
-----
* C: compile without `-ffast-math` (and, to reproduce JAX bit for bit, with
  `-ffp-contract=off`); the function needs `<math.h>` and `-lm`.
* Infinity (returned by the honestly singular families at `d = 0`) is written as a bit
  pattern (`uintBitsToFloat(0x7F800000u)` in GLSL 3.30+ / ES 3.00, `asfloat(...)` in HLSL,
  a runtime `bitcast<f32>` in WGSL, `INFINITY` in C). WGSL implementations may assume
  finite math, so do not rely on infinities there.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from .._curves import Family, get_family
from .._errors import BadTypeError, BadValueError, DataFileError, UnknownNameError
from .._version import __version__
from ._program import Atom, Const, Op, Program, UnsupportedPrimitiveError, Var
from ._trace import trace

#: The target languages of `export`.
LANGUAGES = ("glsl", "hlsl", "wgsl", "c")


# ----------------------------------------------------------------------------- the model
def load_model(source: Any, *, family: str | None = None) -> tuple[Family, dict[str, Any]]:
    """Resolve what `export` accepts into `(family instance, fit information)`.

    `source` is a `Family` instance or class, a registered family name, a `FitResult`
    (anything with a `model` that is a `Family`), a dict as written by
    `FitResult.to_dict()` (a family name under "family" and parameter values under
    "params"), a list of such dicts, or the path of such a JSON file (`attenfit fit --out
    DIR` writes `DIR/fits.json`; the folder is accepted too). When the source holds several
    fits, `family` names the one to use. The fit information is empty except for a fit,
    where it holds what the fit reported (metrics, loss, converged, configuration, file).
    """
    if isinstance(source, Family):
        return source, {}
    if isinstance(source, type) and issubclass(source, Family):
        return source(), {}
    if isinstance(source, str | os.PathLike) and (
        str(source).endswith(".json") or os.sep in str(source) or Path(source).exists()
    ):
        path = Path(source)
        if path.is_dir():
            path = path / "fits.json"
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except FileNotFoundError:
            raise DataFileError(f"fit file {str(path)!r} does not exist") from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise DataFileError(f"fit file {str(path)!r} is not readable JSON: {exc}") from None
        model, info = _from_dict(data, where=f"fit file {str(path)!r}", family=family)
        info["file"] = str(path)
        return model, info
    if isinstance(source, str):
        return get_family(source)(), {}
    if isinstance(source, Mapping | list):
        return _from_dict(source, where="fit dict", family=family)
    model = getattr(source, "model", None)
    if isinstance(model, Family):
        info = {
            key: _plain(getattr(source, key))
            for key in ("metrics", "loss", "converged")
            if getattr(source, key, None) is not None
        }
        return model, info
    raise BadTypeError(
        "export takes a Family, a family name, a FitResult, a FitResult.to_dict() dict or a "
        f"FIT.json path, got {type(source).__name__}"
    )


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    arr = np.asarray(value)
    if arr.dtype.kind in "fiub":
        return arr.item() if arr.ndim == 0 else arr.tolist()
    return value


def _from_dict(
    data: Any, *, where: str, family: str | None = None
) -> tuple[Family, dict[str, Any]]:
    if isinstance(data, Mapping) and isinstance(data.get("fits"), list):
        data = data["fits"]
    if isinstance(data, list):
        names = [d.get("family") if isinstance(d, Mapping) else None for d in data]
        if family is not None:
            if family not in names:
                raise UnknownNameError(f"{where} holds no fit of family {family!r}; it has {names}")
            data = data[names.index(family)]
        elif len(data) != 1:
            raise BadValueError(
                f"{where} holds {len(data)} fits ({', '.join(map(str, names))}); name one "
                "(family=..., or --family on the command line)"
            )
        else:
            data = data[0]
    if not isinstance(data, Mapping):
        raise DataFileError(f"{where} is not a fit result (expected a JSON object)")
    name = data.get("family", data.get("model"))
    if isinstance(name, Mapping):
        name = name.get("name")
    if not isinstance(name, str):
        raise DataFileError(f"{where} names no family (expected a string under 'family')")
    try:
        cls = get_family(name)
    except UnknownNameError as exc:
        raise DataFileError(f"{where}: {exc}") from None
    params = data.get("params", {})
    if not isinstance(params, Mapping):
        raise DataFileError(f"{where}: 'params' must be an object of parameter values")
    try:
        model = cls().replace(**{k: _param_value(v, k, where) for k, v in params.items()})
    except UnknownNameError as exc:
        raise DataFileError(f"{where}: {exc}") from None
    info = {
        k: _plain(data[k]) for k in ("metrics", "loss", "converged", "configuration") if k in data
    }
    return model, info


def _param_value(value: Any, name: str, where: str) -> Any:
    arr = np.asarray(value)
    if arr.dtype.kind not in "fi" or not np.all(np.isfinite(arr)):
        raise DataFileError(f"{where}: parameter {name}={value!r} is not a finite number")
    return float(arr) if arr.ndim == 0 else arr.astype(np.float64)


# ----------------------------------------------------------------------------- literals
def float32_literal(value: float) -> str:
    """The shortest decimal text that reads back as the same float32 (no suffix).

    Always contains a `.` (so it is a float literal in every target language); uses
    an exponent outside [1e-4, 1e7). Not for infinities or NaN.
    """
    x = np.float32(value)
    if not np.isfinite(x):
        raise BadValueError(f"float32_literal needs a finite value, got {value!r}")
    mag = abs(float(x))
    if mag != 0.0 and (mag < 1e-4 or mag >= 1e7):
        text = np.format_float_scientific(x, unique=True, trim="0")
        mantissa, exp = text.split("e")
        if "." not in mantissa:
            mantissa += ".0"
        text = f"{mantissa}e{int(exp)}"
    else:
        text = np.format_float_positional(x, unique=True, trim="0")
        if "." not in text:
            text += ".0"
    assert np.float32(text) == x or (x == 0 and float(text) == 0), (value, text)
    return text


# ----------------------------------------------------------------------------- languages
_KEYWORDS = {
    "d", "in", "out", "inout", "input", "output", "range", "sample", "filter", "half",
    "fixed", "common", "active", "partition", "precise", "patch", "smooth", "flat", "target",
    "buffer", "shared", "uniform", "layout", "struct", "float", "int", "bool", "if", "else",
    "for", "while", "do", "return", "const", "static", "let", "var", "fn", "loop", "switch",
    "case", "default", "break", "continue", "true", "false", "void", "double", "long", "short",
    "char", "unsigned", "signed", "auto", "register", "extern", "volatile", "inline", "main",
    "texture", "sampler", "vec2", "vec3", "vec4", "packed", "linear", "centroid", "line",
    "point", "triangle", "matrix", "vector", "string", "min", "max", "mix", "step", "select",
    "override", "enable", "requires", "alias", "handle", "module", "type", "self", "super",
    "this", "unsafe", "where", "as", "asm", "export", "import", "new", "delete", "private",
    "public", "protected", "namespace", "template", "typedef", "typename", "union", "using",
    "virtual", "discard", "kernel", "writeonly", "readonly", "resource", "goto", "sizeof",
}  # fmt: skip


class _Lang:
    """How one target language spells types, literals, calls and declarations."""

    name = ""
    comment = "//"
    types: ClassVar[Mapping[str, str]] = {"f32": "float", "i32": "int", "bool": "bool"}
    float_suffix = ""
    int_suffix = ""
    fns: ClassVar[Mapping[str, str]] = {}

    def float_lit(self, x: float) -> str:
        if math.isnan(x):
            return self.nan()
        if math.isinf(x):
            return self.inf() if x > 0 else f"(-{self.inf()})"
        text = float32_literal(x) + self.float_suffix
        return f"({text})" if text.startswith("-") else text

    def lit(self, c: Const) -> str:
        if c.dtype == "f32":
            return self.float_lit(c.value)
        if c.dtype == "i32":
            text = f"{int(c.value)}{self.int_suffix}"
            return f"({text})" if c.value < 0 else text
        return self.bool_lit(bool(c.value))

    def bool_lit(self, b: bool) -> str:
        return "true" if b else "false"

    def inf(self) -> str:
        raise NotImplementedError

    def nan(self) -> str:
        raise NotImplementedError

    def call(self, fn: str, *args: str) -> str:
        return f"{self.fns.get(fn, fn)}({', '.join(args)})"

    def select(self, pred: str, if_false: str, if_true: str) -> str:
        return f"({pred} ? {if_true} : {if_false})"

    def convert(self, x: str, to: str) -> str:
        return f"{self.types[to]}({x})"

    def is_finite(self, x: str) -> str:
        return f"(abs({x}) <= {self.float_lit(float(np.finfo(np.float32).max))})"

    def sign(self, x: str) -> str:
        return self.call("sign", x)

    def decl(self, var: str, dtype: str, expr: str) -> str:
        return f"{self.types[dtype]} {var} = {expr};"

    def rsqrt(self, x: str) -> str:
        return self.call("rsqrt", x)

    def atan2(self, y: str, x: str) -> str:
        return self.call("atan2", y, x)


class _Glsl(_Lang):
    name = "glsl"

    def inf(self) -> str:
        return "uintBitsToFloat(0x7F800000u)"

    def nan(self) -> str:
        return "uintBitsToFloat(0x7FC00000u)"

    def rsqrt(self, x: str) -> str:
        return self.call("inversesqrt", x)

    def atan2(self, y: str, x: str) -> str:
        return self.call("atan", y, x)


class _Hlsl(_Lang):
    name = "hlsl"
    float_suffix = "f"

    def inf(self) -> str:
        return "asfloat(0x7F800000u)"

    def nan(self) -> str:
        return "asfloat(0x7FC00000u)"

    def convert(self, x: str, to: str) -> str:
        return f"(({self.types[to]}){x})"

    def sign(self, x: str) -> str:
        return f"((float)sign({x}))"  # HLSL's sign returns int


class _Wgsl(_Lang):
    name = "wgsl"
    types: ClassVar[Mapping[str, str]] = {"f32": "f32", "i32": "i32", "bool": "bool"}
    float_suffix = "f"
    int_suffix = "i"

    def inf(self) -> str:
        return "af_inf"  # a runtime `let`: a constant infinity is a WGSL shader-creation error

    def nan(self) -> str:
        return "af_nan"

    def select(self, pred: str, if_false: str, if_true: str) -> str:
        return f"select({if_false}, {if_true}, {pred})"

    def decl(self, var: str, dtype: str, expr: str) -> str:
        return f"let {var}: {self.types[dtype]} = {expr};"

    def rsqrt(self, x: str) -> str:
        return self.call("inverseSqrt", x)


class _C(_Lang):
    name = "c"
    types: ClassVar[Mapping[str, str]] = {"f32": "float", "i32": "int", "bool": "int"}
    float_suffix = "f"
    fns: ClassVar[Mapping[str, str]] = {
        "sqrt": "sqrtf", "exp": "expf", "exp2": "exp2f", "log": "logf", "tan": "tanf",
        "sin": "sinf", "cos": "cosf", "atan": "atanf", "atan2": "atan2f", "tanh": "tanhf",
        "pow": "powf", "abs": "fabsf", "floor": "floorf", "ceil": "ceilf", "round": "roundf",
        "min": "fminf", "max": "fmaxf", "expm1": "expm1f", "log1p": "log1pf", "cbrt": "cbrtf",
        "rem": "fmodf",
    }  # fmt: skip

    def inf(self) -> str:
        return "INFINITY"

    def nan(self) -> str:
        return "NAN"

    def bool_lit(self, b: bool) -> str:
        return "1" if b else "0"

    def convert(self, x: str, to: str) -> str:
        return f"(({self.types[to]}){x})"

    def is_finite(self, x: str) -> str:
        return f"isfinite({x})"

    def sign(self, x: str) -> str:
        return f"((float)(({x} > 0.0f) - ({x} < 0.0f)))"

    def decl(self, var: str, dtype: str, expr: str) -> str:
        return f"const {self.types[dtype]} {var} = {expr};"

    def rsqrt(self, x: str) -> str:
        return f"(1.0f / sqrtf({x}))"


_LANGS: dict[str, _Lang] = {"glsl": _Glsl(), "hlsl": _Hlsl(), "wgsl": _Wgsl(), "c": _C()}

_BINARY = {"add": "+", "sub": "-", "mul": "*", "div": "/", "lt": "<", "le": "<=", "gt": ">",
           "ge": ">=", "eq": "==", "ne": "!="}  # fmt: skip


def _expr(lang: _Lang, op: Op, a: list[str]) -> str:
    """The right-hand side of one statement."""
    p, out = op.prim, op.out.dtype
    if p in _BINARY:
        return f"{a[0]} {_BINARY[p]} {a[1]}"
    if p in ("and", "or"):
        bool_op = "&&" if p == "and" else "||"
        return f"{a[0]} {bool_op if out == 'bool' else ('&' if p == 'and' else '|')} {a[1]}"
    if p == "not":
        return f"!{a[0]}" if out == "bool" else f"~{a[0]}"
    if p == "neg":
        return f"-{a[0]}"
    if p == "abs":
        return lang.call("abs", a[0]) if not (lang.name == "c" and out == "i32") else f"abs({a[0]})"
    if p in ("max", "min"):
        if lang.name == "c" and out != "f32":
            cmp = ">" if p == "max" else "<"
            return f"({a[0]} {cmp} {a[1]} ? {a[0]} : {a[1]})"
        return lang.call(p, a[0], a[1])
    if p == "clamp":  # lax.clamp(lo, x, hi) = min(max(x, lo), hi), also when lo > hi
        return lang.call("min", lang.call("max", a[1], a[0]), a[2])
    if p == "select_n":
        pred, *cases = a
        if len(cases) == 1:
            return cases[0]
        if op.args[0].dtype == "bool":
            return lang.select(pred, cases[0], cases[1])
        expr = cases[-1]
        for k in range(len(cases) - 2, -1, -1):
            expr = lang.select(f"{pred} == {lang.lit(Const(k, 'i32'))}", expr, cases[k])
        return expr
    if p == "convert":
        return lang.convert(a[0], out)
    if p == "is_finite":
        return lang.is_finite(a[0])
    if p == "sign":
        return lang.sign(a[0])
    if p == "rsqrt":
        return lang.rsqrt(a[0])
    if p == "atan2":
        return lang.atan2(a[0], a[1])
    if p == "logistic":
        one = lang.float_lit(1.0)
        return f"{one} / ({one} + {lang.call('exp', '-' + a[0])})"
    if p in ("expm1", "log1p") and lang.name != "c":
        raise UnsupportedPrimitiveError(
            f"{p} has no {lang.name.upper()} built-in; write the family with exp/log"
        )
    if p == "rem" and lang.name != "c":
        return f"{a[0]} - {a[1]} * {lang.call('trunc', f'{a[0]} / {a[1]}')}"
    if p in ("sqrt", "cbrt", "exp", "exp2", "log", "tan", "sin", "cos", "atan", "tanh", "pow",
             "floor", "ceil", "round", "expm1", "log1p", "rem"):  # fmt: skip
        if p == "cbrt" and lang.name != "c":
            raise UnsupportedPrimitiveError(f"cbrt has no {lang.name.upper()} built-in")
        return lang.call(p, *a)
    raise UnsupportedPrimitiveError(f"no {lang.name.upper()} translation of primitive {p!r}")


def _ident(name: str) -> str:
    return f"{name}_" if name in _KEYWORDS else name


def export(
    model: Any,
    lang: str = "glsl",
    *,
    uniforms: bool = False,
    name: str | None = None,
    params: Mapping[str, Any] | None = None,
    family: str | None = None,
) -> str:
    """A self-contained `lang` function `float name(float d)` evaluating the (fitted) family.

    Parameters
    ----------
    model
        A `Family` (instance or class), a registered family name, a `FitResult`, a
        `FitResult.to_dict()` dict, or the path of a FIT.json (see `load_model`).
    lang
        "glsl", "hlsl", "wgsl" or "c".
    uniforms
        Read the parameters from uniforms (C: extra float arguments after `d`) instead of
        baking them in as float32 literals.
    name
        The function's name (an identifier); default `attenfit_<family>`.
    params
        Parameter values that replace the model's (a fit's error no longer applies then
        and is not quoted).
    family
        Which fit to export when `model` holds several (a FIT.json of many families).

    Returns
    -------
    The source text; `d` is the distance from the light's centre and the result is the
    attenuation in 1/length^2 (float32), exactly the expression `family(d)` evaluates in JAX.
    """
    if lang not in _LANGS:
        raise UnknownNameError(f"unknown language {lang!r}; choose one of {list(LANGUAGES)}")
    fam, info = load_model(model, family=family)
    if params:
        fam = fam.replace(**{k: _param_value(v, k, "params") for k, v in params.items()})
        if info:
            info = {"note": "parameters overridden after the fit; its error does not apply"}
    fname = name if name is not None else f"attenfit_{fam.name}"
    if not (isinstance(fname, str) and fname.isidentifier() and fname.isascii()):
        raise BadValueError(f"function name {fname!r} is not an ASCII identifier")
    return _emit(trace(fam), fam, info, _LANGS[lang], fname, uniforms)


def _emit(
    prog: Program, family: Family, info: dict[str, Any], lang: _Lang, fname: str, uniforms: bool
) -> str:
    names: dict[int, str] = {prog.d.id: "d"}
    # parameters: one local per scalar (array parameters: name_0, name_1, ...)
    param_locals: list[tuple[str, Var, float, str]] = []  # (local, var, value, uniform name)
    for pname, vars_ in prog.params.items():
        values = prog.values[pname]
        for k, (var, value) in enumerate(zip(vars_, values, strict=True)):
            local = _ident(
                pname if len(vars_) == 1 and prog.shapes[pname] == () else f"{pname}_{k}"
            )
            names[var.id] = local
            param_locals.append((local, var, value, f"{fname}_{local.rstrip('_')}"))
    used = {a.id for op in prog.ops for a in op.args if isinstance(a, Var)}
    if isinstance(prog.output, Var):
        used.add(prog.output.id)

    def ref(a: Atom) -> str:
        return lang.lit(a) if isinstance(a, Const) else names[a.id]

    body: list[str] = []
    for i, op in enumerate(prog.ops):
        names[op.out.id] = f"t{i}"
        body.append(lang.decl(f"t{i}", op.out.dtype, _expr(lang, op, [ref(a) for a in op.args])))
    result = ref(prog.output)

    c = lang.comment
    lines = [
        f"{c} {line}" if line else c for line in _header(prog, family, info, lang, fname, uniforms)
    ]
    needs_special = any(
        isinstance(a, Const) and a.dtype == "f32" and not math.isfinite(a.value)
        for a in [*(x for op in prog.ops for x in op.args), prog.output]
    )
    param_lines: list[str] = []
    active = [p for p in param_locals if p[1].id in used]
    if uniforms:
        lines += _uniform_block(lang, fname, [p for p in param_locals], active)
        sig_extra = [f"float {p[0]}" for p in param_locals] if lang.name == "c" else []
        if lang.name != "c":
            for local, _, _, uname in active:
                ref_u = f"{fname}_params.{local.rstrip('_')}" if lang.name == "wgsl" else uname
                param_lines.append(lang.decl(local, "f32", ref_u))
    else:
        sig_extra = []
        for local, _, value, _ in active:
            param_lines.append(lang.decl(local, "f32", lang.float_lit(value)))
    if lang.name == "wgsl":
        args = ", ".join(["d: f32", *sig_extra])
        lines.append(f"fn {fname}({args}) -> f32 {{")
        if needs_special:
            param_lines = [
                "let af_inf_bits: u32 = 0x7F800000u;",
                "let af_inf: f32 = bitcast<f32>(af_inf_bits);",
                "let af_nan: f32 = bitcast<f32>(af_inf_bits | 0x00400000u);",
                *param_lines,
            ]
    else:
        args = ", ".join(["float d", *sig_extra])
        lines.append(f"float {fname}({args}) {{")
    lines += ["    " + s for s in [*param_lines, *body, f"return {result};"]]
    lines.append("}")
    return "\n".join(lines) + "\n"


def _uniform_block(lang: _Lang, fname: str, all_params: list, active: list) -> list[str]:
    if not all_params or lang.name == "c":
        return []
    if lang.name == "glsl":
        return [f"uniform float {u};" for _, _, _, u in all_params]
    if lang.name == "hlsl":
        return [
            f"cbuffer {fname}_params {{",
            *(f"    float {u};" for _, _, _, u in all_params),
            "};",
        ]
    struct = f"{fname}_params_t"
    return [
        f"struct {struct} {{",
        *(f"    {local.rstrip('_')}: f32," for local, _, _, _ in all_params),
        "};",
        f"@group(0) @binding(0) var<uniform> {fname}_params: {struct};  // choose your binding",
    ]


def _header(
    prog: Program, family: Family, info: dict[str, Any], lang: _Lang, fname: str, uniforms: bool
) -> list[str]:
    n_ops = len(prog.ops)
    values = ", ".join(
        f"{p} = {float32_literal(v[0]) if prog.shapes[p] == () else '[' + ', '.join(float32_literal(x) for x in v) + ']'}"
        for p, v in prog.values.items()
    )
    where = (
        "uniforms" if uniforms and lang.name != "c" else ("arguments" if uniforms else "baked in")
    )
    lines = [
        f"{fname}(d): light attenuation f(d) in 1/length^2, d = distance from the light's centre.",
        f"family  : {family.name}",
        f"formula : {family.formula}",
        f"source  : {family.source}",
        f"params  : {values or 'none'} ({where})" if values else "params  : none",
    ]
    if info:
        fit = _fit_summary(info)
        lines += [f"fit     : {fit[0]}", *(f"          {line}" for line in fit[1:])]
    lines += [
        f"Generated by attenfit {__version__} from the jaxpr of the JAX implementation",
        f"({n_ops} scalar operations, float32): the same numerically stable form.",
    ]
    if lang.name == "c":
        lines.append("Needs <math.h> (link -lm); compile without -ffast-math.")
    return lines


def _fit_summary(info: dict[str, Any]) -> list[str]:
    """The fit's error (its error metrics, loss, convergence), configuration and file."""
    errors = []
    metrics = info.get("metrics") or {}
    if isinstance(metrics, Mapping):
        for key, value in metrics.items():
            if "err" in key and isinstance(value, int | float) and not isinstance(value, bool):
                errors.append(f"{key} = {value:.3g}")
    if isinstance(info.get("loss"), int | float):
        errors.append(f"loss = {info['loss']:.3g}")
    if "converged" in info:
        errors.append(f"converged = {info['converged']}")
    lines = [", ".join(errors) or "(no error reported)"]
    if "configuration" in info:
        lines.append(f"fitted to {info['configuration']}")
    if "file" in info:
        lines.append(f"from {info['file']}")
    if "note" in info:
        lines.append(info["note"])
    return lines
