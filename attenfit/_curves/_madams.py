"""Madams 2011's spherical light: the plain curve, its scale-and-bias cutoff, and the tan and
rational distance warps of the follow-up post (Madams 2011b)."""

from __future__ import annotations

import math
from typing import ClassVar

import jax.numpy as jnp
from jaxtyping import ArrayLike, Float

from .._ir import Expr, Ref, fn
from . import _parts as parts
from ._family import Family, Out, Param, jit_call, register_family
from ._forms import shader

__all__ = ["MadamsCutoff", "MadamsRational", "MadamsSphere", "MadamsTan"]


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


def _warped_form(let, r: Ref, d_max: Ref, warped: Expr, ds: Ref) -> Expr:
    """The shader form of `_warped_sphere`: 1/(d' + r)^2 while d_s < d_max, else 0."""
    x = let("x", warped + r)
    return fn("select", ds < d_max, 1.0 / (x * x), 0.0)


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
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    clamp_param = "r"  # f = 1 / max(d, r)^2
    tends_to_inverse_square = True
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r = parts.promote(d, self.r)
        return parts.keep_nan(
            d, parts.surface_sphere(parts.surface_distance(parts.distance(d), r), r)
        )

    @shader(
        "Madams 2011 and its comments: r^2/D^2 clamped at the surface, over r^2",
        engine=False,
        note="1/max(d, r)^2 (the reference adds r back to max(d - r, 0))",
    )
    def shader_form(self, let, d, r):
        m = let("m", fn("max", d, r))
        return 1.0 / (m * m)


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
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    window = "hard"
    range_tie = ("cutoff", "cutoff")  # reaches 0 at r/sqrt(cutoff)
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, r, c = parts.promote(d, self.r, self.cutoff)
        return parts.keep_nan(d, parts.cutoff_bias(parts.distance(d), r, c) / (r * r))

    @shader(
        "Madams 2011, Light attenuation (GLSL DirectIllumination): scale and bias by the cutoff",
        engine=False,
        note="a - cutoff cancels near the range r/sqrt(cutoff) (the reference factors it)",
    )
    def shader_form(self, let, d, r, cutoff):
        r_sqr = let("r_sqr", r * r)
        scale = let("scale", 1.0 / ((1.0 - cutoff) * r_sqr))
        m = let("m", fn("max", d, r))
        return fn("max", r_sqr / (m * m) - cutoff, 0.0) * scale


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
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    range_tie = ("d_max", "surface")  # d_max is measured from the surface
    range_param = "d_max"
    window = "smooth"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        return _warped_sphere(parts.tan_warp, d, self.r, self.d_max)

    @shader(
        "Madams 2011b, Improved light attenuation: the tan warp (2 d_max/pi for the post's 2.1)",
        engine=False,
        note="tan near its pole as written (the reference uses 1/tan of the complement there)",
    )
    def shader_form(self, let, d, r, d_max):
        k = let("k", (2.0 / math.pi) * d_max)
        ds = let("ds", fn("max", d - r, 0.0))
        return _warped_form(let, r, d_max, k * fn("tan", ds / k), ds)


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
    at_radius: ClassVar = {"r": (1.0, 1)}  # as published: the light's radius
    range_tie = ("d_max", "surface")  # d_max is measured from the surface
    range_param = "d_max"
    window = "smooth"
    scale_covariant = True

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        return _warped_sphere(parts.rational_warp, d, self.r, self.d_max)

    @shader(
        "Madams 2011b, Improved light attenuation: the rational warp d/(1 - (d/d_max)^2)",
        engine=False,
        note="1 - (d/d_max)^2 cancels near the range (the reference factors it)",
    )
    def shader_form(self, let, d, r, d_max):
        inv_d_max = let("inv_d_max", 1.0 / d_max)
        ds = let("ds", fn("max", d - r, 0.0))
        u = let("u", ds * inv_d_max)
        return _warped_form(let, r, d_max, ds / (1.0 - u * u), ds)
