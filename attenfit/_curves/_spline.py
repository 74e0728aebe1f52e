"""An artist-style curve: a monotone cubic spline through knots in log f against log d (RTR4
section 5.2.2, Tomb Raider 2013)."""

from __future__ import annotations

import itertools
import math
from typing import ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadValueError
from . import _parts as parts
from ._family import Family, Out, jit_call, register_family
from ._model_base import no_shader_form

__all__ = ["Spline", "spline_curve"]

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
    knots_param = "knot_values"
    #: Tomb Raider published no formula: `export` prints the guarded form of the JAX code.
    shader_form = no_shader_form

    def __check_init__(self):
        knots = tuple(float(k) for k in self.knots)
        if (
            len(knots) < 2
            or any(not (b > a) for a, b in itertools.pairwise(knots))
            or knots[0] <= 0
        ):
            raise BadValueError(
                f"family 'spline': knots must be >= 2 positive, strictly increasing distances, got {knots}"
            )

    @jit_call
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Out:
        d, values = parts.promote(d, self.knot_values)
        return spline_curve(d, values, jnp.asarray(self.knots, dtype=d.dtype))


def spline_curve(d: Array, values: Array, knots: Array) -> Array:
    """`Spline`'s curve at `d` (promoted with `values`) through knot distances `knots`, an
    array (traced or not: a compiled solve can take the knots as data, `attenfit._scenes`)."""
    d = parts.distance(d)
    logk = jnp.log(knots)
    k0 = knots[0]
    kn = knots[-1]
    mid = (d > k0) & (d < kn)
    logd = jnp.log(jnp.where(mid, d, jnp.full_like(d, k0)))

    k = values.shape[-1]
    if k != knots.shape[0]:
        raise ValueError(f"spline: knot_values has {k} values for {knots.shape[0]} knots")
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
