"""What each area model's shader form costs compiled, and the form with a light's radius baked
in: printed (`area_function_source`) or evaluated at a precision (`evaluate_area_form`).

`area_compiled_cost(model)` compiles the GLSL function with the scalar parameters and radius at
generic values (the count of the model's shader for any light, as `structural_cost` does for
a family) to SPIR-V (glslangValidator + spirv-opt -O); without the compilers, the
traced-operation estimate of `_cost.SHADER_WEIGHTS` over the form.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .._curves import AreaModel
from .._errors import BadValueError
from .._ir import ShaderForm, evaluate_form
from ._compilers import CompiledCost, cost_method, generic_model, spirv_counts
from ._print import print_form

__all__ = [
    "area_compiled_cost",
    "area_function_source",
    "baked_values",
    "evaluate_area_form",
]


def _form(model: AreaModel) -> ShaderForm:
    form = model.shader_form()
    if form is None:
        raise BadValueError(f"area model {model.name!r} has no shader form")
    return form


def baked_values(model: AreaModel, r: float | Mapping[str, float]) -> dict[str, float]:
    """The form's parameter values with the light's size baked in (scalar parameters only):
    `r` the radius, or each of the model's `form_sizes` by name (a number: all of them)."""
    out = {k: float(np.asarray(v)) for k, v in model.params().items() if np.ndim(v) == 0}
    for size in type(model).form_sizes:
        out.setdefault(size, float(r[size] if isinstance(r, Mapping) else r))
    return out


def area_function_source(model: AreaModel, lang: str, fname: str, r: float) -> str:
    """The function `fname(d, cos_r, cos_e, cos_n, g)` of `model` in `lang`, `r` baked in."""
    return print_form(_form(model), lang, fname, baked_values(model, r), uniforms=False, header=())


def evaluate_area_form(
    model: AreaModel,
    inputs: Mapping[str, Any],
    dtype: Any = np.float32,
) -> np.ndarray:
    """The form of `model` at `inputs` (a mapping with the form's inputs, `AREA_FORM_INPUTS`
    by default, and the light's size: `r`, or the inputs `form_sizes` names), every operation
    rounded to `dtype` (`_ir.evaluate_form`); each size must be one value."""
    form = _form(model)
    sizes = {
        p: float(np.asarray(inputs[k]).reshape(-1)[0]) for p, k in type(model).form_sizes.items()
    }
    given = {k: inputs[k] for k in form.inputs}
    return evaluate_form(form, given, baked_values(model, sizes), dtype)


#: A generic radius (no value a compiler folds away).
_GENERIC_R = 0.6173


def area_compiled_cost(model: AreaModel) -> CompiledCost:
    """The compiled cost of `model`'s shader form, its scalar parameters and `r` at generic
    values (the same count for every light); SPIR-V where glslangValidator and spirv-opt are
    installed, else the traced-operation estimate (`CompiledCost`, with no SASS count)."""
    from ._cost import form_cost

    m = generic_model(model)
    form = _form(m)
    fname = "attenfit_area"
    glsl = print_form(form, "glsl", fname, baked_values(m, _GENERIC_R), uniforms=False, header=())
    spirv = spirv_counts(glsl, fname, inputs=len(form.inputs)) if cost_method() == "spirv" else None
    method = "spirv" if spirv is not None else "estimate"
    return CompiledCost(model.name, "shader", spirv, None, form_cost(form), method)
