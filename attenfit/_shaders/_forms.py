"""The shader form of each family: the expression an engine ships, or a person would write.

One `ShaderForm` per family, written once in the expression language of `_ir` and printed
in every language by `_print`. Where an engine ships the curve, the form transcribes the
engine's code (file and function in `source`); otherwise it is the textbook formula. Unlike
the JAX reference forms of `attenfit.families` (what fitting and the truth comparisons use),
these have no guards: no NaN pass-through, no negative-d branch, no overflow-free hypot.
Each `note` says where the form parts from the reference.

Parameters the engines precompute on the CPU (1/r^2, 1/range) are named temporaries that
read parameters only: a shader compiler folds them when the parameters are baked in.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from .._curves import Family
from .._ir import Expr, Lets, Ref, ShaderForm, fn

__all__ = ["SHADER_FORMS", "shader_form"]

#: family name -> builder of its form (from the instance: static options may change it).
SHADER_FORMS: dict[str, Callable[[Family], ShaderForm]] = {}


def _form(family: str, params: tuple[str, ...], source: str, *, engine: bool, note: str = ""):
    """Register `build(let, d, *params) -> result` as the form of `family`."""

    def deco(build: Callable[..., Expr]) -> Callable[..., Expr]:
        def make(_instance: Family | None = None) -> ShaderForm:
            let = Lets()
            result = build(let, Ref("d", "d"), *(Ref(p, "param") for p in params))
            return ShaderForm(family, params, tuple(let.items), result, source, engine, note)

        SHADER_FORMS[family] = make
        return build

    return deco


def shader_form(family: Family) -> ShaderForm | None:
    """The shader form of `family` (an instance), or None when it has none."""
    if hasattr(family, "shader_form"):  # a model that owns its form (issue 26's end state)
        return family.shader_form()
    make = SHADER_FORMS.get(family.name)
    return None if make is None else make(family)


_OVERFLOW = (
    "d*d overflows float32 beyond d = 1.8e19 and float16 beyond 256 (the reference does not)"
)


# ----------------------------------------------------------------------------- unwindowed
@_form("inverse_square", (), "RTR4 eq. 5.11 (textbook)", engine=False, note=_OVERFLOW)
def _inverse_square(let, d):
    return 1.0 / (d * d)


@_form(
    "unreal_epsilon",
    ("eps",),
    "Unreal CapsuleLightIntegrate.ush (Falloff = 1/(DistSqr + DistBiasSqr), DistBiasSqr from "
    "DeferredLightingCommon.ush::GetCapsule); described, not copied",
    engine=True,
    note=_OVERFLOW,
)
def _unreal_epsilon(let, d, eps):
    return 1.0 / (d * d + eps)


@_form("clamped", ("r_min",), "RTR4 eq. 5.13 (textbook)", engine=False, note=_OVERFLOW)
def _clamped(let, d, r_min):
    m = let("m", fn("max", d, r_min))
    return 1.0 / (m * m)


@_form(
    "yuksel",
    ("r",),
    "Blender EEVEE eevee_light_lib.glsl::light_point_light (Yuksel 2020's rewrite of eq. 7)",
    engine=True,
    note=_OVERFLOW + "; no hypot",
)
def _yuksel(let, d, r):
    d_sqr = let("d_sqr", d * d)
    r_sqr = let("r_sqr", r * r)
    return 2.0 / (d_sqr + r_sqr + d * fn("sqrt", d_sqr + r_sqr))


@_form("yuksel_adhoc", ("r",), "Yuksel 2020 eq. 8 (textbook)", engine=False, note=_OVERFLOW)
def _yuksel_adhoc(let, d, r):
    half_r_sqr = let("half_r_sqr", 0.5 * (r * r))
    return 1.0 / (d * d + half_r_sqr)


@_form("disk_facing", ("r",), "Howell catalogue B-12 (closed form)", engine=False, note=_OVERFLOW)
def _disk_facing(let, d, r):
    return 1.0 / (d * d + r * r)


@_form(
    "polynomial",
    ("kc", "kl", "kq"),
    "OpenGL glLight fixed-function attenuation, in Horner's form",
    engine=False,
    note="one polynomial for every d (the reference switches to 1/d at d > 1)",
)
def _polynomial(let, d, kc, kl, kq):
    return 1.0 / (kc + d * (kl + kq * d))


# ----------------------------------------------------------------------------- Madams
@_form(
    "madams_sphere",
    ("r",),
    "Madams 2011 and its comments: r^2/D^2 clamped at the surface, over r^2",
    engine=False,
    note="1/max(d, r)^2 (the reference adds r back to max(d - r, 0))",
)
def _madams_sphere(let, d, r):
    m = let("m", fn("max", d, r))
    return 1.0 / (m * m)


@_form(
    "madams_cutoff",
    ("r", "cutoff"),
    "Madams 2011, Light attenuation (GLSL DirectIllumination): scale and bias by the cutoff",
    engine=False,
    note="a - cutoff cancels near the range r/sqrt(cutoff) (the reference factors it)",
)
def _madams_cutoff(let, d, r, cutoff):
    r_sqr = let("r_sqr", r * r)
    scale = let("scale", 1.0 / ((1.0 - cutoff) * r_sqr))
    m = let("m", fn("max", d, r))
    return fn("max", r_sqr / (m * m) - cutoff, 0.0) * scale


def _warped(let, d, r, d_max, warped: Expr, ds: Ref) -> Expr:
    x = let("x", warped + r)
    return fn("select", ds < d_max, 1.0 / (x * x), 0.0)


@_form(
    "madams_tan",
    ("r", "d_max"),
    "Madams 2011b, Improved light attenuation: the tan warp (2 d_max/pi for the post's 2.1)",
    engine=False,
    note="tan near its pole as written (the reference uses 1/tan of the complement there)",
)
def _madams_tan(let, d, r, d_max):
    k = let("k", (2.0 / math.pi) * d_max)
    ds = let("ds", fn("max", d - r, 0.0))
    return _warped(let, d, r, d_max, k * fn("tan", ds / k), ds)


@_form(
    "madams_rational",
    ("r", "d_max"),
    "Madams 2011b, Improved light attenuation: the rational warp d/(1 - (d/d_max)^2)",
    engine=False,
    note="1 - (d/d_max)^2 cancels near the range (the reference factors it)",
)
def _madams_rational(let, d, r, d_max):
    inv_d_max = let("inv_d_max", 1.0 / d_max)
    ds = let("ds", fn("max", d - r, 0.0))
    u = let("u", ds * inv_d_max)
    return _warped(let, d, r, d_max, ds / (1.0 - u * u), ds)


# ----------------------------------------------------------------------------- windows
_WINDOW = "1 - x^4 cancels near the range (the reference factors it); " + _OVERFLOW


@_form(
    "unreal_window",
    ("eps", "r_max"),
    "Unreal DeferredLightingCommon.ush::GetLocalLightAttenuation (LightMask) over "
    "CapsuleLightIntegrate.ush's 1/(DistSqr + DistBiasSqr); described, not copied",
    engine=True,
    note=_WINDOW,
)
def _unreal_window(let, d, eps, r_max):
    inv_r_sqr = let("inv_r_sqr", 1.0 / (r_max * r_max))
    dist_sqr = let("dist_sqr", d * d)
    t = let("t", dist_sqr * inv_r_sqr)
    mask = let("mask", fn("saturate", 1.0 - t * t))
    return mask * mask / (dist_sqr + eps)


@_form(
    "frostbite_window",
    ("r_min", "r_max"),
    "Filament shaders/src/light_punctual.fs::getSquareFalloffAttenuation and "
    "getDistanceAttenuation (falloff = 1/r_max^2 from LightManager.cpp::setFalloff)",
    engine=True,
    note=_WINDOW + "; the clamp is on d^2 (max(d^2, r_min^2), as Filament's 1e-4)",
)
def _frostbite_window(let, d, r_min, r_max):
    falloff = let("falloff", 1.0 / (r_max * r_max))
    r_min_sqr = let("r_min_sqr", r_min * r_min)
    distance_square = let("distanceSquare", d * d)
    factor = let("factor", distance_square * falloff)
    smooth = let("smoothFactor", fn("saturate", 1.0 - factor * factor))
    attenuation = let("attenuation", smooth * smooth)
    return attenuation / fn("max", distance_square, r_min_sqr)


@_form(
    "godot",
    ("a", "r_max"),
    "Godot servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl::"
    "get_omni_attenuation (inv_range = 1/range from light_storage.cpp)",
    engine=True,
    note="1 - x^4 cancels near the range (the reference factors it); pow as the engine",
)
def _godot(let, d, a, r_max):
    inv_range = let("inv_range", 1.0 / r_max)
    nd = let("nd", d * inv_range)
    nd2 = let("nd2", nd * nd)
    window = let("window", fn("max", 1.0 - nd2 * nd2, 0.0))
    return window * window * fn("pow", fn("max", d, 0.0001), -a)


def _cryengine(instance: Family | None) -> ShaderForm:
    squared = bool(getattr(instance, "squared", True))
    let = Lets()
    d, r_min, r_max = Ref("d", "d"), Ref("r_min", "param"), Ref("r_max", "param")
    k = let("k", (1.0 / r_max) / 0.2)
    fade = let("fade", fn("saturate", (r_max - d) * k))
    m = let("m", fn("max", d, r_min))
    ramp = fade * fade if squared else fade
    return ShaderForm(
        "cryengine_linear",
        ("r_min", "r_max"),
        tuple(let.items),
        ramp / (m * m),
        "CRYENGINE Engine/Shaders/HWScripts/CryFX/shadeLib.cfi::GetPhysicalLightAttenuation, "
        "divided by the bulb size squared",
        True,
        "1/(1 + max(d - b, 0)/b)^2 / b^2 written as 1/max(d, b)^2; " + _OVERFLOW,
    )


SHADER_FORMS["cryengine_linear"] = _cryengine


@_form(
    "just_cause_2",
    ("scale", "r_max"),
    "RTR4 section 5.2.2 (Just Cause 2; textbook)",
    engine=False,
    note="1 - x^2 cancels near the range (the reference factors it)",
)
def _just_cause_2(let, d, scale, r_max):
    inv_r_sqr = let("inv_r_sqr", 1.0 / (r_max * r_max))
    w = let("w", fn("max", 1.0 - d * d * inv_r_sqr, 0.0))
    return scale * (w * w)


@_form(
    "unreal_exponent",
    ("scale", "r_max", "p"),
    "Unreal DynamicLightingCommon.ush::RadialAttenuation; described, not copied",
    engine=True,
    note="1 - x^2 cancels near the range (the reference factors it); pow as the engine",
)
def _unreal_exponent(let, d, scale, r_max, p):
    inv_r = let("inv_r", 1.0 / r_max)
    t = let("t", d * inv_r)
    return scale * fn("pow", 1.0 - fn("saturate", t * t), p)


@_form(
    "threejs",
    ("decay", "cutoff"),
    "three.js src/renderers/shaders/ShaderChunk/lights_pars_begin.glsl.js::"
    "getDistanceAttenuation (and src/nodes/lighting/LightUtils.js)",
    engine=True,
    note="1 - x^4 cancels near the cutoff (the reference factors it); d/cutoff as d * (1/cutoff)",
)
def _threejs(let, d, decay, cutoff):
    inv_cutoff = let("inv_cutoff", 1.0 / cutoff)
    falloff = let("distanceFalloff", 1.0 / fn("max", fn("pow", d, decay), 0.01))
    x = let("x", d * inv_cutoff)
    x2 = let("x2", x * x)
    w = let("w", fn("saturate", 1.0 - x2 * x2))
    return falloff * (w * w)


@_form(
    "gltf_range",
    ("range",),
    "glTF KHR_lights_punctual README, Range Property; glTF-Sample-Viewer "
    "source/Renderer/shaders/punctual.glsl::getRangeAttenuation (pow written as products)",
    engine=True,
    note="1 - x^4 cancels near the range, 1/d^2 as 1/(d*d) (the reference splits at range/2); "
    + _OVERFLOW,
)
def _gltf_range(let, d, range_):
    inv_range = let("inv_range", 1.0 / range_)
    x = let("x", d * inv_range)
    x2 = let("x2", x * x)
    return fn("clamp", 1.0 - x2 * x2, 0.0, 1.0) / (d * d)


# ----------------------------------------------------------------------------- spots
def _spot_scale(let, umbra, penumbra) -> tuple[Ref, Ref]:
    cos_outer = let("cos_outer", fn("cos", umbra))
    scale = let("scale", 1.0 / fn("max", fn("cos", penumbra) - cos_outer, 0.001))
    return cos_outer, scale


@_form(
    "spot_frostbite",
    ("umbra", "penumbra"),
    "Filament shaders/src/light_punctual.fs::getAngleAttenuation (scale and offset as "
    "LightManager.cpp::setSpotLightCone, floor 0.001 as Frostbite's getAngleAtt)",
    engine=True,
)
def _spot_frostbite(let, d, umbra, penumbra):
    cos_outer, scale = _spot_scale(let, umbra, penumbra)
    offset = let("offset", -cos_outer * scale)
    t = let("t", fn("saturate", d * scale + offset))
    return t * t


@_form(
    "spot_threejs",
    ("umbra", "penumbra"),
    "three.js getSpotAttenuation: smoothstep(coneCos, penumbraCos, angleCos), written out",
    engine=True,
)
def _spot_threejs(let, d, umbra, penumbra):
    cos_outer, scale = _spot_scale(let, umbra, penumbra)
    t = let("t", fn("saturate", (d - cos_outer) * scale))
    return t * t * (3.0 - 2.0 * t)
