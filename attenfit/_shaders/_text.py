"""What every generated function shares, in every language: literals, identifiers, uniform
declarations, and the one place where text from outside (a fit file, a family's formula,
a file name) is made safe to put into a comment.

`comment_lines` is the only way text reaches generated code: every character outside
printable ASCII is written as an escape (`\\u2028`), so no line terminator of any target
language survives (C, HLSL, CUDA and GLSL end a `//` comment at LF and at a lone CR; WGSL
also at VT, FF, NEL, U+2028 and U+2029); a backslash is written `\\x5c` and `??` as `?\\x3f`,
so no line can end in a line splice (C's `\\`, or the trigraph `??/`, which C99 turns into
one); `*/` and `/*` are broken up, so the text cannot end or open a block comment.
Everything else the code holds is generated: identifiers are checked, numbers are float32
literals.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from .._errors import BadValueError

__all__ = [
    "LANGUAGES",
    "comment_lines",
    "comment_safe",
    "finish_header",
    "fit_summary",
    "float32_literal",
    "float32_param",
    "ident",
]

#: The target languages of `export`.
LANGUAGES = ("glsl", "hlsl", "wgsl", "c", "cuda")


def comment_safe(text: object) -> str:
    """`text` as one line that cannot end, open or close a comment in any target language."""
    out = []
    for ch in str(text):
        code = ord(ch)
        if ch == "\\":
            out.append("\\x5c")
        elif 0x20 <= code < 0x7F:
            out.append(ch)
        elif code <= 0xFF:
            out.append(f"\\x{code:02x}")
        else:
            out.append(f"\\u{code:04x}" if code <= 0xFFFF else f"\\U{code:08x}")
    safe = "".join(out)
    while "??" in safe:  # C99 trigraphs (??/ is a backslash)
        safe = safe.replace("??", "?\\x3f")
    return safe.replace("*/", "* /").replace("/*", "/ *")


def comment_lines(lines: Iterable[str]) -> list[str]:
    """`//` comment lines (every target language has them), each made safe by `comment_safe`."""
    return [f"// {comment_safe(line)}".rstrip() for line in lines]


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


_F32 = np.finfo(np.float32)


def scalar_params(model: Any) -> dict[str, float]:
    """A model's parameters (a family's or an area model's) as finite float32 scalars: one
    problem, not a batch (`BadValueError` for a batch or a value float32 cannot hold)."""
    out = {}
    for p, v in model.params().items():
        value = np.asarray(v, np.float64)
        if value.ndim:
            raise BadValueError(
                f"{model.kind} {model.name!r} has parameter {p} of shape {value.shape}; export "
                "and cost take one set of parameters, not a batch: pick one problem"
            )
        out[p] = float32_param(model.name, p, float(value))
    return out


def float32_param(model: str, name: str, value: float) -> float:
    """`value` as the float32 a shader computes with, refused (`BadValueError`) when it is
    not finite there or rounds to 0 or a subnormal (which GPUs flush to 0)."""
    x = (
        np.float32(value)
        if np.isfinite(value) and abs(value) <= float(_F32.max)
        else np.float32(np.inf)
    )
    if not np.isfinite(x):
        raise BadValueError(
            f"parameter {name}={value!r} of {model!r} is not a finite float32 "
            f"(float32 ends at {float(_F32.max):.3g}); a shader cannot hold it"
        )
    if value != 0 and abs(float(x)) < _F32.tiny:
        raise BadValueError(
            f"parameter {name}={value!r} of {model!r} rounds to {float(x):g} in float32 (normal "
            f"float32 starts at {float(_F32.tiny):.3g}; GPUs flush smaller values to 0): the "
            "shader would compute with 0; rescale the scene's units"
        )
    return float(x)


# ----------------------------------------------------------------------------- header
def fit_summary(info: Mapping[str, Any]) -> list[str]:
    """A fit's header lines: its error (metrics, loss, convergence), configuration and file."""
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


def finish_header(
    lines: Sequence[str],
    info: Mapping[str, Any],
    notes: Sequence[str],
    generated: Sequence[str],
    lang: str,
) -> list[str]:
    """A function's header comment: `lines`, a fit's error (`info`), `notes`, how it was
    `generated`, and what `lang` needs, each line through `comment_lines`."""
    out = list(lines)
    if info:
        fit = fit_summary(dict(info))
        out += [f"fit     : {fit[0]}", *(f"          {line}" for line in fit[1:])]
    out += [*notes, *generated]
    if lang == "c":
        out.append("Needs <math.h> (link -lm); compile without -ffast-math.")
    if lang == "cuda":
        out.append("A CUDA __device__ function (nvcc or NVRTC).")
    return comment_lines(out)


# ----------------------------------------------------------------------------- identifiers
KEYWORDS = {
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


def ident(name: str) -> str:
    """`name` as a local identifier of every target language (a trailing `_` on keywords)."""
    return f"{name}_" if name in KEYWORDS else name


def check_function_name(fname: str) -> str:
    """`fname` if it is an ASCII identifier (the one name a user puts into the code)."""
    if not (isinstance(fname, str) and fname.isidentifier() and fname.isascii()):
        raise BadValueError(f"function name {fname!r} is not an ASCII identifier")
    return fname


def uniform_block(lang: str, fname: str, names: Sequence[str]) -> list[str]:
    """Declarations of the uniforms `names` (GLSL uniforms, an HLSL cbuffer, a WGSL struct)."""
    if not names or lang in ("c", "cuda"):
        return []
    if lang == "glsl":
        return [f"uniform float {fname}_{n};" for n in names]
    if lang == "hlsl":
        return [f"cbuffer {fname}_params {{", *(f"    float {fname}_{n};" for n in names), "};"]
    struct = f"{fname}_params_t"
    return [
        f"struct {struct} {{",
        *(f"    {n}: f32," for n in names),
        "};",
        f"@group(0) @binding(0) var<uniform> {fname}_params: {struct};  // choose your binding",
    ]


def uniform_ref(lang: str, fname: str, name: str) -> str:
    """How the function reads uniform `name` (C and CUDA: its argument)."""
    if lang == "wgsl":
        return f"{fname}_params.{name}"
    if lang in ("c", "cuda"):
        return ident(name)
    return f"{fname}_{name}"
