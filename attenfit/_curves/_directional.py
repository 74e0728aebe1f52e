"""Directional (spotlight and emitter-shape) factors `g` of the point-light model.

A light's irradiance is `E = I * g * f(d) * max(0, n.l)` (docs/architecture.md, Conventions); this module
gives `g`. Angles are half-angles from the spot axis, in radians: the **umbra** angle
`theta_u` bounds the cone (g = 0 beyond it) and the **penumbra** angle `theta_p <= theta_u`
bounds the inner cone of full intensity (RTR4 section 5.2.2, Fig. 5.7). `cos_s` is the cosine
of the angle between the spot direction and the direction from the light to the receiver.

All functions are pure, broadcast their arguments, keep the dtype of `cos_s` (a float array)
and have finite gradients everywhere, t = 0 and t = 1 included.
"""

from __future__ import annotations

from typing import ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadValueError
from .._ir import Lets, Ref, fn
from . import _parts as parts
from ._family import Family
from ._forms import shader

#: The floor on cos(theta_p) - cos(theta_u) used by Frostbite's `getAngleAtt` CPU side
#: (`1/max(0.001, cosInner - cosOuter)`), the glTF KHR_lights_punctual reference code and
#: Unity URP. Filament uses 1/1024, Bevy and Unity HDRP 1e-4.
MIN_COS_WIDTH = 1e-3


def _check_angles(umbra: ArrayLike, penumbra: ArrayLike) -> None:
    """Eager validation of concrete angles (skipped for traced values)."""
    if isinstance(umbra, jax.core.Tracer) or isinstance(penumbra, jax.core.Tracer):
        return
    u = np.asarray(umbra, dtype=np.float64)
    p = np.asarray(penumbra, dtype=np.float64)
    if np.any(~(u >= 0) | ~(u <= np.pi)):
        raise BadValueError(f"umbra must be an angle in [0, pi] radians, got {u.tolist()}")
    if np.any(~(p >= 0) | ~(p <= np.pi)):
        raise BadValueError(f"penumbra must be an angle in [0, pi] radians, got {p.tolist()}")
    if np.any(p > u):
        raise BadValueError(
            f"penumbra ({p.tolist()}) must not exceed umbra ({u.tolist()}): it is the inner cone"
        )


def spot_t(
    cos_s: Float[ArrayLike, "*#shape"],
    umbra: Float[ArrayLike, "*#shape"],
    penumbra: Float[ArrayLike, "*#shape"],
    *,
    min_width: float = MIN_COS_WIDTH,
) -> Float[Array, "*shape"]:
    """The spot ramp t = clamp((cos_s - cos umbra)/(cos penumbra - cos umbra), 0, 1) (RTR4 eq. 5.18).

    The denominator is floored at `min_width` (Frostbite's and glTF's 0.001), so a hard-edged
    spot (penumbra = umbra) is a steep but finite ramp instead of a division by zero. The
    clamp is written with `where`, so the gradient is finite at t = 0 and t = 1 (it is the
    one-sided derivative from outside the ramp: 0). Angles in radians, 0 <= penumbra <=
    umbra <= pi.
    """
    _check_angles(umbra, penumbra)
    cos_s, umbra, penumbra = jnp.broadcast_arrays(*parts.promote(cos_s, umbra, penumbra))
    cu = jnp.cos(umbra)
    width = jnp.cos(penumbra) - cu
    width = jnp.where(width > min_width, width, jnp.full_like(width, min_width))
    t = (cos_s - cu) / width
    return jnp.where(t >= 1, jnp.ones_like(t), jnp.where(t <= 0, jnp.zeros_like(t), t))


def spot_frostbite(
    cos_s: Float[ArrayLike, "*#shape"],
    umbra: Float[ArrayLike, "*#shape"],
    penumbra: Float[ArrayLike, "*#shape"],
    *,
    min_width: float = MIN_COS_WIDTH,
) -> Float[Array, "*shape"]:
    """Frostbite's spot falloff, t^2 (RTR4 eq. 5.19).

    Lagarde and de Rousiers 2014, listing `getAngleAtt`: saturate(cos_s * scale + offset)^2
    with scale = 1/max(0.001, cos_inner - cos_outer), offset = -cos_outer * scale; the same
    in Unreal (`SpotAttenuation`), Filament (floor 1/1024), Bevy and glTF's reference code.
    """
    t = spot_t(cos_s, umbra, penumbra, min_width=min_width)
    return t * t


def spot_threejs(
    cos_s: Float[ArrayLike, "*#shape"],
    umbra: Float[ArrayLike, "*#shape"],
    penumbra: Float[ArrayLike, "*#shape"],
    *,
    min_width: float = MIN_COS_WIDTH,
) -> Float[Array, "*shape"]:
    """three.js's spot falloff, smoothstep(t) = t^2 (3 - 2 t) (RTR4 eq. 5.20).

    three.js `LightUtils.js::getSpotAttenuation` = smoothstep(coneCos, penumbraCos, cos_s),
    with coneCos = cos(angle) and penumbraCos = cos(angle (1 - penumbra)) in
    `SpotLightNode.js`: three.js's `angle` is the umbra here and its `penumbra` (a fraction)
    gives the penumbra angle angle * (1 - penumbra). GLSL leaves smoothstep undefined for
    equal edges (three.js's default penumbra 0); here the width is floored at `min_width`.
    Also the glTF-Sample-Viewer's spot (`punctual.glsl`).
    """
    t = spot_t(cos_s, umbra, penumbra, min_width=min_width)
    return t * t * (3 - 2 * t)


def lambert_disk(cos_e: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
    """A one-sided Lambertian disk's directional factor, max(0, cos theta_e).

    A disk of radius r and radiance L has intensity I cos(theta_e) at the angle theta_e from
    its normal (docs/architecture.md, Conventions: I = pi r^2 L along the normal); 0 behind it. The gradient
    at cos_e = 0 is the one from the lit side (1).
    """
    (cos_e,) = parts.promote(cos_e)
    return jnp.where(cos_e >= 0, cos_e, jnp.zeros_like(cos_e))


# ----------------------------------------------------------------------------- as families
# (Spot falloffs as families of d = cos(theta_s), so that the cost and export stages, which
# read families, can count and print them.)


class SpotFalloff(Family):
    """A spot's directional falloff as a (non-registered) family of `d = cos(theta_s)`.

    Abstract: `SpotFrostbite` and `SpotThreeJS` wrap `attenfit.directional` so that
    `attenfit.cost` can count their operations and `attenfit.export` can print them.
    `umbra` and `penumbra` are half-angles in radians; `d` is the cosine of the angle
    between the spot's direction and the direction from the light to the receiver.
    """

    umbra: eqx.AbstractVar[Float[ArrayLike, "*batch"]]
    penumbra: eqx.AbstractVar[Float[ArrayLike, "*batch"]]


def _spot_scale(let: Lets, umbra: Ref, penumbra: Ref) -> tuple[Ref, Ref]:
    """`(cos umbra, 1/max(cos penumbra - cos umbra, MIN_COS_WIDTH))` as temporaries."""
    cos_outer = let("cos_outer", fn("cos", umbra))
    scale = let("scale", 1.0 / fn("max", fn("cos", penumbra) - cos_outer, 0.001))
    return cos_outer, scale


class SpotFrostbite(SpotFalloff):
    """Frostbite's spot falloff t^2 (`spot_frostbite`, RTR4 eq. 5.19)."""

    umbra: Float[ArrayLike, "*batch"] = 0.5
    penumbra: Float[ArrayLike, "*batch"] = 0.4

    name = "spot_frostbite"
    formula = "t^2, t = clamp((d - cos umbra)/(cos penumbra - cos umbra), 0, 1), d = cos(theta_s)"
    source = "RTR4 eq. 5.19; Lagarde and de Rousiers 2014, getAngleAtt"
    default_free = ("umbra", "penumbra")
    constraints: ClassVar = {"penumbra": "nonnegative"}

    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        return spot_frostbite(d, self.umbra, self.penumbra)

    @shader(
        "Filament shaders/src/light_punctual.fs::getAngleAttenuation (scale and offset as "
        "LightManager.cpp::setSpotLightCone, floor 0.001 as Frostbite's getAngleAtt)",
        engine=True,
    )
    def shader_form(self, let, d, umbra, penumbra):
        cos_outer, scale = _spot_scale(let, umbra, penumbra)
        offset = let("offset", -cos_outer * scale)
        t = let("t", fn("saturate", d * scale + offset))
        return t * t


class SpotThreeJS(SpotFalloff):
    """three.js's spot falloff smoothstep(t) (`spot_threejs`, RTR4 eq. 5.20)."""

    umbra: Float[ArrayLike, "*batch"] = 0.5
    penumbra: Float[ArrayLike, "*batch"] = 0.4

    name = "spot_threejs"
    formula = "t^2 (3 - 2t), t = clamp((d - cos umbra)/(cos penumbra - cos umbra), 0, 1), d = cos(theta_s)"
    source = "RTR4 eq. 5.20; three.js LightUtils.js getSpotAttenuation"
    default_free = ("umbra", "penumbra")
    constraints: ClassVar = {"penumbra": "nonnegative"}

    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        return spot_threejs(d, self.umbra, self.penumbra)

    @shader(
        "three.js getSpotAttenuation: smoothstep(coneCos, penumbraCos, angleCos), written out",
        engine=True,
    )
    def shader_form(self, let, d, umbra, penumbra):
        cos_outer, scale = _spot_scale(let, umbra, penumbra)
        t = let("t", fn("saturate", (d - cos_outer) * scale))
        return t * t * (3.0 - 2.0 * t)


SPOT_FALLOFFS: dict[str, type[SpotFalloff]] = {"frostbite": SpotFrostbite, "threejs": SpotThreeJS}
