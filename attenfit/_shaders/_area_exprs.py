"""The shader form of each area model: the engine's code its model cites, written once in the
expression language of `_ir` and printed in every language by `_print`.

An area model's form is a `ShaderForm` of five per-receiver inputs (`AREA_FORM_INPUTS`: the
distance, the cosine at the receiver, the cosine at the emitter, the normal against a disk's
axis, the emitter factor) and its parameters plus the light's radius `r`, named `radius` in
the form (a family's own `r` keeps its name). Each transcribes the engine's function its
model cites (`attenfit._curves._area_models`), with the engine's clamps; `note` says where it
parts from the JAX reference. `PointLight(family)`'s form is the family's own form (`_forms`)
times `g max(0, cos_r)`: the point-light model in the same terms.

`area_function_source` prints a form with the radius baked in (what the compiled cost
counts); `area_export_form` makes the radius the input `r`, in `AREA_INPUTS` order (what
`export` prints, `_area_export`). Imports no compiler (`_compilers` imports `_export`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .._curves import AREA_INPUTS, AreaModel, PointLight
from .._ir import Call, Expr, Lets, Ref, ShaderForm, evaluate_form, fn
from ._forms import shader_form
from ._print import print_form

__all__ = [
    "AREA_FORM_INPUTS",
    "area_export_form",
    "area_function_source",
    "area_shader_form",
    "baked_values",
    "evaluate_area_form",
]

#: The per-receiver inputs of an area model's form, in argument order.
AREA_FORM_INPUTS = ("d", "cos_r", "cos_e", "cos_n", "g")

_BUILDERS: dict[str, Callable[[AreaModel], ShaderForm]] = {}
_PI = math.pi


def _inputs() -> dict[str, Ref]:
    return {x: Ref(x, "d") for x in AREA_FORM_INPUTS}


def _area_form(name: str, source: str, *, engine: bool, note: str = ""):
    """Register `build(let, x, p, model) -> result` as the form of area model `name`; `x` are
    the inputs, `p` the parameters (the model's and `radius`) as `Ref`s, `model` the instance
    (for its static options)."""

    def deco(build: Callable[..., Expr]) -> Callable[..., Expr]:
        def make(model: AreaModel) -> ShaderForm:
            let = Lets()
            params = (*model.param_names(), "radius")
            p = {k: Ref(k, "param") for k in params}
            result = build(let, _inputs(), p, model)
            return ShaderForm(
                name, params, tuple(let.items), result, source, engine, note, AREA_FORM_INPUTS
            )

        _BUILDERS[name] = make
        return build

    return deco


def _illuminance(let: Lets, cos_theta: Expr, sin2: Expr, tag: str) -> Ref:
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
def _snyder_sphere(let, x, p, _model):
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
def _frostbite_disk(let, x, p, _model):
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
def _vector_disk(let, x, p, model):
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
    if getattr(model, "clip", "cap") == "clamp":  # max(0, n.F) where the horizon cuts it too
        e_clip: Expr = e_vec
    else:
        f_len = let("f_len", fn("sqrt", q * q + 4.0 * z * z * s2))  # |F| den / r^2
        sin2 = let("cap_sin2", fn("min", r2 * f_len / den, 0.9999))
        cos_w = let("cap_cos", fn("clamp", num / f_len, -0.999, 0.999))
        e_clip = _illuminance(let, cos_w, sin2, "cap_") * (f_len / (_PI * sin2 * den))
    w = let("w", fn("sqrt", fn("max", 1.0 - cn * cn, 0.0)))
    above = fn("ge", d * cr, p["radius"] * w)
    lit = fn("select", ce > 0.0, fn("select", above, e_vec, e_clip), 0.0)
    return fn("select", d * cr > -p["radius"] * w, lit, 0.0)


@_area_form(
    "unreal_wrap",
    "Unreal Engine CapsuleLight.ush::SphereHorizonCosWrap; described, not copied",
    engine=True,
    note="the sphere's 1/max(d, r)^2 for the engine's 1/(d^2 + 1 cm^2)",
)
def _unreal_wrap(let, x, p, _model):
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
def _godot_wrap(let, x, p, _model):
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
def _hdrp_sphere(let, x, p, _model):
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
def _mrp_sphere(let, x, p, _model):
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
    if hasattr(model, "shader_form"):  # a model that owns its form (issue 26's end state)
        return model.shader_form()
    if isinstance(model, PointLight):
        return _point_light(model)
    make = _BUILDERS.get(model.name)
    return None if make is None else make(model)


def area_export_form(model: AreaModel) -> tuple[ShaderForm, dict[str, str]] | None:
    """The form `export` prints: `model`'s shader form with the light's radius an input, the
    six inputs in `AREA_INPUTS` order (`d, cos_r, cos_e, r, cos_n, g`, as `AreaModel.__call__`
    takes them), and the names it renamed (a parameter or temporary named like an input,
    e.g. the family `r` of `PointLight(Yuksel())`, gets a `_param`/`_let` suffix), or None
    when the model has no shader form."""
    form = area_shader_form(model)
    if form is None:
        return None
    swap: dict[tuple[str, str], Ref] = {}
    if not isinstance(model, PointLight):  # a point light reads no radius
        swap[("radius", "param")] = Ref("r", "d")
    taken = set(AREA_INPUTS) | set(form.params) | {n for n, _ in form.lets}
    renamed: dict[str, str] = {}
    for name, kind in [*((p, "param") for p in form.params), *((n, "let") for n, _ in form.lets)]:
        if name in AREA_INPUTS and (name, kind) not in swap:
            new = f"{name}_{kind}"
            while new in taken:
                new += "_"
            taken.add(new)
            renamed[name] = new
            swap[(name, kind)] = Ref(new, kind)

    def sub(e: Expr) -> Expr:
        if isinstance(e, Ref):
            return swap.get((e.name, e.kind), e)
        if isinstance(e, Call):
            return Call(e.op, tuple(sub(a) for a in e.args))
        return e

    radius_input = ("radius", "param") in swap
    kept = [p for p in form.params if not (radius_input and p == "radius")]
    params = tuple(renamed.get(p, p) for p in kept)
    lets = tuple((renamed.get(n, n), sub(e)) for n, e in form.lets)
    out = ShaderForm(form.family, params, lets, sub(form.result), form.source, form.engine,
                     form.note, AREA_INPUTS)  # fmt: skip
    return out, renamed


def baked_values(model: AreaModel, r: float) -> dict[str, float]:
    """The form's parameter values with the radius `r` baked in (scalar parameters only)."""
    out = {k: float(np.asarray(v)) for k, v in model.params().items() if np.ndim(v) == 0}
    out["radius"] = float(r)
    return out


def area_function_source(model: AreaModel, lang: str, fname: str, r: float) -> str:
    """The function `fname(d, cos_r, cos_e, cos_n, g)` of `model` in `lang`, `r` baked in."""
    form = area_shader_form(model)
    if form is None:
        raise ValueError(f"area model {model.name!r} has no shader form")
    return print_form(form, lang, fname, baked_values(model, r), uniforms=False, header=())


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
    return evaluate_form(
        form, {k: inputs[k] for k in AREA_FORM_INPUTS}, baked_values(model, r), dtype
    )
