"""Building a model's shader form: the expression an engine ships (or a person would write),
in the expression language of `attenfit._ir`, which `attenfit._shaders` prints, evaluates in
float16/32/64, compiles and exports.

Each model writes its own form beside its JAX code (`Model.shader_form`), a method decorated
`@shader(source, engine=..., note=...)` (a family: the input `d`, `distance_form`) or
`@area_shader(...)` (an area model: the inputs `AREA_FORM_INPUTS` and the light's radius as
the parameter `radius`, `area_form`), whose body builds the expression. Unlike the JAX forms
(what fitting and the truth comparisons use), the shader forms have no guards: no NaN
pass-through, no negative-d branch, no overflow-free hypot; each `note` says where a form
parts from its model. Parameters the engines precompute on the CPU (1/r^2, 1/range) are
named temporaries that read parameters only: a compiler folds them when they are baked in.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

from .._ir import Expr, Lets, Ref, ShaderForm, fn

__all__ = [
    "AREA_FORM_INPUTS",
    "OVERFLOW",
    "area_form",
    "area_shader",
    "distance_form",
    "illuminance",
    "shader",
]

#: The per-receiver inputs of an area model's form, in argument order (the light's radius is
#: the parameter `radius`: `attenfit._shaders` makes it an input where it exports the form).
AREA_FORM_INPUTS = ("d", "cos_r", "cos_e", "cos_n", "g")

#: The `note` of a form that squares `d` where its model does not overflow.
OVERFLOW = "d*d overflows float32 beyond d = 1.8e19 and float16 beyond 256 (the reference does not)"


def distance_form(
    model: Any, build: Callable[..., Expr], source: str, *, engine: bool, note: str = ""
) -> ShaderForm:
    """The form `build(let, d, *params) -> result` of a family `model`: `let` collects the
    named temporaries (`Lets`), `d` and each parameter (in `param_names()` order) are `Ref`s.

    `source` cites the engine's file and function (or the textbook equation) the form
    transcribes, `engine` says whether it is an engine's own code, `note` where it parts
    from the JAX form.
    """
    params = model.param_names()
    let = Lets()
    result = build(let, Ref("d", "d"), *(Ref(p, "param") for p in params))
    return ShaderForm(model.name, params, tuple(let.items), result, source, engine, note)


def area_form(
    model: Any, build: Callable[..., Expr], source: str, *, engine: bool, note: str = ""
) -> ShaderForm:
    """The form `build(let, x, p) -> result` of an area model: `x` maps each of the model's
    `form_inputs` (default `AREA_FORM_INPUTS`) to its `Ref`, `p` each parameter and the
    light's size (`form_sizes`: `radius`; a rectangle's `half_width`, `half_height`)."""
    cls = type(model)
    inputs = tuple(getattr(cls, "form_inputs", AREA_FORM_INPUTS))
    params = (*model.param_names(), *getattr(cls, "form_sizes", {"radius": "r"}))
    let = Lets()
    x = {k: Ref(k, "d") for k in inputs}
    result = build(let, x, {k: Ref(k, "param") for k in params})
    return ShaderForm(model.name, params, tuple(let.items), result, source, engine, note, inputs)


def shader(source: str, *, engine: bool, note: str = ""):
    """Make `build(self, let, d, *params) -> result` a family's `shader_form(self)`
    (`distance_form`; `self` for its static options)."""
    return _method(distance_form, source, engine, note)


def area_shader(source: str, *, engine: bool, note: str = ""):
    """Make `build(self, let, x, p) -> result` an area model's `shader_form(self)`
    (`area_form`)."""
    return _method(area_form, source, engine, note)


def _method(make: Callable[..., ShaderForm], source: str, engine: bool, note: str):
    def deco(build: Callable[..., Expr]) -> Callable[[Any], ShaderForm]:
        @functools.wraps(build)
        def shader_form(self: Any) -> ShaderForm:
            return make(self, functools.partial(build, self), source, engine=engine, note=note)

        return shader_form

    return deco


def illuminance(let: Lets, cos_theta: Expr, sin2: Expr, tag: str) -> Ref:
    """Frostbite's `illuminanceSphereOrDisk(cosTheta, sinSigmaSqr)` (Lagarde & de Rousiers 2014,
    section 4.7.2.4), both branches then a select, as a compiler flattens the `if`."""
    st = let(f"{tag}sin_theta", fn("sqrt", 1.0 - cos_theta * cos_theta))
    x = let(f"{tag}x", fn("sqrt", 1.0 / sin2 - 1.0))
    y = let(f"{tag}y", -x * (cos_theta / st))
    sy = let(f"{tag}sin_theta_sqrt_y", st * fn("sqrt", 1.0 - y * y))
    clipped = (cos_theta * fn("acos", y) - x * sy) * sin2 + fn("atan", sy / x)
    unclipped = math.pi * sin2 * fn("saturate", cos_theta)
    ill = fn("select", cos_theta * cos_theta > sin2, unclipped, clipped)
    return let(f"{tag}illuminance", fn("max", ill, 0.0))
