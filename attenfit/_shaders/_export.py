"""A (fitted) family as a self-contained GLSL, HLSL, WGSL, C or CUDA function.

Two forms (`FORMS`):

* **shader** (the default): the family's shader form (`_forms`), the expression an engine
  ships or a person would write, printed with named temporaries (`_print`). A family with
  no shader form (a user's own, `spline`) falls back to the stable form, and its header
  says so.
* **stable**: the expression the JAX code evaluates, read from its jaxpr (`_trace`) and
  printed one statement per operation (`_stable`): the guards at 0, at the range and
  against overflow included.

Parameters are baked in as float32 literals that round-trip exactly, or (`uniforms=True`)
read from uniforms (GLSL `uniform`, an HLSL `cbuffer`, a WGSL uniform-buffer struct) or, in
C and CUDA, passed as extra arguments. A header comment cites the family's source, the
form's source (the engine's file and function), the parameters and, for a fit, its error;
every text in it goes through `_text.comment_safe`.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .._curves import Family
from .._errors import BadValueError, UnknownNameError
from .._version import __version__
from ._forms import shader_form
from ._model import load_model, param_value
from ._print import print_form
from ._program import UnsupportedPrimitiveError as UnsupportedPrimitiveError
from ._stable import print_stable
from ._text import LANGUAGES, check_function_name, comment_lines, float32_literal
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
    """A self-contained `lang` function `float name(float d)` evaluating the (fitted) family.

    Parameters
    ----------
    model
        A `Family` (instance or class), a registered family name, a `FitResult`, a
        `FitResult.to_dict()` dict, or the path of a FIT.json (see `load_model`).
    lang
        "glsl", "hlsl", "wgsl", "c" or "cuda" (a `__device__` function).
    uniforms
        Read the parameters from uniforms (C and CUDA: extra float arguments after `d`)
        instead of baking them in as float32 literals.
    name
        The function's name (an identifier); default `attenfit_<family>`.
    params
        Parameter values that replace the model's (a fit's error no longer applies then
        and is not quoted).
    family
        Which fit to export when `model` holds several (a FIT.json of many families).
    form
        "shader" (the engines' expression, no guards) or "stable" (the JAX form).

    Returns
    -------
    The source text; `d` is the distance from the light's centre and the result is the
    attenuation in 1/length^2 (float32).
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


def scalar_params(family: Family) -> dict[str, float]:
    """The family's parameters as finite float32 scalars (one problem, not a batch)."""
    out = {}
    for p in family.param_names():
        value = np.asarray(getattr(family, p), np.float64)
        if value.ndim:
            raise BadValueError(
                f"family {family.name!r} has parameter {p} of shape {value.shape}; export "
                "and cost take one set of parameters, not a batch: pick one problem"
            )
        out[p] = float32_param(family.name, p, float(value))
    return out


def float32_param(family: str, name: str, value: float) -> float:
    """`value` as the float32 a shader computes with, refused (`BadValueError`) when it is
    not finite there or rounds to 0 or a subnormal (which GPUs flush to 0)."""
    x = (
        np.float32(value)
        if np.isfinite(value) and abs(value) <= float(_F32.max)
        else np.float32(np.inf)
    )
    if not np.isfinite(x):
        raise BadValueError(
            f"parameter {name}={value!r} of {family!r} is not a finite float32 "
            f"(float32 ends at {float(_F32.max):.3g}); a shader cannot hold it"
        )
    if value != 0 and abs(float(x)) < _F32.tiny:
        raise BadValueError(
            f"parameter {name}={value!r} of {family!r} rounds to {float(x):g} in float32 (normal "
            f"float32 starts at {float(_F32.tiny):.3g}; GPUs flush smaller values to 0): the "
            "shader would compute with 0; rescale the scene's units"
        )
    return float(x)


_F32 = np.finfo(np.float32)


def function_source(
    family: Family,
    lang: str,
    fname: str,
    *,
    form: str = "shader",
    uniforms: bool = False,
    info: Mapping[str, Any] | None = None,
    header: bool = True,
) -> tuple[str, str]:
    """(source text, the form printed): "shader", or "stable" where the family has none."""
    sf = shader_form(family) if form == "shader" else None
    lines: list[str] = []
    if sf is not None:
        values = scalar_params(family)
        if header:
            lines = _header(family, info or {}, lang, fname, uniforms, values, sf)
        text = print_form(sf, lang, fname, values, uniforms=uniforms, header=lines)
        return text, "shader"
    for p in family.param_names():
        for x in np.ravel(np.asarray(getattr(family, p), np.float64)):
            float32_param(family.name, p, float(x))
    prog = trace(family)
    if header:
        values = {p: (v[0] if prog.shapes[p] == () else list(v)) for p, v in prog.values.items()}
        lines = _header(
            family, info or {}, lang, fname, uniforms, values, None, form, len(prog.ops)
        )
    return print_stable(prog, lang, fname, uniforms=uniforms, header=lines), "stable"


def _header(
    family: Family,
    info: Mapping[str, Any],
    lang: str,
    fname: str,
    uniforms: bool,
    values: Mapping[str, Any],
    sf: Any,
    asked: str = "shader",
    n_ops: int = 0,
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
    if info:
        fit = _fit_summary(dict(info))
        lines += [f"fit     : {fit[0]}", *(f"          {line}" for line in fit[1:])]
    if sf is not None:
        lines.append(
            f"Generated by attenfit {__version__}; `attenfit export --form stable` gives the "
            "guarded form."
        )
    else:
        lines += [
            f"Generated by attenfit {__version__} from the jaxpr of the JAX implementation",
            f"({n_ops} scalar operations, float32): the same numerically stable form.",
        ]
    if lang == "c":
        lines.append("Needs <math.h> (link -lm); compile without -ffast-math.")
    if lang == "cuda":
        lines.append("A CUDA __device__ function (nvcc or NVRTC).")
    return comment_lines(lines)


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
