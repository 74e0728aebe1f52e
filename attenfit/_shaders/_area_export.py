"""An area model as a self-contained GLSL, HLSL, WGSL, C or CUDA function of the receiver
geometry, with the header a family's export has.

The function is `float NAME(float d, float cos_r, float cos_e, float r, float cos_n, float g)`:
the six `AreaInputs` in their order (`attenfit._curves._area`), the light's radius `r` one of
them (an engine reads it from the light's data), so that one function serves every light of
the model and reads what `model(d, cos_r, cos_e, r, cos_n, g)` reads. It returns `E / I` in
1/length^2. The body is the model's shader form (`_area_forms`: the engine's code its model
cites, with the engine's clamps), printed by `_print`; an area model has no stable form (its
JAX code is not traced). The model's parameters are baked in as float32 literals or read from
uniforms (C and CUDA: extra arguments after `g`), as a family's. Every text in the header goes
through `_text.comment_lines`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._curves import AREA_INPUTS, AreaModel, Family
from .._errors import BadValueError
from .._version import __version__
from ._area_exprs import area_export_form
from ._print import print_form
from ._text import comment_lines, fit_summary, float32_literal, float32_param

__all__ = ["AREA_INPUT_TEXT", "area_source", "area_values"]

#: Each input of an area model's function: what it is, and its unit.
AREA_INPUT_TEXT: Mapping[str, str] = {
    "d": "distance from the receiver to the light's centre (a capsule: to its segment); length",
    "cos_r": "n.l, the cosine at the receiver (l: the unit vector to the light's centre); 1",
    "cos_e": "m.(p - c)/d, the cosine at the emitter (m: a disk's normal; 1 for a sphere); 1",
    "r": "the light's radius; length (the unit of d)",
    "cos_n": "-n.m, the receiver's normal against a disk's axis (a sphere: cos_r); 1",
    "g": "the emitter factor (1 for a sphere, max(0, cos_e) for a one-sided disk); 1",
}


def area_values(model: AreaModel) -> dict[str, float]:
    """The model's parameters as finite float32 scalars (`BadValueError` for a batch, or for
    a value float32 cannot hold)."""
    out = {}
    for p, v in model.params().items():
        value = np.asarray(v, np.float64)
        if value.ndim:
            raise BadValueError(
                f"area model {model.name!r} has parameter {p} of shape {value.shape}; export "
                "takes one set of parameters, not a batch: pick one problem"
            )
        out[p] = float32_param(model.name, p, float(value))
    return out


def area_source(
    model: AreaModel,
    lang: str,
    fname: str,
    *,
    uniforms: bool = False,
    info: Mapping[str, Any] | None = None,
    header: bool = True,
    notes: Sequence[str] = (),
) -> str:
    """The function `fname(d, cos_r, cos_e, r, cos_n, g)` of `model` in `lang` (see the module
    docstring), after its header comment (unless `header=False`); `info` is a fit's (as for a
    family), `notes` more header lines (what a scene says of it)."""
    made = area_export_form(model)
    if made is None:
        inner = getattr(model, "family", None)
        what = f" (family {inner.name!r} has none)" if isinstance(inner, Family) else ""
        raise BadValueError(f"area model {model.name!r} has no shader form{what}: cannot export it")
    form, renamed = made
    values = area_values(model)
    lines = []
    if header:
        lines = _header(model, form, renamed, values, info or {}, lang, fname, uniforms, notes)
    printed = {renamed.get(p, p): v for p, v in values.items()}
    return print_form(form, lang, fname, printed, uniforms=uniforms, header=lines)


def _header(
    model: AreaModel,
    form: Any,
    renamed: Mapping[str, str],
    values: Mapping[str, float],
    info: Mapping[str, Any],
    lang: str,
    fname: str,
    uniforms: bool,
    notes: Sequence[str],
) -> list[str]:
    clike = lang in ("c", "cuda")
    where = "arguments after g" if uniforms and clike else ("uniforms" if uniforms else "baked in")
    shown = ", ".join(
        f"{p} = {float32_literal(v)}" + (f" (written {renamed[p]})" if p in renamed else "")
        for p, v in values.items()
    )
    inner = getattr(model, "family", None)
    lines = [
        f"{fname}({', '.join(AREA_INPUTS)}): E / I, the irradiance of an area light over its "
        "intensity, at a receiver.",
        f"model   : {model.name} (an area model; lights: {model.light})",
        f"formula : {model.formula}",
    ]
    if isinstance(inner, Family):
        lines.append(f"          f = {inner.name}: {inner.formula} (source: {inner.source})")
    lines += [
        f"source  : {model.source}",
        f"form    : shader, {'as in' if form.engine else 'after'} {form.source}",
    ]
    if form.note:
        lines.append(f"          differs from the JAX model: {form.note}")
    lines.append(f"params  : {shown} ({where})" if shown else "params  : none")
    width = max(map(len, AREA_INPUTS))
    for k, x in enumerate(AREA_INPUTS):
        lines.append(f"{'inputs  :' if k == 0 else ' ' * 9} {x:<{width}}  {AREA_INPUT_TEXT[x]}")
    lines.append(
        "output  : E / I in 1/length^2 (I: the light's point-equivalent intensity, "
        "I = pi r^2 L; docs/architecture.md, Conventions)"
    )
    if info:
        fit = fit_summary(dict(info))
        lines += [f"fit     : {fit[0]}", *(f"          {line}" for line in fit[1:])]
    lines += list(notes)
    lines.append(
        f"Generated by attenfit {__version__} from the model's shader form (an area model has "
        "no stable form)."
    )
    if lang == "c":
        lines.append("Needs <math.h> (link -lm); compile without -ffast-math.")
    if lang == "cuda":
        lines.append("A CUDA __device__ function (nvcc or NVRTC).")
    return comment_lines(lines)
