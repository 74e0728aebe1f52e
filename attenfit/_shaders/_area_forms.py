"""The shader form of each area model, and what it costs compiled.

An area model's form is a `ShaderForm` of five per-receiver inputs (`AREA_FORM_INPUTS`: the
distance, the cosine at the receiver, the cosine at the emitter, the normal against a disk's
axis, the emitter factor) and its parameters plus the light's radius `r`, baked in as a
family's parameters are (an engine reads both from the light's data), named `radius` in
the form (a family's own `r` keeps its name). Each transcribes the
engine's function its model cites (`attenfit._curves._area_models`), with the engine's
clamps; `note` says where it parts from the JAX reference. `PointLight(family)`'s form is the
family's own form (`_forms`) times `g max(0, cos_r)`: the point-light model in the same terms.

`area_compiled_cost(model)` compiles the GLSL function with the scalar parameters and radius at
generic values (the count of the model's shader for any light, as `structural_cost` does for
a family) to SPIR-V (glslangValidator + spirv-opt -O); without the compilers, the
traced-operation estimate of `_cost.SHADER_WEIGHTS` over the form.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .._curves import AreaModel, PointLight
from ._compilers import Compiled, cost_method, spirv_counts
from ._forms import _Lets, shader_form
from ._ir import Expr, Ref, ShaderForm, evaluate_form, fn
from ._print import print_form

__all__ = [
    "AREA_FORM_INPUTS",
    "AreaCompiledCost",
    "area_compiled_cost",
    "area_function_source",
    "area_shader_form",
    "evaluate_area_form",
]

#: The per-receiver inputs of an area model's form, in argument order.
AREA_FORM_INPUTS = ("d", "cos_r", "cos_e", "cos_n", "g")

_BUILDERS: dict[str, Callable[[AreaModel], ShaderForm]] = {}
_PI = math.pi


def _inputs() -> dict[str, Ref]:
    return {x: Ref(x, "d") for x in AREA_FORM_INPUTS}


def _area_form(name: str, source: str, *, engine: bool, note: str = ""):
    """Register `build(let, x, p) -> result` as the form of area model `name`; `x` are the
    inputs, `p` the parameters (the model's and `r`) as `Ref`s."""

    def deco(build: Callable[..., Expr]) -> Callable[..., Expr]:
        def make(model: AreaModel) -> ShaderForm:
            let = _Lets()
            params = (*model.param_names(), "radius")
            p = {k: Ref(k, "param") for k in params}
            result = build(let, _inputs(), p)
            return ShaderForm(
                name, params, tuple(let.items), result, source, engine, note, AREA_FORM_INPUTS
            )

        _BUILDERS[name] = make
        return build

    return deco


def _illuminance(let: _Lets, cos_theta: Expr, sin2: Expr, tag: str) -> Ref:
    """Frostbite's `illuminanceSphereOrDisk(cosTheta, sinSigmaSqr)` (Lagarde & de Rousiers 2014,
    section 4.7.2.4), both branches then a select, as a compiler flattens the `if`."""
    st = let(f"{tag}sin_theta", fn("sqrt", 1.0 - cos_theta * cos_theta))
    x = let(f"{tag}x", fn("sqrt", 1.0 / sin2 - 1.0))
    y = let(f"{tag}y", -x * (cos_theta / st))
    sy = let(f"{tag}sin_theta_sqrt_y", st * fn("sqrt", 1.0 - y * y))
    clipped = (cos_theta * fn("acos", y) - x * sy) * sin2 + fn("atan", sy / x)
    unclipped = _PI * sin2 * fn("saturate", cos_theta)
    ill = fn("select", cos_theta * cos_theta > sin2, unclipped, clipped)
    return let(f"{tag}illuminance", fn("max", ill, 0.0))


@_area_form(
    "snyder_sphere",
    "Frostbite 2014 section 4.7.2.4 (illuminanceSphereOrDisk, sphere evaluation)",
    engine=True,
    note="clamps cosTheta to +-0.999 and sin^2 to 0.9999 (the engine's); 1/(pi r^2) folded",
)
def _snyder_sphere(let, x, p):
    sin2 = let("sin_sigma_sqr", fn("min", p["radius"] * p["radius"] / (x["d"] * x["d"]), 0.9999))
    ct = let("cos_theta", fn("clamp", x["cos_r"], -0.999, 0.999))
    inv_area = let("inv_pi_r2", 1.0 / (_PI * p["radius"] * p["radius"]))
    return x["g"] * _illuminance(let, ct, sin2, "") * inv_area


@_area_form(
    "frostbite_disk",
    "Frostbite 2014 section 4.7.2.4 (illuminanceSphereOrDisk, disk evaluation)",
    engine=True,
    note="g stands for saturate(dot(planeNormal, -L)); cosTheta clamped to +-0.999",
)
def _frostbite_disk(let, x, p):
    r2 = let("r2", p["radius"] * p["radius"])
    sin2 = let("sin_sigma_sqr", r2 / (r2 + fn("max", r2, x["d"] * x["d"])))
    ct = let("cos_theta", fn("clamp", x["cos_r"], -0.999, 0.999))
    inv_area = let("inv_pi_r2", 1.0 / (_PI * r2))
    return x["g"] * _illuminance(let, ct, sin2, "") * inv_area


@_area_form(
    "vector_disk",
    "Howell B-12/B-14 (the vector irradiance of a disk); the clipped case as Hill & Heitz "
    "2016 slide 102 and Unity HDRP AreaLighting.hlsl (a sphere cap of the same form factor, "
    "evaluated by Frostbite's illuminanceSphereOrDisk)",
    engine=False,
    note="unguarded: no rescaling by sqrt(d^2 + r^2), no product form near the rim",
)
def _vector_disk(let, x, p):
    d, cr, ce, cn = x["d"], x["cos_r"], x["cos_e"], x["cos_n"]
    r2 = let("r2", p["radius"] * p["radius"])
    z = let("z", d * ce)
    s2 = let("s2", d * d - z * z)
    a = let("a", d * d + r2)
    big_s = let("big_s", fn("sqrt", fn("max", a * a - 4.0 * s2 * r2, 0.0)))
    q = let("q", big_s + z * z + r2 - s2)
    num = let("num", q * cn + 2.0 * z * (d * cr - z * cn))
    den = let("den", big_s * (big_s + a))
    e_vec = let("e_vec", fn("max", num, 0.0) / den)
    f_len = let("f_len", fn("sqrt", q * q + 4.0 * z * z * s2))  # |F| den / r^2
    sin2 = let("cap_sin2", fn("min", r2 * f_len / den, 0.9999))
    cos_w = let("cap_cos", fn("clamp", num / f_len, -0.999, 0.999))
    e_cap = _illuminance(let, cos_w, sin2, "cap_") * (f_len / (_PI * sin2 * den))
    w = let("w", fn("sqrt", fn("max", 1.0 - cn * cn, 0.0)))
    above = fn("ge", d * cr, p["radius"] * w)
    lit = fn("select", ce > 0.0, fn("select", above, e_vec, e_cap), 0.0)
    return fn("select", d * cr > -p["radius"] * w, lit, 0.0)


@_area_form(
    "unreal_wrap",
    "Unreal Engine CapsuleLight.ush::SphereHorizonCosWrap; described, not copied",
    engine=True,
    note="the sphere's 1/max(d, r)^2 for the engine's 1/(d^2 + 1 cm^2)",
)
def _unreal_wrap(let, x, p):
    inv = let("inv_d", 1.0 / fn("max", x["d"], p["radius"]))
    s = let("sin_a", p["k"] * fn("sqrt", fn("saturate", p["radius"] * p["radius"] * inv * inv)))
    c = let("nol", fn("max", x["cos_r"], -s))
    w = fn("select", x["cos_r"] < s, (c + s) * (c + s) / (4.0 * s), x["cos_r"])
    return x["g"] * w * inv * inv


@_area_form(
    "godot_wrap",
    "Godot 4 scene_forward_lights_inc.glsl::light_process_omni (size_A) and light_compute",
    engine=True,
    note="t = k r / max(d, r) for size / max(0.001, light_length); 1/max(d, r)^2 for the "
    "engine's windowed falloff",
)
def _godot_wrap(let, x, p):
    inv = let("inv_d", 1.0 / fn("max", x["d"], p["radius"]))
    t = let("t", p["k"] * p["radius"] * inv)
    size_a = let("size_a", fn("max", 1.0 - 1.0 / fn("sqrt", 1.0 + t * t), 0.0))
    ndotl = fn("max", fn("min", size_a + x["cos_r"], 1.0), 0.0)
    return x["g"] * ndotl * inv * inv


@_area_form(
    "hdrp_sphere",
    "Unity HDRP AreaLighting.hlsl::DiffuseSphereLightIrradiance "
    "(APPROXIMATE_SPHERE_LIGHT_NUMERICALLY)",
    engine=True,
    note="sinSqSigma = min(r^2/d^2, 0.9999); the form factor over r^2",
)
def _hdrp_sphere(let, x, p):
    s2 = let("x", fn("min", p["radius"] * p["radius"] / (x["d"] * x["d"]), 0.9999))
    y = x["cos_r"]
    poly = p["a0"] + s2 * (p["a1"] + s2 * (p["a2"] + s2 * p["a3"]))
    ff = fn("saturate", s2 * (y + p["e"]) * (0.5 + (y - p["e"]) * poly))
    return x["g"] * ff / (p["radius"] * p["radius"])


@_area_form(
    "mrp_sphere",
    "Drobot 2014 (GPU Pro 5) most representative point, via Frostbite 2014 section 4.7.2.5",
    engine=False,
    note="inside the radius, sin^2 a clamped to 1",
)
def _mrp_sphere(let, x, p):
    inv = let("inv_d", 1.0 / fn("max", x["d"], p["radius"]))
    s2 = let("sin2", fn("saturate", p["radius"] * p["radius"] * inv * inv))
    ca = let("cos_a", fn("sqrt", 1.0 - s2))
    c = x["cos_r"]
    near = fn(
        "select",
        fn("ge", c, ca),
        1.0,
        c * ca + fn("sqrt", fn("max", 1.0 - c * c, 0.0)) * fn("sqrt", s2),
    )
    return x["g"] * (2.0 / (1.0 + ca)) * fn("max", near, 0.0) * inv * inv


def _point_light(model: PointLight) -> ShaderForm | None:
    inner = shader_form(model.family)
    if inner is None:
        return None
    x = _inputs()
    result = x["g"] * inner.result * fn("max", x["cos_r"], 0.0)
    return ShaderForm(
        "point_light",
        inner.params,
        inner.lets,
        result,
        f"the point-light model g f(d) max(0, n.l), f: {inner.source}",
        inner.engine,
        inner.note,
        AREA_FORM_INPUTS,
    )


def area_shader_form(model: AreaModel) -> ShaderForm | None:
    """The shader form of `model` (an instance), or None when it has none."""
    if isinstance(model, PointLight):
        return _point_light(model)
    make = _BUILDERS.get(model.name)
    return None if make is None else make(model)


def _values(model: AreaModel, r: float) -> dict[str, float]:
    out = {k: float(np.asarray(v)) for k, v in model.params().items() if np.ndim(v) == 0}
    out["radius"] = float(r)
    return out


def area_function_source(model: AreaModel, lang: str, fname: str, r: float) -> str:
    """The function `fname(d, cos_r, cos_e, cos_n, g)` of `model` in `lang`, `r` baked in."""
    form = area_shader_form(model)
    if form is None:
        raise ValueError(f"area model {model.name!r} has no shader form")
    return print_form(form, lang, fname, _values(model, r), uniforms=False, header=())


def evaluate_area_form(
    model: AreaModel,
    inputs: Mapping[str, Any],
    dtype: Any = np.float32,
) -> np.ndarray:
    """The form of `model` at `inputs` (a mapping with `AREA_FORM_INPUTS` and `r`), every
    operation rounded to `dtype` (`_ir.evaluate_form`); `r` must be one value."""
    form = area_shader_form(model)
    if form is None:
        raise ValueError(f"area model {model.name!r} has no shader form")
    r = float(np.asarray(inputs["r"]).reshape(-1)[0])
    return evaluate_form(form, {k: inputs[k] for k in AREA_FORM_INPUTS}, _values(model, r), dtype)


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
    glsl = print_form(form, "glsl", fname, _values(m, _GENERIC_R), uniforms=False, header=())
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
        from ._ir import Call, _refs

        if isinstance(e, Call):
            if _refs(e, {"d"}, uniform):
                total += SHADER_WEIGHTS.get(names.get(e.op, e.op), 1)
            for a in e.args:
                walk(a)

    for name, expr in form.lets:
        if name not in uniform:
            walk(expr)
    walk(form.result)
    return AreaCompiledCost(model.name, spirv, total, "spirv" if spirv is not None else "estimate")
