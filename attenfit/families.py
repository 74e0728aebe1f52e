"""The named attenuation families (DESIGN.md section 2), all registered.

Each family is a small final `eqx.Module` whose fields are its parameters (scalars, or arrays
that broadcast with `d`) and whose `__call__` is a product of the parts in `attenfit._parts`:
a base falloff, optionally a distance warp, optionally a range window. `d` is the distance
from the light's centre; lengths are in metres for the engine defaults; `f` is in 1/m^2 and,
for the physically motivated families, tends to 1/d^2 far from the light.

Common behaviour (tested for every registered family):

- any float dtype in, the same dtype out (the widest of `d` and non-weak parameters);
- negative `d` is treated as 0, NaN gives NaN, +inf gives 0 (1/inf^2);
- values are finite and non-negative everywhere, except `inverse_square` and `gltf_range`,
  which return +inf where 1/d^2 overflows (d = 0 included), never NaN;
- gradients with respect to `d` and every parameter are finite wherever the value is.
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from . import _parts as parts
from ._family import Family, register_family

__all__ = [
    "Clamped",
    "CryEngineLinear",
    "DiskFacing",
    "FrostbiteWindow",
    "GltfRange",
    "Godot",
    "InverseSquare",
    "JustCause2",
    "MadamsCutoff",
    "MadamsRational",
    "MadamsSphere",
    "MadamsTan",
    "Polynomial",
    "Spline",
    "ThreeJS",
    "UnrealEpsilon",
    "UnrealExponent",
    "UnrealWindow",
    "Yuksel",
    "YukselAdhoc",
]

Param = Float[ArrayLike, "*batch"]


def _jit_call(call):
    """Compile a family's `__call__` once per shape and dtype (not per parameter value).

    Parameters and `d` are turned into arrays first (Python numbers stay weakly typed), so
    `eqx.filter_jit` traces them instead of baking their values in; inside a caller's own
    `jit`/`vmap`/`grad` this is simply inlined. Eager calls then cost one dispatch instead of
    one per primitive.
    """
    jitted = eqx.filter_jit(call)

    @functools.wraps(call)
    def wrapper(self, d):
        self = jax.tree_util.tree_map(jnp.asarray, self)
        return jitted(self, jnp.asarray(d))

    return wrapper


Out = Float[Array, "*shape"]


def _warped_sphere_range(r: Param, d_max: Param) -> Array:
    """The centre distance r + d_max where a Madams warped sphere reaches 0 (m)."""
    r, d_max = parts.promote(r, d_max)
    return r + d_max


def _warped_sphere(warp, d: Float[ArrayLike, "*shape"], r: Param, d_max: Param) -> Out:
    """Madams' sphere 1/(d' + r)^2 on the surface distance warped by `warp`, 0 beyond d_max.

    `warp(d_s, d_max, gap) -> (d', inside)` is `parts.tan_warp` or `parts.rational_warp`
    (Madams 2011b, Improved light attenuation); shared by `MadamsTan` and `MadamsRational`.
    """
    d, r, d_max = parts.promote(d, r, d_max)
    d = parts.distance(d)
    gap = parts.surface_gap(d, r, d_max)
    warped, inside = warp(parts.surface_distance(d, r), d_max, gap)
    f = parts.surface_sphere(warped, r)
    return parts.keep_nan(d, jnp.where(inside, f, jnp.zeros_like(f)))


# ----------------------------------------------------------------------------- inverse square
@register_family
class InverseSquare(Family):
    """Inverse-square attenuation, f = 1/d^2 (RTR4 section 5.2.2, eq. 5.11).

    The correct law for an ideal point light. Honestly singular: +inf at d = 0 and wherever
    1/d^2 overflows the dtype (e.g. d < 5.4e-20 in float32), never NaN. No parameters.
    """

    name = "inverse_square"
    formula = "1/d^2"
    source = "Akenine-Moller et al., Real-Time Rendering 4th ed. (RTR4), eq. 5.11"
    default_free = ()
    singular = True
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        (d,) = parts.promote(d)
        return parts.keep_nan(d, parts.inverse_square(parts.distance(d)))


@register_family
class UnrealEpsilon(Family):
    """Unreal's softened inverse square, f = 1/(d^2 + eps) (RTR4 eq. 5.12).

    Unreal Engine 4/5 `CapsuleLightIntegrate.ush` (`Falloff = 1/(d^2 + DistBiasSqr)`, with
    `DistBiasSqr = 1` set in `DeferredLightingCommon.ush::GetCapsule`) works in centimetres, so
    eps = 1 cm^2 = 1e-4 m^2 (the default). `eps` is an area (m^2). f(0) = 1/eps.
    """

    eps: Param = 1e-4

    name = "unreal_epsilon"
    formula = "1/(d^2 + eps)"
    source = "RTR4 eq. 5.12; Unreal Engine CapsuleLightIntegrate.ush (DistBiasSqr = 1 cm^2)"
    default_free = ("eps",)
    units: ClassVar = {"eps": 2}
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, eps = parts.promote(d, self.eps)
        return parts.keep_nan(d, parts.softened_inverse_square(parts.distance(d), jnp.sqrt(eps)))


@register_family
class Clamped(Family):
    """Inverse square with the distance clamped, f = 1/max(d, r_min)^2 (RTR4 eq. 5.13).

    Used by CryEngine and Frostbite; r_min (m) is the radius of the physical emitter, so
    d < r_min would be inside it. Default r_min = 0.1 m (the default light radius). f(0) =
    1/r_min^2; the slope has a kink at r_min.
    """

    r_min: Param = 0.1

    name = "clamped"
    formula = "1/max(d, r_min)^2"
    source = "RTR4 eq. 5.13 (CryEngine, Frostbite)"
    default_free = ("r_min",)
    length_params = ("r_min",)
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r_min = parts.promote(d, self.r_min)
        return parts.keep_nan(d, parts.clamped_inverse_square(parts.distance(d), r_min))


# ----------------------------------------------------------------------------- Yuksel and disk
@register_family
class Yuksel(Family):
    """Yuksel's non-singular attenuation, f = 2/r^2 (1 - d/sqrt(d^2 + r^2)) (Yuksel 2020 eq. 7).

    C. Yuksel, "Point Light Attenuation Without Singularity", SIGGRAPH 2020 Talks, eq. 7: a
    point light of radius r (m) treated as a facing disk of radiance 1/(pi r^2); f is that
    disk's solid angle times its radiance, without the cosine factor. Evaluated in the
    cancellation-free form 2/(s (s + d)), s = hypot(d, r) (the project page's rewrite, used by
    Blender EEVEE `eevee_light_lib.glsl::light_point_light`): the naive eq. 7 loses every digit
    for d >> r in float32. f(0) = 2/r^2; f -> 1/d^2 (1 + 3/4 r^2/d^2 ...)^-1 far away.
    """

    r: Param = 0.1

    name = "yuksel"
    formula = "2/(s (s + d)), s = sqrt(d^2 + r^2)  [= 2/r^2 (1 - d/sqrt(d^2 + r^2))]"
    source = "Yuksel 2020, Point Light Attenuation Without Singularity, eq. 7"
    default_free = ("r",)
    length_params = ("r",)
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(d, parts.yuksel(parts.distance(d), r))


@register_family
class YukselAdhoc(Family):
    """Yuksel's version of the ad hoc softening, f = 1/(d^2 + r^2/2) (Yuksel 2020 eq. 8).

    Same value at d = 0 as eq. 7 (2/r^2) and, as the talk says, bounded by eq. 7 and by
    inverse square. Equals the exact facing-disk irradiance of a disk of radius r/sqrt(2).
    r in m.
    """

    r: Param = 0.1

    name = "yuksel_adhoc"
    formula = "1/(d^2 + r^2/2)"
    source = "Yuksel 2020, Point Light Attenuation Without Singularity, eq. 8"
    default_free = ("r",)
    length_params = ("r",)
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(
            d, parts.softened_inverse_square(parts.distance(d), r * math.sqrt(0.5))
        )


@register_family
class DiskFacing(Family):
    """The exact facing-disk attenuation, f = 1/(d^2 + r^2).

    Irradiance on the axis of a Lambertian disk of radius r (m) and radiance 1/(pi r^2)
    (unit intensity), at distance d, receiver facing it: E = pi L sin^2(sigma) = 1/(d^2 + r^2)
    (Howell's catalogue B-12; groundtruth.md section 4). The Madams thread remarks that his
    curve is really a disc light's. f(0) = 1/r^2.
    """

    r: Param = 0.1

    name = "disk_facing"
    formula = "1/(d^2 + r^2)"
    source = "closed form (Howell catalogue B-12); Madams 2011 comment thread"
    default_free = ("r",)
    length_params = ("r",)
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(d, parts.softened_inverse_square(parts.distance(d), r))


@register_family
class Polynomial(Family):
    """Fixed-function attenuation, f = 1/(kc + kl d + kq d^2).

    OpenGL `glLight` (GL_CONSTANT/LINEAR/QUADRATIC_ATTENUATION), Direct3D 9 and Ogre RTSS
    `getDistanceAttenuation`. Madams 2011 reads it as a sphere of radius r with kc = 1,
    kl = 2/r, kq = 1/r^2 in surface distance (normalised to 1 at the surface); in this
    project's normalisation the defaults kc = r^2 = 0.01 m^2, kl = 2r = 0.2 m, kq = 1
    (r = 0.1 m) give 1/(d + r)^2. All coefficients are non-negative; with kc = 0 the family
    is singular at d = 0 like inverse square. Evaluated in two branches so nothing overflows.
    """

    kc: Param = 0.01
    kl: Param = 0.2
    kq: Param = 1.0

    name = "polynomial"
    formula = "1/(kc + kl d + kq d^2)"
    source = "OpenGL glLight fixed-function attenuation; Madams 2011 (kc=1, kl=2/r, kq=1/r^2)"
    default_free = ("kc", "kl", "kq")
    constraints: ClassVar = {"kc": "nonnegative", "kl": "nonnegative", "kq": "nonnegative"}
    length_params = ("kl",)
    units: ClassVar = {"kc": 2}
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, kc, kl, kq = parts.promote(d, self.kc, self.kl, self.kq)
        return parts.keep_nan(d, parts.polynomial(parts.distance(d), kc, kl, kq))


# ----------------------------------------------------------------------------- Madams
@register_family
class MadamsSphere(Family):
    """Madams' spherical-light attenuation, f = 1/(d_s + r)^2 = 1/max(d, r)^2.

    T. Madams, "Light attenuation" (2011-01-31): 1/(d_s/r + 1)^2 with d_s = max(d - r, 0) the
    distance from the light's surface (the post's GLSL `DirectIllumination`), divided by r^2
    so that it tends to 1/d^2; a comment gives the equivalent centre-distance form r^2/D^2
    clamped at r. r in m.
    """

    r: Param = 0.1

    name = "madams_sphere"
    formula = "1/(d_s + r)^2, d_s = max(d - r, 0)  [= 1/max(d, r)^2]"
    source = "Madams 2011, Light attenuation (imdoingitwrong.wordpress.com), and its comments"
    default_free = ("r",)
    length_params = ("r",)
    tends_to_inverse_square = True
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(
            d, parts.surface_sphere(parts.surface_distance(parts.distance(d), r), r)
        )


@register_family
class MadamsCutoff(Family):
    """Madams' sphere with a scale-and-bias cutoff, f = (1/r^2) max(0, (a - c)/(1 - c)).

    a = r^2/max(d, r)^2 is the post's attenuation (1 at the surface), c = `cutoff` the
    threshold below which light is ignored (Madams 2011, GLSL `DirectIllumination`; the post
    shows c = 0.001 and 0.005). It reaches 0 at the centre distance r/sqrt(c) (the post's
    d_max = r (sqrt(Li/Ic) - 1) from the surface, with Li = 1) with a non-zero slope (a hard
    edge, the problem the follow-up post fixes). Peak value 1/r^2 is unchanged.
    """

    r: Param = 0.1
    cutoff: Param = 0.001

    name = "madams_cutoff"
    formula = "(1/r^2) max(0, (a - cutoff)/(1 - cutoff)), a = r^2/max(d, r)^2"
    source = "Madams 2011, Light attenuation: scale and bias by the cutoff threshold"
    default_free = ("r",)
    constraints: ClassVar = {"cutoff": "unit"}
    length_params = ("r",)
    window = "hard"
    scale_covariant = True

    def range_distance(self) -> Array:
        """The centre distance r/sqrt(cutoff) where the curve reaches 0."""
        r, c = parts.promote(self.r, self.cutoff)
        return r / jnp.sqrt(c)

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r, c = parts.promote(d, self.r, self.cutoff)
        return parts.keep_nan(d, parts.cutoff_bias(parts.distance(d), r, c) / (r * r))


@register_family
class MadamsTan(Family):
    """Madams' sphere with the tan distance warp, f = 1/(d' + r)^2, 0 beyond d_max.

    T. Madams, "Improved light attenuation" (2011-02-10), after J. Scholler: the surface
    distance d_s = max(d - r, 0) is warped to d' = (2 d_max/pi) tan(pi d_s/(2 d_max)), which
    tends to infinity at d_s = d_max, so value and slope reach 0 there (a smooth window at the
    centre distance r + d_max). The post writes 2.1 tan(...) for its own d_max; 2 d_max/pi
    keeps d' ~ d_s near the light. Evaluated near d_max through
    tan(pi/2 u) = 1/tan(pi/2 (1 - u)), 1 - u = (d_max - d_s)/d_max. r and d_max in m.
    """

    r: Param = 0.1
    d_max: Param = 10.0

    name = "madams_tan"
    formula = "1/(d' + r)^2, d' = (2 d_max/pi) tan(pi d_s/(2 d_max)), d_s = max(d - r, 0); 0 for d_s >= d_max"
    source = "Madams 2011b, Improved light attenuation (tan warp)"
    default_free = ("r",)
    length_params = ("r", "d_max")
    range_param = "d_max"
    window = "smooth"
    scale_covariant = True

    def range_distance(self) -> Array:
        """The centre distance r + d_max where the curve reaches 0."""
        return _warped_sphere_range(self.r, self.d_max)

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        return _warped_sphere(parts.tan_warp, d, self.r, self.d_max)


@register_family
class MadamsRational(Family):
    """Madams' sphere with the rational distance warp, f = 1/(d' + r)^2, 0 beyond d_max.

    T. Madams, "Improved light attenuation" (2011-02-10): d' = d_s/(1 - (d_s/d_max)^2) with
    d_s = max(d - r, 0), the cheaper alternative to the tan warp; value and slope reach 0 at
    the centre distance r + d_max. Evaluated as d_s/((1 - u)(1 + u)), 1 - u = (d_max -
    d_s)/d_max. r and d_max in m.
    """

    r: Param = 0.1
    d_max: Param = 10.0

    name = "madams_rational"
    formula = "1/(d' + r)^2, d' = d_s/(1 - (d_s/d_max)^2), d_s = max(d - r, 0); 0 for d_s >= d_max"
    source = "Madams 2011b, Improved light attenuation (rational warp)"
    default_free = ("r",)
    length_params = ("r", "d_max")
    range_param = "d_max"
    window = "smooth"
    scale_covariant = True

    def range_distance(self) -> Array:
        """The centre distance r + d_max where the curve reaches 0."""
        return _warped_sphere_range(self.r, self.d_max)

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        return _warped_sphere(parts.rational_warp, d, self.r, self.d_max)


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

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, eps, r_max = parts.promote(d, self.eps, self.r_max)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.softened_inverse_square(d, jnp.sqrt(eps)) * parts.smooth_window(d, r_max)
        )


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
    range_param = "r_max"
    window = "smooth"
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r_min, r_max = parts.promote(d, self.r_min, self.r_max)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.clamped_inverse_square(d, r_min) * parts.smooth_window(d, r_max)
        )


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

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, a, r_max = parts.promote(d, self.a, self.r_max)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.smooth_window(d, r_max) * parts.power_min_distance(d, a, 1e-4)
        )


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
    range_param = "r_max"
    window = "hard"
    scale_covariant = True

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r_min, r_max = parts.promote(d, self.r_min, self.r_max)
        d = parts.distance(d)
        fade = parts.linear_tail_window(d, r_max, 0.2, 2 if self.squared else 1)
        return parts.keep_nan(d, parts.clamped_inverse_square(d, r_min) * fade)


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

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, scale, r_max = parts.promote(d, self.scale, self.r_max)
        return parts.keep_nan(d, scale * parts.smooth_window(parts.distance(d), r_max, 2, 2))


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

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, scale, r_max, p = parts.promote(d, self.scale, self.r_max, self.p)
        return parts.keep_nan(d, scale * parts.smooth_window(parts.distance(d), r_max, 2, p))


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

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, decay, cutoff = parts.promote(d, self.decay, self.cutoff)
        d = parts.distance(d)
        return parts.keep_nan(
            d, parts.power_clamped_value(d, decay, 0.01) * parts.smooth_window(d, cutoff)
        )


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

    @_jit_call
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


# ----------------------------------------------------------------------------- spline
_SPLINE_KNOTS = (1e-3, 1e-2, 1e-1, 1.0, 10.0, 100.0)


def _spline_default() -> np.ndarray:
    """ln(1/(d^2 + 0.01)) at the default knots (float64; the curve follows `d`'s dtype)."""
    return np.array([-math.log(k * k + 0.01) for k in _SPLINE_KNOTS])


@register_family
class Spline(Family):
    """An artist-style curve: monotone cubic through k knots in log f against log d.

    RTR4 section 5.2.2: Tomb Raider (2013) authored falloff curves with spline tools (no
    formula published). `knot_values` (the fitted parameter, shape (..., k)) are ln f (f in
    1/m^2) at the static knot distances `knots` (m, strictly increasing, k >= 2); between
    knots the Fritsch-Carlson monotone cubic (PCHIP) in (ln d, ln f); below the first knot f
    is constant (finite at d = 0); beyond the last knot it continues as inverse square,
    f = f_k (d_k/d)^2. Defaults: 6 knots from 1 mm to 100 m through ln(1/(d^2 + 0.01)) (the
    facing disk of radius 0.1 m). Monotone whenever the knot values are non-increasing.
    """

    knot_values: Float[ArrayLike, "*batch k"] = eqx.field(default_factory=_spline_default)
    knots: tuple[float, ...] = eqx.field(static=True, default=_SPLINE_KNOTS)

    name = "spline"
    formula = "exp(PCHIP(ln d; ln knots, knot_values)); constant below knots[0], f_k (d_k/d)^2 beyond knots[-1]"
    source = "RTR4 section 5.2.2 (Tomb Raider 2013 spline-authored falloff); Fritsch & Carlson 1980"
    default_free = ("knot_values",)
    constraints: ClassVar = {"knot_values": "real"}
    monotone = False

    def __check_init__(self):
        knots = tuple(float(k) for k in self.knots)
        if (
            len(knots) < 2
            or any(not (b > a) for a, b in itertools.pairwise(knots))
            or knots[0] <= 0
        ):
            from ._errors import BadValueError

            raise BadValueError(
                f"family 'spline': knots must be >= 2 positive, strictly increasing distances, got {knots}"
            )

    @_jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, values = parts.promote(d, self.knot_values)
        d = parts.distance(d)
        logk = jnp.log(jnp.asarray(self.knots, dtype=d.dtype))
        k0 = self.knots[0]
        kn = self.knots[-1]
        mid = (d > k0) & (d < kn)
        logd = jnp.log(jnp.where(mid, d, jnp.full_like(d, k0)))

        k = values.shape[-1]
        if k != len(self.knots):
            raise ValueError(f"spline: knot_values has {k} values for {len(self.knots)} knots")
        shape = jnp.broadcast_shapes(d.shape, values.shape[:-1])
        d = jnp.broadcast_to(d, shape)
        if values.ndim > 1:  # batched knot values: one row per point
            values = jnp.broadcast_to(values, (*shape, k))
        interp = parts.monotone_cubic(jnp.broadcast_to(logd, shape), logk, values)
        f_mid = jnp.exp(interp)
        f_first = jnp.exp(values[..., 0])
        far = d >= kn
        d_far = jnp.where(far, d, jnp.full_like(d, kn))
        ratio = kn / d_far
        f_far = jnp.exp(values[..., -1]) * ratio * ratio
        return parts.keep_nan(d, jnp.where(mid, f_mid, jnp.where(far, f_far, f_first)))
