"""The stable form of a family printed as GLSL, HLSL, WGSL, C or CUDA: the scalar program
`_trace` reads from the jaxpr, one statement per operation, so the shader computes the same
numerically stable form as the library (Yuksel's `2/(s(s+d))`, the same guards at 0 and at
the range), in float32.

Notes
-----
* C: compile without `-ffast-math` (and, to reproduce JAX bit for bit, with
  `-ffp-contract=off`); the function needs `<math.h>` and `-lm`.
* Infinity (returned by the honestly singular families at `d = 0`) is written as a bit
  pattern (`uintBitsToFloat(0x7F800000u)` in GLSL 3.30+ / ES 3.00, `asfloat(...)` in HLSL,
  a runtime `bitcast<f32>` in WGSL, `INFINITY` in C, `__int_as_float` in CUDA). WGSL
  implementations may assume finite math, so do not rely on infinities there.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import ClassVar

import numpy as np

from ._program import Atom, Const, Op, Program, UnsupportedPrimitiveError, Var
from ._text import float32_literal, ident, uniform_block, uniform_ref

__all__ = ["print_stable"]


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


class _Cuda(_C):
    name = "cuda"

    def inf(self) -> str:
        return "__int_as_float(0x7f800000)"

    def nan(self) -> str:
        return "__int_as_float(0x7fc00000)"

    def rsqrt(self, x: str) -> str:
        return f"rsqrtf({x})"


_CLIKE = ("c", "cuda")
_LANGS: dict[str, _Lang] = {
    "glsl": _Glsl(), "hlsl": _Hlsl(), "wgsl": _Wgsl(), "c": _C(), "cuda": _Cuda()
}  # fmt: skip

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
        return (
            lang.call("abs", a[0]) if not (lang.name in _CLIKE and out == "i32") else f"abs({a[0]})"
        )
    if p in ("max", "min"):
        if lang.name in _CLIKE and out != "f32":
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
    if p in ("expm1", "log1p") and lang.name not in _CLIKE:
        raise UnsupportedPrimitiveError(
            f"{p} has no {lang.name.upper()} built-in; write the family with exp/log"
        )
    if p == "rem" and lang.name not in _CLIKE:
        return f"{a[0]} - {a[1]} * {lang.call('trunc', f'{a[0]} / {a[1]}')}"
    if p in ("sqrt", "cbrt", "exp", "exp2", "log", "tan", "sin", "cos", "atan", "tanh", "pow",
             "floor", "ceil", "round", "expm1", "log1p", "rem"):  # fmt: skip
        if p == "cbrt" and lang.name not in _CLIKE:
            raise UnsupportedPrimitiveError(f"cbrt has no {lang.name.upper()} built-in")
        return lang.call(p, *a)
    raise UnsupportedPrimitiveError(f"no {lang.name.upper()} translation of primitive {p!r}")


def print_stable(
    prog: Program, lang_name: str, fname: str, *, uniforms: bool, header: Sequence[str]
) -> str:
    """The function `fname(d)` of the traced program `prog` in `lang_name`, after `header`."""
    lang = _LANGS[lang_name]
    names: dict[int, str] = {prog.d.id: "d"}
    # parameters: one local per scalar (array parameters: name_0, name_1, ...)
    param_locals: list[tuple[str, Var, float]] = []
    for pname, vars_ in prog.params.items():
        values = prog.values[pname]
        for k, (var, value) in enumerate(zip(vars_, values, strict=True)):
            single = len(vars_) == 1 and prog.shapes[pname] == ()
            local = ident(pname if single else f"{pname}_{k}")
            names[var.id] = local
            param_locals.append((local, var, value))
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
    lines = list(header)
    needs_special = any(
        isinstance(a, Const) and a.dtype == "f32" and not math.isfinite(a.value)
        for a in [*(x for op in prog.ops for x in op.args), prog.output]
    )
    param_lines: list[str] = []
    active = [p for p in param_locals if p[1].id in used]
    sig_extra: list[str] = []
    if uniforms:
        lines += uniform_block(lang.name, fname, [p[0].rstrip("_") for p in param_locals])
        if lang.name in _CLIKE:
            sig_extra = [f"float {p[0]}" for p in param_locals]
        else:
            for local, _, _ in active:
                ref_u = uniform_ref(lang.name, fname, local.rstrip("_"))
                param_lines.append(lang.decl(local, "f32", ref_u))
    else:
        for local, _, value in active:
            param_lines.append(lang.decl(local, "f32", lang.float_lit(value)))
    if lang.name == "wgsl":
        lines.append(f"fn {fname}({', '.join(['d: f32', *sig_extra])}) -> f32 {{")
        if needs_special:
            param_lines = [
                "let af_inf_bits: u32 = 0x7F800000u;",
                "let af_inf: f32 = bitcast<f32>(af_inf_bits);",
                "let af_nan: f32 = bitcast<f32>(af_inf_bits | 0x00400000u);",
                *param_lines,
            ]
    else:
        prefix = "__device__ " if lang.name == "cuda" else ""
        lines.append(f"{prefix}float {fname}({', '.join(['float d', *sig_extra])}) {{")
    lines += ["    " + s for s in [*param_lines, *body, f"return {result};"]]
    lines.append("}")
    return "\n".join(lines) + "\n"
