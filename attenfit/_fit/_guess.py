"""Starting guesses from the data, computed inside the compiled solve (batchable).

A fit starts from the best (lowest loss) of a few candidates: the caller's start, that
start with every free length parameter scaled by one common factor over a log grid
(models declare their `length_params`; under d -> s d the curve's shape only depends on
d / length), and, for models whose reciprocal is linear in their parameters (their
`inverse_linear`: `1/f = kc + kl d + kq d^2` for `polynomial`, `1/f = d^2 + eps` for
`unreal_epsilon`), the
weighted linear least-squares solution of `1/f = 1/target` (rows weighted so that its
error reads as the fit's loss), which lands next to the optimum. A good start is what makes
a batch of thousands of fits cheap: a vmapped solve runs until its slowest problem has
finished. (Refining the linear start by Gauss-Newton steps here was tried: each costs as
much as a solver step and saves at most one.)
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import jax.numpy as jnp
from jaxtyping import Array, Float

from ._solvers import gram, spd_solve

__all__ = ["linear_candidate", "scale_candidates"]

#: Scale factors tried for the free length parameters (1 is the caller's start).
SCALES = tuple(float(2.0**k) for k in range(-8, 9) if k != 0)

_Basis = Callable[[Array], Array]


def scale_candidates(
    start: Mapping[str, Array], free: tuple[str, ...], free_lengths: tuple[str, ...]
) -> dict[str, Array]:
    """The start with all free length parameters multiplied by each factor in `SCALES`.

    Returns the free parameters' values stacked, one row per factor (`{}` when no length
    parameter is free): each parameter is one product with the factors, not one per factor.
    """
    if not free_lengths:
        return {}
    out = {}
    for name in free:
        value = jnp.asarray(start[name])
        if name in free_lengths:
            factors = jnp.asarray(SCALES, value.dtype).reshape((-1,) + (1,) * value.ndim)
            out[name] = value * factors
        else:
            out[name] = jnp.broadcast_to(value, (len(SCALES), *value.shape))
    return out


def linear_candidate(
    inverse_linear: tuple[_Basis, Mapping[str, _Basis]] | None,
    start: Mapping[str, Array],
    free: tuple[str, ...],
    kinds: Mapping[str, str],
    d: Float[Array, " n"],
    target: Float[Array, " n"],
    inv_target: Float[Array, " n"],
    weights: Float[Array, " n"] | None,
    loss: str,
    batched: bool = False,
) -> dict[str, Array] | None:
    """The reweighted linear least-squares start of an inverse-linear model, or None.

    `inverse_linear`: the model's `(offset, {param: basis})`, `1/f = offset + sum p basis`
    (`attenfit.Model.inverse_linear`); None: no linear start. `inv_target`: 1 / target where target > 0, else 0.
    Only the free parameters are solved for; fixed ones move to the offset. Solutions
    outside a parameter's constraint fall back to the start (positive) or to 0
    (nonnegative); the caller keeps whichever candidate has the lowest loss.
    """
    if inverse_linear is None:
        return None
    offset_fn, basis = inverse_linear
    solve_for = [p for p in basis if p in free]
    if not solve_for or any(p not in start for p in basis):
        return None
    dtype = d.dtype
    rhs = inv_target - offset_fn(d)
    for p in basis:
        if p not in free:
            rhs = rhs - start[p] * basis[p](d)
    # Linear least squares for 1/f = 1/target, rows weighted so that |g - h| reads as
    # the relative (log) error |g - h| / g ~ |g - h| f, or |g - h| f^2 (absolute).
    power = 2 if loss == "absolute" else 1
    scale = target**power if weights is None else target**power * weights
    rows = [basis[p](d).astype(dtype) * scale for p in solve_for]
    ata, atb = gram(rows, rhs * scale, batched)
    # Jacobi scaling (unit columns): the system's condition is that of the basis' shapes
    norms = jnp.sqrt(jnp.diagonal(ata))
    norms = jnp.where(norms > 0, norms, 1)
    ata = ata / (norms[:, None] * norms[None, :])
    eye = jnp.eye(len(solve_for), dtype=dtype)
    a = ata + eye * (jnp.finfo(dtype).eps * len(solve_for))
    coef = spd_solve(a, atb / norms) / norms
    cand = dict(start)
    for i, p in enumerate(solve_for):
        c = coef[i]
        if kinds[p] == "positive":
            c = jnp.where(c > 0, c, start[p])
        elif kinds[p] == "nonnegative":
            c = jnp.maximum(c, 0)
        elif kinds[p] == "unit":
            c = jnp.where((c > 0) & (c < 1), c, start[p])
        cand[p] = jnp.where(jnp.isfinite(c), c, start[p]).astype(dtype)
    return cand
