"""A (fitted) family or area model as a self-contained GLSL, HLSL, WGSL, C or CUDA function.

A family's function is `float NAME(float d)`, in one of two forms (`FORMS`):

* **shader** (the default): the family's shader form (`Model.shader_form`, written on its
  class), the expression an engine ships or a person would write, printed with named
  temporaries (`_print`). A family with no shader form (`spline`, a user's own that says
  `shader_form = no_shader_form`) falls back to the stable form, and its header says so.
* **stable**: the expression the JAX code evaluates, read from its jaxpr (`_trace`) and
  printed one statement per operation (`_stable`): the guards at 0, at the range and
  against overflow included.

Parameters are baked in as float32 literals that round-trip exactly, or (`uniforms=True`)
read from uniforms (GLSL `uniform`, an HLSL `cbuffer`, a WGSL uniform-buffer struct) or, in
C and CUDA, passed as extra arguments. A header comment cites the family's source, the
form's source (the engine's file and function), the parameters and, for a fit, its error;
every text in it goes through `_text.comment_safe`.

An area model's function (`_area_export`) is `float NAME(float d, float cos_r, float cos_e,
float r, float cos_n, float g)`, its shader form only, with the same header plus its inputs
and their units.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._curves import Model
from .._errors import BadValueError, UnknownNameError
from .._version import __version__
from ._area_export import area_source
from ._model import load_model, param_value
from ._print import print_form
from ._program import UnsupportedPrimitiveError as UnsupportedPrimitiveError
from ._stable import print_stable
from ._text import (
    LANGUAGES,
    check_function_name,
    finish_header,
    float32_literal,
    float32_param,
    scalar_params,
)
from ._trace import trace

__all__ = ["FORMS", "LANGUAGES", "export", "function_source", "scalar_params"]

#: The forms `export` prints: the engines' expression, or attenfit's guarded one.
FORMS = ("shader", "stable")


def export(
    model: Any,
    lang: str = "glsl",
    *,
    uniforms: bool = False,
    name: str | None = None,
    params: Mapping[str, Any] | None = None,
    family: str | None = None,
    form: str = "shader",
) -> str:
    """A self-contained `lang` function evaluating the (fitted) family or area model.

    Parameters
    ----------
    model
        A `Family` (instance or class), a registered family name, a `FitResult`, a
        `FitResult.to_dict()` dict, or the path of a FIT.json (see `load_model`); or an
        `AreaModel` (instance or class), a registered area model's name, or a `FitResult`
        of one.
    lang
        "glsl", "hlsl", "wgsl", "c" or "cuda" (a `__device__` function).
    uniforms
        Read the parameters from uniforms (C and CUDA: extra float arguments after the
        inputs) instead of baking them in as float32 literals.
    name
        The function's name (an identifier); default `attenfit_<family or model>`.
    params
        Parameter values that replace the model's (a fit's error no longer applies then
        and is not quoted).
    family
        Which fit to export when `model` holds several (a FIT.json of many families); not
        for an area model.
    form
        "shader" (the engines' expression, no guards) or "stable" (the JAX form; a family's
        only: an area model has its shader form alone).

    Returns
    -------
    The source text. A family's function is `name(d)`, `d` the distance from the light's
    centre, and returns the attenuation in 1/length^2; an area model's is
    `name(d, cos_r, cos_e, r, cos_n, g)` (`attenfit.area.AreaInputs`) and returns `E / I`
    in 1/length^2. Both in float32.
    """
    if lang not in LANGUAGES:
        raise UnknownNameError(f"unknown language {lang!r}; choose one of {list(LANGUAGES)}")
    if form not in FORMS:
        raise UnknownNameError(f"unknown form {form!r}; choose one of {list(FORMS)}")
    fam, info = load_model(model, family=family)
    if params:
        fam = fam.replace(**{k: param_value(v, k, "params") for k, v in params.items()})
        if info:
            info = {"note": "parameters overridden after the fit; its error does not apply"}
    fname = check_function_name(name if name is not None else f"attenfit_{fam.name}")
    return function_source(fam, lang, fname, form=form, uniforms=uniforms, info=info)[0]


def function_source(
    family: Model,
    lang: str,
    fname: str,
    *,
    form: str = "shader",
    uniforms: bool = False,
    info: Mapping[str, Any] | None = None,
    header: bool = True,
    notes: Sequence[str] = (),
) -> tuple[str, str]:
    """(source text, the form printed): "shader", or "stable" where the family has none.

    `family` may be an area model (a model of several `inputs`, `_area_export.area_source`):
    its shader form, the only one it has. `notes` are more header lines (what a scene says
    of the function)."""
    if family.inputs:
        if form != "shader":
            raise BadValueError(
                f"area model {family.name!r} has no stable form (form {form!r}, --form "
                f"{form}, is a family's guarded JAX form): export its shader form"
            )
        text = area_source(
            family, lang, fname, uniforms=uniforms, info=info, header=header, notes=notes
        )
        return text, "shader"
    sf = family.shader_form() if form == "shader" else None
    lines: list[str] = []
    if sf is not None:
        values = scalar_params(family)
        if header:
            lines = _header(family, info or {}, lang, fname, uniforms, values, sf, notes=notes)
        text = print_form(sf, lang, fname, values, uniforms=uniforms, header=lines)
        return text, "shader"
    for p in family.param_names():
        for x in np.ravel(np.asarray(getattr(family, p), np.float64)):
            float32_param(family.name, p, float(x))
    prog = trace(family)
    if header:
        values = {p: (v[0] if prog.shapes[p] == () else list(v)) for p, v in prog.values.items()}
        lines = _header(
            family, info or {}, lang, fname, uniforms, values, None, form, len(prog.ops), notes
        )
    return print_stable(prog, lang, fname, uniforms=uniforms, header=lines), "stable"


def _header(
    family: Model,
    info: Mapping[str, Any],
    lang: str,
    fname: str,
    uniforms: bool,
    values: Mapping[str, Any],
    sf: Any,
    asked: str = "shader",
    n_ops: int = 0,
    notes: Sequence[str] = (),
) -> list[str]:
    def show(v: Any) -> str:
        if isinstance(v, list):
            return "[" + ", ".join(float32_literal(x) for x in v) + "]"
        return float32_literal(v)

    shown = ", ".join(f"{p} = {show(v)}" for p, v in values.items())
    clike = lang in ("c", "cuda")
    where = "arguments" if uniforms and clike else ("uniforms" if uniforms else "baked in")
    lines = [
        f"{fname}(d): light attenuation f(d) in 1/length^2, d = distance from the light's centre.",
        f"family  : {family.name}",
        f"formula : {family.formula}",
        f"source  : {family.source}",
    ]
    if sf is not None:
        lines.append(f"form    : shader, {'as in' if sf.engine else 'after'} {sf.source}")
        if sf.note:
            lines.append(f"          differs from the stable form: {sf.note}")
    elif asked == "shader":
        lines.append("form    : stable (this family has no shader form: attenfit's guarded form)")
    else:
        lines.append("form    : stable (attenfit's guarded form, read from the JAX code)")
    lines.append(f"params  : {shown} ({where})" if shown else "params  : none")
    generated = (
        [
            f"Generated by attenfit {__version__}; `attenfit export --form stable` gives the "
            "guarded form."
        ]
        if sf is not None
        else [
            f"Generated by attenfit {__version__} from the jaxpr of the JAX implementation",
            f"({n_ops} scalar operations, float32): the same numerically stable form.",
        ]
    )
    return finish_header(lines, info, notes, generated, lang)
