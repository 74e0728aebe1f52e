"""A `ShaderForm` printed as GLSL, HLSL, WGSL, C or CUDA: named temporaries, the
languages' own `clamp`/`saturate`/`max`, parentheses only where precedence or the order of
evaluation needs them."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from .._ir import Call, Expr, Num, Ref, ShaderForm
from ._text import float32_literal, ident, uniform_block, uniform_ref

__all__ = ["print_form"]

_BINARY = {"add": ("+", 3), "sub": ("-", 3), "mul": ("*", 4), "div": ("/", 4),
           "lt": ("<", 2), "le": ("<=", 2), "gt": (">", 2), "ge": (">=", 2)}  # fmt: skip
_SUFFIX = {"glsl": "", "hlsl": "f", "wgsl": "f", "c": "f", "cuda": "f"}
_CFN = {"sqrt": "sqrtf", "pow": "powf", "exp": "expf", "log": "logf", "tan": "tanf",
        "cos": "cosf", "min": "fminf", "max": "fmaxf", "abs": "fabsf", "atan": "atanf",
        "acos": "acosf", "atan2": "atan2f"}  # fmt: skip


class _Printer:
    def __init__(self, lang: str, names: Mapping[str, str]) -> None:
        self.lang = lang
        self.names = names  # parameter and temporary names as printed

    def num(self, x: float) -> str:
        text = float32_literal(x) + _SUFFIX[self.lang]
        return f"({text})" if text.startswith("-") else text

    def call(self, name: str, *args: str) -> str:
        if self.lang in ("c", "cuda"):
            name = _CFN.get(name, name)
        elif name == "rsqrt":
            name = {"glsl": "inversesqrt", "wgsl": "inverseSqrt"}.get(self.lang, name)
        elif name == "atan2" and self.lang == "glsl":
            name = "atan"  # GLSL's two-argument atan is atan2
        return f"{name}({', '.join(args)})"

    def expr(self, e: Expr) -> tuple[str, int]:
        """The text of `e` and its precedence (6: an atom or a call)."""
        if isinstance(e, Num):
            return self.num(e.value), 6
        if isinstance(e, Ref):
            return (e.name if e.kind == "d" else self.names[e.name]), 6
        assert isinstance(e, Call)
        if e.op in _BINARY:
            sym, prec = _BINARY[e.op]
            left, lp = self.expr(e.args[0])
            right, rp = self.expr(e.args[1])
            left = left if lp >= prec else f"({left})"
            right = right if rp > prec else f"({right})"  # keeps the order of evaluation
            return f"{left} {sym} {right}", prec
        args = [self.expr(a)[0] for a in e.args]
        if e.op == "neg":
            text, prec = self.expr(e.args[0])
            return (f"-{text}" if prec == 6 else f"-({text})"), 5
        if e.op == "select":
            if self.lang == "wgsl":
                return f"select({args[2]}, {args[1]}, {args[0]})", 6
            return f"({args[0]} ? {args[1]} : {args[2]})", 6
        if e.op == "saturate":
            if self.lang in ("hlsl", "wgsl"):
                return f"saturate({args[0]})", 6
            if self.lang == "cuda":
                return f"__saturatef({args[0]})", 6
            return self._clamp(args[0], self.num(0.0), self.num(1.0)), 6
        if e.op == "clamp":
            return self._clamp(*args), 6
        if e.op == "rsqrt" and self.lang == "c":
            return f"(1.0f / sqrtf({args[0]}))", 6
        if e.op == "rsqrt" and self.lang == "cuda":
            return f"rsqrtf({args[0]})", 6
        return self.call(e.op, *args), 6

    def _clamp(self, x: str, lo: str, hi: str) -> str:
        if self.lang in ("c", "cuda"):
            return f"fminf(fmaxf({x}, {lo}), {hi})"
        return f"clamp({x}, {lo}, {hi})"

    def decl(self, name: str, text: str, *, const: bool = False) -> str:
        if self.lang == "wgsl":
            return f"let {name}: f32 = {text};"
        if self.lang in ("c", "cuda") or const:
            return f"const float {name} = {text};"
        return f"float {name} = {text};"


def print_form(
    form: ShaderForm,
    lang: str,
    fname: str,
    values: Mapping[str, float],
    *,
    uniforms: bool,
    header: Sequence[str],
) -> str:
    """The function `fname(d)` of `form` in `lang`, after the `header` comment lines.

    `values` are the parameters (baked in as float32 literals unless `uniforms`, when GLSL
    and HLSL read uniforms, WGSL a uniform struct, C and CUDA extra arguments).
    """
    names = {p: ident(p) for p in form.params}
    names.update({n: ident(n) for n, _ in form.lets})
    pr = _Printer(lang, names)
    lines = list(header)
    lines += uniform_block(lang, fname, list(form.params)) if uniforms else []
    body = []
    for p in form.params:
        value = values[p]
        if not math.isfinite(value):
            raise ValueError(f"parameter {p} = {value} is not finite")
        text = uniform_ref(lang, fname, p) if uniforms else pr.num(value)
        if not (uniforms and lang in ("c", "cuda")):
            body.append(pr.decl(names[p], text, const=not uniforms))
    body += [pr.decl(names[n], pr.expr(e)[0]) for n, e in form.lets]
    body.append(f"return {pr.expr(form.result)[0]};")
    args = [f"float {names[p]}" for p in form.params] if uniforms and lang in ("c", "cuda") else []
    if lang == "wgsl":
        lines.append(f"fn {fname}({', '.join(f'{x}: f32' for x in form.inputs)}) -> f32 {{")
    else:
        prefix = "__device__ " if lang == "cuda" else ""
        ins = [f"float {x}" for x in form.inputs]
        lines.append(f"{prefix}float {fname}({', '.join([*ins, *args])}) {{")
    lines += ["    " + s for s in body]
    lines.append("}")
    return "\n".join(lines) + "\n"
