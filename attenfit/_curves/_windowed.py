"""Engine falloffs with a range window: Unreal, Frostbite/Filament/Bevy, Godot, CryEngine, Just
Cause 2, Unreal's exponent mode, three.js and glTF (RTR4 section 5.2.2 and each engine's code)."""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
from jaxtyping import ArrayLike, Float

from .._ir import fn
from . import _parts as parts
from ._family import Family, Out, Param, jit_call, register_family
from ._forms import OVERFLOW, shader

__all__ = [
    "CryEngineLinear",
    "FrostbiteWindow",
    "GltfRange",
    "Godot",
    "JustCause2",
    "ThreeJS",
    "UnrealExponent",
    "UnrealWindow",
]

#: The `note` of a form with the engines' 1 - x^4 window.
_WINDOW = "1 - x^4 cancels near the range (the reference factors it); " + OVERFLOW


# ----------------------------------------------------------------------------- windowed engines
@register_family
class UnrealWindow(Family):
    """Unreal's inverse-squared falloff, f = 1/(d^2 + eps) (1 - (d/r_max)^4)+^2 (RTR4 eq. 5.14).

    Unreal Engine `DeferredLightingCommon.ush::GetLocalLightAttenuation` (LightMask =
    saturate(1 - (d^2/r^2)^2)^2) times `CapsuleLightIntegrate.ush`'s 1/(d^2 + 1 cm^2); Karis
    2013. eps in m^2 (default 1e-4 = 1 cm^2), r_max (AttenuationRadius) in m.
    """

    eps: Param = 1e-4
    r_max: Param = 10.0

    name = "unreal_window"
    formula = "1/(d^2 + eps) * (1 - (d/r_max)^4)+^2"
    source = "RTR4 eq. 5.14; Unreal DeferredLightingCommon.ush::GetLocalLightAttenuation"
    default_free = ("eps",)
    length_params = ("r_max",)
    units: ClassVar = {"eps": 2}
    range_param = "r_max"
    window = "smooth"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, eps, r_max = parts.promote(d, self.eps, self.r_max)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.softened_inverse_square(d, jnp.sqrt(eps)) * parts.smooth_window(d, r_max)
        )

    @shader(
        "Unreal DeferredLightingCommon.ush::GetLocalLightAttenuation (LightMask) over "
        "CapsuleLightIntegrate.ush's 1/(DistSqr + DistBiasSqr); described, not copied",
        engine=True,
        note=_WINDOW,
    )
    def shader_form(self, let, d, eps, r_max):
        inv_r_sqr = let("inv_r_sqr", 1.0 / (r_max * r_max))
        dist_sqr = let("dist_sqr", d * d)
        t = let("t", dist_sqr * inv_r_sqr)
        mask = let("mask", fn("saturate", 1.0 - t * t))
        return mask * mask / (dist_sqr + eps)


@register_family
class FrostbiteWindow(Family):
    """Frostbite's windowed inverse square, f = (1 - (d/r_max)^4)+^2 / max(d, r_min)^2.

    Lagarde and de Rousiers 2014, "Moving Frostbite to PBR", eq. 26 (E_window1, n = 4) and
    listing `getDistanceAtt` (`smoothDistanceAtt / max(d^2, 0.01^2)`: "point lights are
    considered to have a radius of 1cm"). The same form is in Filament
    `light_punctual.fs::getDistanceAttenuation` (max(d^2, 1e-4)), Bevy `pbr_lighting.wgsl`
    and Unity URP `RealtimeLights.hlsl::DistanceAttenuation` (clamp d^2 >= 2^-14). r_min
    (default 0.01 m) and r_max (default 10 m) in m.
    """

    r_min: Param = 0.01
    r_max: Param = 10.0

    name = "frostbite_window"
    formula = "(1 - (d/r_max)^4)+^2 / max(d, r_min)^2"
    source = "Lagarde & de Rousiers 2014, Moving Frostbite to PBR, eq. 26 and getDistanceAtt; Filament light_punctual.fs"
    default_free = ("r_min",)
    length_params = ("r_min", "r_max")
    clamp_param = "r_min"  # f = window(d) / max(d, r_min)^2
    range_param = "r_max"
    window = "smooth"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r_min, r_max = parts.promote(d, self.r_min, self.r_max)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.clamped_inverse_square(d, r_min) * parts.smooth_window(d, r_max)
        )

    @shader(
        "Filament shaders/src/light_punctual.fs::getSquareFalloffAttenuation and "
        "getDistanceAttenuation (falloff = 1/r_max^2 from LightManager.cpp::setFalloff)",
        engine=True,
        note=_WINDOW + "; the clamp is on d^2 (max(d^2, r_min^2), as Filament's 1e-4)",
    )
    def shader_form(self, let, d, r_min, r_max):
        falloff = let("falloff", 1.0 / (r_max * r_max))
        r_min_sqr = let("r_min_sqr", r_min * r_min)
        distance_square = let("distanceSquare", d * d)
        factor = let("factor", distance_square * falloff)
        smooth = let("smoothFactor", fn("saturate", 1.0 - factor * factor))
        attenuation = let("attenuation", smooth * smooth)
        return attenuation / fn("max", distance_square, r_min_sqr)


@register_family
class Godot(Family):
    """Godot 4's omni attenuation, f = (1 - (d/r_max)^4)+^2 / max(d, 1e-4)^a.

    Godot `servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl::
    get_omni_attenuation` (the clamp is on d, at 1e-4 m). `a` is `omni_attenuation`,
    default 1 (Godot's default; 2 is inverse square, 0 keeps the brightness constant up to
    the window), r_max is `omni_range` (Godot's default is 5 m; 10 m here like the other
    ranges). Not normalised to 1/d^2 unless a = 2, and not scale-covariant (fixed 1e-4 m).
    """

    a: Param = 1.0
    r_max: Param = 10.0

    name = "godot"
    formula = "(1 - (d/r_max)^4)+^2 / max(d, 1e-4)^a"
    source = "Godot 4 scene_forward_lights_inc.glsl::get_omni_attenuation"
    default_free = ("a",)
    constraints: ClassVar = {"a": "nonnegative"}
    length_params = ("r_max",)
    range_param = "r_max"
    window = "smooth"

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, a, r_max = parts.promote(d, self.a, self.r_max)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.smooth_window(d, r_max) * parts.power_min_distance(d, a, 1e-4)
        )

    @shader(
        "Godot servers/rendering/renderer_rd/shaders/scene_forward_lights_inc.glsl::"
        "get_omni_attenuation (inv_range = 1/range from light_storage.cpp)",
        engine=True,
        note="1 - x^4 cancels near the range (the reference factors it); pow as the engine",
    )
    def shader_form(self, let, d, a, r_max):
        inv_range = let("inv_range", 1.0 / r_max)
        nd = let("nd", d * inv_range)
        nd2 = let("nd2", nd * nd)
        window = let("window", fn("max", 1.0 - nd2 * nd2, 0.0))
        return window * window * fn("pow", fn("max", d, 0.0001), -a)


@register_family
class CryEngineLinear(Family):
    """CryEngine's physical light, f = fade^2 / max(d, r_min)^2, fade linear over the last 20%.

    CRYENGINE 5 `Engine/Shaders/HWScripts/CryFX/shadeLib.cfi::GetPhysicalLightAttenuation`:
    fade = saturate((r_max - d)/(0.2 r_max)), result fade^2 / (1 + max(d - b, 0)/b)^2 =
    fade^2 min(1, (b/d)^2) with the bulb radius b = r_min (`fAttenuationBulbSize`, default
    0.05 m; `Radius` default 10 m). The engine normalises to 1 inside the bulb (its intensity
    is the value at the bulb); here f is divided by r_min^2 so it tends to 1/d^2 like the
    others. The engine squares the ramp (zero slope at r_max, a kink at 0.8 r_max); RTR4
    describes the plain linear ramp: `squared=False` (a static option) gives that (only C0 at
    r_max). Declared a "hard" window because the plain option is.
    """

    r_min: Param = 0.05
    r_max: Param = 10.0
    squared: bool = eqx.field(static=True, default=True)

    name = "cryengine_linear"
    formula = "fade^2 / max(d, r_min)^2, fade = clamp((r_max - d)/(0.2 r_max), 0, 1)  [fade, not squared, with squared=False]"
    source = "CRYENGINE shadeLib.cfi::GetPhysicalLightAttenuation; RTR4 section 5.2.2 (linear tail)"
    default_free = ("r_min",)
    length_params = ("r_min", "r_max")
    at_radius: ClassVar = {"r_min": (1.0, 1)}  # the bulb radius (fAttenuationBulbSize)
    clamp_param = "r_min"  # f = fade(d)^2 / max(d, r_min)^2
    range_param = "r_max"
    window = "hard"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r_min, r_max = parts.promote(d, self.r_min, self.r_max)
        d = parts.distance(d)
        fade = parts.linear_tail_window(d, r_max, 0.2, 2 if self.squared else 1)
        return parts.keep_nan(d, parts.clamped_inverse_square(d, r_min) * fade)

    @shader(
        "CRYENGINE Engine/Shaders/HWScripts/CryFX/shadeLib.cfi::GetPhysicalLightAttenuation, "
        "divided by the bulb size squared",
        engine=True,
        note="1/(1 + max(d - b, 0)/b)^2 / b^2 written as 1/max(d, b)^2; " + OVERFLOW,
    )
    def shader_form(self, let, d, r_min, r_max):
        k = let("k", (1.0 / r_max) / 0.2)
        fade = let("fade", fn("saturate", (r_max - d) * k))
        m = let("m", fn("max", d, r_min))
        return (fade * fade if self.squared else fade) / (m * m)


@register_family
class JustCause2(Family):
    """Just Cause 2's falloff, f = scale (1 - (d/r_max)^2)+^2 (RTR4 section 5.2.2).

    RTR4 attributes it to Persson, "Making it Large, Beautiful, Fast, and Consistent: Lessons
    Learned Developing Just Cause 2", GPU Pro (2010); no primary code found. Not inverse
    square: a free `scale` (1/m^2) stands in for the normalisation. r_max in m.
    """

    scale: Param = 1.0
    r_max: Param = 10.0

    name = "just_cause_2"
    formula = "scale * (1 - (d/r_max)^2)+^2"
    source = "RTR4 section 5.2.2 (Just Cause 2; Persson, GPU Pro 2010)"
    default_free = ("scale", "r_max")
    length_params = ("r_max",)
    units: ClassVar = {"scale": -2}
    range_param = "r_max"
    window = "smooth"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, scale, r_max = parts.promote(d, self.scale, self.r_max)
        return parts.keep_nan(d, scale * parts.smooth_window(parts.distance(d), r_max, 2, 2))

    @shader(
        "RTR4 section 5.2.2 (Just Cause 2; textbook)",
        engine=False,
        note="1 - x^2 cancels near the range (the reference factors it)",
    )
    def shader_form(self, let, d, scale, r_max):
        inv_r_sqr = let("inv_r_sqr", 1.0 / (r_max * r_max))
        w = let("w", fn("max", 1.0 - d * d * inv_r_sqr, 0.0))
        return scale * (w * w)


@register_family
class UnrealExponent(Family):
    """Unreal's non-inverse-squared mode, f = scale (1 - (d/r_max)^2)+^p.

    Unreal `DynamicLightingCommon.ush::RadialAttenuation` (mask 1 - saturate(|v|^2), v = toLight
    / r, raised to `LightFalloffExponent`, default 8: "2 is almost linear ... around 8 it looks
    reasonable"); with `bUseInverseSquaredFalloff` off there is no 1/d^2 term. A free `scale`
    (1/m^2) stands in for the normalisation. Smooth at r_max for p > 1. r_max in m.
    """

    scale: Param = 1.0
    r_max: Param = 10.0
    p: Param = 8.0

    name = "unreal_exponent"
    formula = "scale * (1 - (d/r_max)^2)+^p"
    source = "RTR4 section 5.2.2; Unreal DynamicLightingCommon.ush::RadialAttenuation"
    default_free = ("scale", "p")
    length_params = ("r_max",)
    units: ClassVar = {"scale": -2}
    range_param = "r_max"
    window = "smooth"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, scale, r_max, p = parts.promote(d, self.scale, self.r_max, self.p)
        return parts.keep_nan(d, scale * parts.smooth_window(parts.distance(d), r_max, 2, p))

    @shader(
        "Unreal DynamicLightingCommon.ush::RadialAttenuation; described, not copied",
        engine=True,
        note="1 - x^2 cancels near the range (the reference factors it); pow as the engine",
    )
    def shader_form(self, let, d, scale, r_max, p):
        inv_r = let("inv_r", 1.0 / r_max)
        t = let("t", d * inv_r)
        return scale * fn("pow", 1.0 - fn("saturate", t * t), p)


@register_family
class ThreeJS(Family):
    """three.js punctual lights, f = (1 - (d/cutoff)^4)+^2 / max(d^decay, 0.01).

    three.js `src/nodes/lighting/LightUtils.js::getDistanceAttenuation` (and the GLSL
    `lights_pars_begin.glsl.js`) since r155 (physically correct lights): the clamp is on
    d^decay, so for decay = 2 distances below 10 cm read as 10 cm. `decay` default 2 (three.js
    default since PR #23897), `cutoff` (three.js `distance`) default 10 m here; three.js's
    default distance 0 means no window, which this family does not model (use a large cutoff).
    Not scale-covariant (fixed 0.01 floor).
    """

    decay: Param = 2.0
    cutoff: Param = 10.0

    name = "threejs"
    formula = "(1 - (d/cutoff)^4)+^2 / max(d^decay, 0.01)"
    source = "three.js src/nodes/lighting/LightUtils.js::getDistanceAttenuation (r155+)"
    default_free = ("decay",)
    length_params = ("cutoff",)
    range_param = "cutoff"
    window = "smooth"

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, decay, cutoff = parts.promote(d, self.decay, self.cutoff)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.power_clamped_value(d, decay, 0.01) * parts.smooth_window(d, cutoff)
        )

    @shader(
        "three.js src/renderers/shaders/ShaderChunk/lights_pars_begin.glsl.js::"
        "getDistanceAttenuation (and src/nodes/lighting/LightUtils.js)",
        engine=True,
        note="1 - x^4 cancels near the cutoff (the reference factors it); d/cutoff as d * "
        "(1/cutoff)",
    )
    def shader_form(self, let, d, decay, cutoff):
        inv_cutoff = let("inv_cutoff", 1.0 / cutoff)
        falloff = let("distanceFalloff", 1.0 / fn("max", fn("pow", d, decay), 0.01))
        x = let("x", d * inv_cutoff)
        x2 = let("x2", x * x)
        w = let("w", fn("saturate", 1.0 - x2 * x2))
        return falloff * (w * w)


@register_family
class GltfRange(Family):
    """glTF KHR_lights_punctual's recommended falloff, f = clamp(1 - (d/range)^4, 0, 1)/d^2.

    KhronosGroup/glTF `extensions/2.0/Khronos/KHR_lights_punctual/README.md`, section "Range
    Property" (and glTF-Sample-Viewer `punctual.glsl::getRangeAttenuation`). Unlike the
    engines the window is not squared, so the curve reaches 0 at `range` (m) with a non-zero
    slope. No near clamp: honestly singular, +inf where 1/d^2 overflows (d = 0 included).
    """

    range: Param = 10.0

    name = "gltf_range"
    formula = "clamp(1 - (d/range)^4, 0, 1) / d^2"
    source = "glTF KHR_lights_punctual README, Range Property"
    default_free = ("range",)
    length_params = ("range",)
    range_param = "range"
    window = "hard"
    singular = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, rng = parts.promote(d, self.range)
        d = parts.distance(d)
        # Near the light (d < range/2) as 1/d^2 - d^2/range^4: no cancellation there (the
        # second term is < 1/16 of the first) and no 0 * inf in the gradient at d = 0.
        near = d < rng / 2
        x = jnp.where(near, d, jnp.zeros_like(d)) / rng
        f_near = parts.inverse_square(d) - (x / rng) * (x / rng)
        f_far = parts.inverse_square(jnp.where(near, rng, d)) * parts.smooth_window(d, rng, 4, 1)
        return parts.keep_nan(d, jnp.where(near, f_near, f_far))

    @shader(
        "glTF KHR_lights_punctual README, Range Property; glTF-Sample-Viewer "
        "source/Renderer/shaders/punctual.glsl::getRangeAttenuation (pow written as "
        "products)",
        engine=True,
        note="1 - x^4 cancels near the range, 1/d^2 as 1/(d*d) (the reference splits at "
        "range/2); " + OVERFLOW,
    )
    def shader_form(self, let, d, range_):
        inv_range = let("inv_range", 1.0 / range_)
        x = let("x", d * inv_range)
        x2 = let("x2", x * x)
        return fn("clamp", 1.0 - x2 * x2, 0.0, 1.0) / (d * d)
