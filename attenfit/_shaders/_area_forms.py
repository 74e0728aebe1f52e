"""What each area model's shader form costs compiled; the forms themselves are in `_area_exprs`
(re-exported here: `attenfit.area` reads them from this module).

`area_compiled_cost(model)` compiles the GLSL function with the scalar parameters and radius at
generic values (the count of the model's shader for any light, as `structural_cost` does for
a family) to SPIR-V (glslangValidator + spirv-opt -O); without the compilers, the
traced-operation estimate of `_cost.SHADER_WEIGHTS` over the form.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._curves import AreaModel
from ._area_exprs import AREA_FORM_INPUTS as AREA_FORM_INPUTS
from ._area_exprs import area_export_form as area_export_form
from ._area_exprs import area_function_source as area_function_source
from ._area_exprs import area_shader_form as area_shader_form
from ._area_exprs import baked_values
from ._area_exprs import evaluate_area_form as evaluate_area_form
from ._compilers import Compiled, cost_method, spirv_counts
from ._print import print_form

__all__ = [
    "AREA_FORM_INPUTS",
    "AreaCompiledCost",
    "area_compiled_cost",
    "area_export_form",
    "area_function_source",
    "area_shader_form",
    "evaluate_area_form",
]


# ----------------------------------------------------------------------------- cost
class AreaCompiledCost:
    """What one area model's shader form costs compiled (`spirv`), or its estimate."""

    def __init__(self, model: str, spirv: Compiled | None, estimate: float, method: str):
        self.model, self.spirv, self.estimate, self.method = model, spirv, estimate, method

    @property
    def cost(self) -> float:
        """SPIR-V instructions where compiled, else the estimate."""
        return float(self.spirv.total) if self.spirv is not None else float(self.estimate)

    def label(self) -> str:
        """What `cost` counts, naming the compiler."""
        if self.spirv is not None:
            return f"SPIR-V instructions ({self.spirv.tool})"
        return "estimate: weighted traced operations (no compiler installed)"

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        return {
            "model": self.model,
            "cost": self.cost,
            "label": self.label(),
            "spirv": None if self.spirv is None else self.spirv.to_dict(),
            "estimate": self.estimate,
        }


#: Generic values (none a compiler folds away) for the parameters and the radius.
_GENERIC = {"positive": 0.7313, "nonnegative": 0.5311, "unit": 0.3713, "real": 0.4217}
_GENERIC_R = 0.6173


def area_compiled_cost(model: AreaModel) -> AreaCompiledCost:
    """The compiled cost of `model`'s shader form, its scalar parameters and `r` at generic
    values (the same count for every light); SPIR-V where glslangValidator and spirv-opt are
    installed, else the traced-operation estimate."""
    from ._cost import SHADER_WEIGHTS

    generic = {
        p: _GENERIC[model.constraint(p)] for p, v in model.params().items() if np.ndim(v) == 0
    }
    m = model.replace(**generic) if generic else model
    form = area_shader_form(m)
    if form is None:
        raise ValueError(f"area model {model.name!r} has no shader form")
    fname = "attenfit_area"
    glsl = print_form(form, "glsl", fname, baked_values(m, _GENERIC_R), uniforms=False, header=())
    spirv = (
        spirv_counts(glsl, fname, inputs=len(AREA_FORM_INPUTS))
        if cost_method() == "spirv"
        else None
    )
    uniform = form.uniform_lets()
    names = {"saturate": "clamp", "select": "select_n"}
    total = 0.0

    def walk(e: Any) -> None:
        nonlocal total
        from .._ir import Call, reads

        if isinstance(e, Call):
            if reads(e, {"d"}, uniform):
                total += SHADER_WEIGHTS.get(names.get(e.op, e.op), 1)
            for a in e.args:
                walk(a)

    for name, expr in form.lets:
        if name not in uniform:
            walk(expr)
    walk(form.result)
    return AreaCompiledCost(model.name, spirv, total, "spirv" if spirv is not None else "estimate")
