"""Constraint-aware reparametrisation: the unconstrained coordinates a solver moves in.

A fit never moves a parameter `p` directly; it moves an unconstrained `u` and evaluates the
family at `p = to_param(kind, u)`, with `kind` the parameter's declared constraint
(`attenfit.Family.constraints`):

- ``"positive"``: `p = exp(u)`. Smooth, scale-free (a step in `u` is a relative step in `p`,
  which suits lengths that span decades) and never reaches 0, so a radius can never go
  negative. An optimum at 0 is *not* reachable this way: declare such a parameter
  ``"nonnegative"``.
- ``"nonnegative"``: the reflection `p = |u|` (with slope +1 at `u = 0`). It reaches the
  edge: when the data want `p <= 0`, the residual is piecewise linear in `u` on either side
  of 0, so Gauss-Newton lands on `p = 0` in one step for a zero-residual optimum, and
  damped (Levenberg-Marquardt) steps close in on it otherwise. A log or softplus map cannot
  do this (the optimum is at `u -> -inf` and a fit runs out of steps); a squared map `p = u^2` has a zero
  Jacobian at the edge, so Gauss-Newton steps only halve `u` each time. This is the
  reflective treatment of bounds, as in Coleman and Li's trust-region-reflective method
  (scipy's ``least_squares(method="trf")``).
- ``"unit"``: `p = sigmoid(u)`, strictly between 0 and 1.
- ``"real"``: `p = u`.

All maps are elementwise, dtype-preserving, and have finite derivatives everywhere.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

__all__ = ["by_kind", "param_slope", "to_internal", "to_param"]


def to_param(kind: str, u: Float[Array, "*s"]) -> Float[Array, "*s"]:
    """The parameter value for unconstrained coordinate `u` under constraint `kind`."""
    if kind == "positive":
        return jnp.exp(u)
    if kind == "nonnegative":
        return jnp.where(u >= 0, u, -u)  # |u| with derivative +1 at 0, so a start at 0 moves
    if kind == "unit":
        return jax.nn.sigmoid(u)
    return u


def param_slope(kind: str, u: Float[Array, "*s"]) -> Float[Array, "*s"]:
    """`d to_param(kind, u) / du`, the slope of the map at `u` (+1 at 0 for the reflection)."""
    if kind == "positive":
        return jnp.exp(u)
    if kind == "nonnegative":
        return jnp.where(u >= 0, 1, -1).astype(u.dtype)
    if kind == "unit":
        q = jax.nn.sigmoid(u)
        return q * (1 - q)
    return jnp.ones_like(u)


def to_internal(kind: str, p: Float[ArrayLike, "*s"]) -> Float[Array, "*s"]:
    """The unconstrained coordinate of a (feasible) parameter value `p`.

    Values on or past an open bound are nudged inside first (a positive parameter of 0
    starts at the smallest normal number of its dtype; a unit parameter of 0 or 1 starts a
    machine epsilon inside), so every start maps to a finite `u`.
    """
    p = jnp.asarray(p)
    if kind == "positive":
        return jnp.log(jnp.maximum(p, jnp.finfo(p.dtype).tiny))
    if kind == "nonnegative":
        return jnp.abs(p)
    if kind == "unit":
        eps = jnp.finfo(p.dtype).eps
        q = jnp.clip(p, eps, 1 - eps)
        return jnp.log(q) - jnp.log1p(-q)
    return p


def by_kind(
    fn: Callable[[str, Array], Array], kinds: tuple[str, ...], u: Float[Array, " k"]
) -> Array:
    """`fn(kinds[i], u[i])` for every coordinate of `u`, as one elementwise expression.

    Each kind's map is evaluated on every coordinate and the right one selected, so this is
    for values only: under differentiation an unselected map that overflows (`exp`) would
    turn the gradient into NaN.
    """
    out = fn("real", u)
    for kind in sorted(set(kinds) - {"real"}):
        mask = np.array([k == kind for k in kinds])
        out = jnp.where(mask, fn(kind, u), out)
    return out
