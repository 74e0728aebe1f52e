"""Unwindowed families: inverse square, its softened and clamped forms, Yuksel's curves,
the exact facing disk and the fixed-function polynomial (RTR4 section 5.2.2; Yuksel 2020)."""

from __future__ import annotations

import math
from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import ArrayLike, Float

from .._ir import fn
from . import _parts as parts
from ._family import Family, Out, Param, jit_call, register_family
from ._forms import OVERFLOW, shader

__all__ = [
    "Clamped",
    "DiskFacing",
    "InverseSquare",
    "Polynomial",
    "UnrealEpsilon",
    "Yuksel",
    "YukselAdhoc",
]


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

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        (d,) = parts.promote(d)
        return parts.keep_nan(d, parts.inverse_square(parts.distance(d)))

    @shader("RTR4 eq. 5.11 (textbook)", engine=False, note=OVERFLOW)
    def shader_form(self, let, d):
        return 1.0 / (d * d)


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
    #: 1/f = d^2 + eps: linear in eps (the fit's linear start)
    inverse_linear: ClassVar = (lambda d: d * d, {"eps": jnp.ones_like})
    tends_to_inverse_square = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, eps = parts.promote(d, self.eps)
        return parts.keep_nan(d, parts.softened_inverse_square(parts.distance(d), jnp.sqrt(eps)))

    @shader(
        "Unreal CapsuleLightIntegrate.ush (Falloff = 1/(DistSqr + DistBiasSqr), DistBiasSqr "
        "from DeferredLightingCommon.ush::GetCapsule); described, not copied",
        engine=True,
        note=OVERFLOW,
    )
    def shader_form(self, let, d, eps):
        return 1.0 / (d * d + eps)


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
    at_radius: ClassVar = {"r_min": (1.0, 1)}  # "the radius of the physical object" (RTR4)
    clamp_param = "r_min"  # f = 1 / max(d, r_min)^2
    tends_to_inverse_square = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r_min = parts.promote(d, self.r_min)
        return parts.keep_nan(d, parts.clamped_inverse_square(parts.distance(d), r_min))

    @shader("RTR4 eq. 5.13 (textbook)", engine=False, note=OVERFLOW)
    def shader_form(self, let, d, r_min):
        m = let("m", fn("max", d, r_min))
        return 1.0 / (m * m)


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
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    tends_to_inverse_square = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(d, parts.yuksel(parts.distance(d), r))

    @shader(
        "Blender EEVEE eevee_light_lib.glsl::light_point_light (Yuksel 2020's rewrite of eq. 7)",
        engine=True,
        note=OVERFLOW + "; no hypot",
    )
    def shader_form(self, let, d, r):
        d_sqr = let("d_sqr", d * d)
        r_sqr = let("r_sqr", r * r)
        return 2.0 / (d_sqr + r_sqr + d * fn("sqrt", d_sqr + r_sqr))


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
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    tends_to_inverse_square = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(
            d, parts.softened_inverse_square(parts.distance(d), r * math.sqrt(0.5))
        )

    @shader("Yuksel 2020 eq. 8 (textbook)", engine=False, note=OVERFLOW)
    def shader_form(self, let, d, r):
        half_r_sqr = let("half_r_sqr", 0.5 * (r * r))
        return 1.0 / (d * d + half_r_sqr)


@register_family
class DiskFacing(Family):
    """The exact facing-disk attenuation, f = 1/(d^2 + r^2).

    Irradiance on the axis of a Lambertian disk of radius r (m) and radiance 1/(pi r^2)
    (unit intensity), at distance d, receiver facing it: E = pi L sin^2(sigma) = 1/(d^2 + r^2)
    (Howell's catalogue B-12; docs/ground-truth.md §4). The Madams thread remarks that his
    curve is really a disc light's. f(0) = 1/r^2.
    """

    r: Param = 0.1

    name = "disk_facing"
    formula = "1/(d^2 + r^2)"
    source = "closed form (Howell catalogue B-12); Madams 2011 comment thread"
    default_free = ("r",)
    length_params = ("r",)
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    tends_to_inverse_square = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(d, parts.softened_inverse_square(parts.distance(d), r))

    @shader("Howell catalogue B-12 (closed form)", engine=False, note=OVERFLOW)
    def shader_form(self, let, d, r):
        return 1.0 / (d * d + r * r)


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
    #: Madams 2011's kc = 1, kl = 2/r, kq = 1/r^2 on centre distance, divided by r^2
    at_radius: ClassVar = {"kc": (1.0, 2), "kl": (2.0, 1), "kq": (1.0, 0)}
    #: 1/f = kc + kl d + kq d^2: linear in the coefficients (the fit's linear start)
    inverse_linear: ClassVar = (
        jnp.zeros_like,
        {"kc": jnp.ones_like, "kl": lambda d: d, "kq": lambda d: d * d},
    )
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, kc, kl, kq = parts.promote(d, self.kc, self.kl, self.kq)
        return parts.keep_nan(d, parts.polynomial(parts.distance(d), kc, kl, kq))

    @shader(
        "OpenGL glLight fixed-function attenuation, in Horner's form",
        engine=False,
        note="one polynomial for every d (the reference switches to 1/d at d > 1)",
    )
    def shader_form(self, let, d, kc, kl, kq):
        return 1.0 / (kc + d * (kl + kq * d))
