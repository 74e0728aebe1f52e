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

A family with a clamped distance, f = g(d) / max(d, p)^2 (its `clamp_param` p: Frostbite's
and CryEngine's r_min, RTR4 eq. 5.13), gets p's exact optimum given its other parameters
(`clamp_candidate`), where the samples come in order of distance (either way): the loss in p is a
quadratic in 1/p^2 between consecutive samples (the samples nearer than p see g/p^2, the
others do not see p), so every interval's minimum follows from running sums. The loss
has a kink at every sample (the slope of max(d, p)), and a quarter of the benchmark's
problems have their optimum on one: a solver started there measured 9-12 steps to give up
on it, and one started from the scan's candidates ended in a worse interval than this in
218 of 1,000 `clamped` fits (`python -m benchmarks fit`).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import jax.numpy as jnp
from jaxtyping import Array, Float

from ._solvers import gram, spd_solve

__all__ = ["clamp_candidate", "in_order", "linear_candidate", "scale_candidates"]

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


def clamp_candidate(
    d: Float[Array, " n"],
    f0: Float[Array, " n"],
    p0: Float[Array, ""],
    residual: Callable[[Array], Array],
) -> tuple[Float[Array, ""], Array]:
    """The optimum of a clamp parameter p given the other parameters: `(p, in_order)`.

    `f0`: the model at the samples with p = `p0` (its start), so that g = f0 max(d, p0)^2;
    `residual`: the loss's map from model values to residuals, affine in them (the
    relative and absolute losses, weighted or not: `attenfit._fit._problem`). With the
    samples in order of distance (`in_order`), p between d_(k-1) and d_k clamps the first
    k: their residuals are a_i x + b_i with x = 1/p^2, the others' do not depend on p, so
    the loss there is A x^2 + 2 B x + C plus the others' sum, its minimum in closed form.
    Where nothing clamped is best, `p0` if it clamps nothing, else half the nearest
    distance. Samples in neither increasing nor decreasing order give `p0` (and
    `in_order` False).
    """
    dtype = d.dtype
    m = jnp.maximum(d, p0)
    g = f0 * m * m
    inv_d2 = 1 / jnp.where(d > 0, d * d, 1)
    b = residual(jnp.zeros_like(g))
    a = residual(g) - b
    free = a * inv_d2 + b  # residuals of unclamped samples (the residual is affine)
    up, down = in_order(d)
    # element j's interval clamps the first j + 1 samples (increasing distances: p from
    # d_j out to d_(j+1)) or sample j and all after it (decreasing: p from d_j out to
    # d_(j-1)); either way x = 1/p^2 lies between inv_d2[j] and its neighbour's, the
    # farthest sample's interval reaching out to 1e4 times it. A, B, D sum a a, a b and
    # b b - free free over the clamped samples: the loss there is A x^2 + 2 B x + D + P.
    q = jnp.stack([a * a, a * b, b * b - free * free])
    incl = _prefix_sums(q)
    A, B, D = jnp.where(up, incl, incl[:, -1:] - incl + q)
    P = jnp.sum(free * free)
    after = jnp.concatenate([inv_d2[1:], inv_d2[-1:] * 1e-8])
    before = jnp.concatenate([inv_d2[:1] * 1e-8, inv_d2[:-1]])
    x_lo = jnp.where(up, after, before)
    x_hi = jnp.where(d > 0, inv_d2, jnp.inf)
    x = jnp.clip(-B / jnp.where(A > 0, A, 1), x_lo, x_hi)
    x = jnp.where(A > 0, x, x_lo)  # the clamped samples do not see p (g = 0 there)
    loss = A * x * x + 2 * B * x + D + P
    loss = jnp.where(jnp.isfinite(loss), loss, jnp.inf)
    # the best interval's x, by two plain reductions (an argmin and a gather under `vmap`
    # measured 1 ms per 1,000 problems); ties take the smallest p
    best = jnp.min(loss)
    x_best = jnp.max(jnp.where(loss == best, x, -jnp.inf))
    # ...or none clamped (p below the nearest sample, which must then be beyond 0)
    nearest = jnp.where(up, d[0], d[-1])
    none = (nearest > 0) & (P <= best)
    unclamped = jnp.where(p0 < nearest, p0, nearest / 2)
    p = jnp.where(none, unclamped, 1 / jnp.sqrt(x_best))
    ok = (up | down) & jnp.isfinite(p) & (p > 0)
    return jnp.where(ok, p, p0).astype(dtype), ok


#: Block length of `_prefix_sums`.
_BLOCK = 16


def _prefix_sums(rows: Float[Array, "m n"]) -> Float[Array, "m n"]:
    """Running sums along the last axis (inclusive), by blocks: a product with a triangular
    matrix within each block of `_BLOCK` samples, then one with a strictly triangular
    matrix for the blocks before. XLA's CPU `cumsum` (a scan) measured 5.1 ms per 1,000
    problems of 4 rows of 256 under `vmap`, a `cumsum` of the blocks' totals 1.9 ms, this
    1.6 ms."""
    m, n = rows.shape
    blocks = -(-n // _BLOCK)
    padded = jnp.pad(rows, ((0, 0), (0, blocks * _BLOCK - n)))
    tri = jnp.triu(jnp.ones((_BLOCK, _BLOCK), rows.dtype))
    inner = padded.reshape(m, blocks, _BLOCK) @ tri
    before = inner[:, :, -1] @ jnp.triu(jnp.ones((blocks, blocks), rows.dtype), 1)
    return (inner + before[:, :, None]).reshape(m, blocks * _BLOCK)[:, :n]


def in_order(d: Float[Array, "*batch n"]) -> tuple[Array, Array]:
    """Whether the samples' distances are non-decreasing, and non-increasing."""
    step = d[..., 1:] - d[..., :-1]
    return jnp.all(step >= 0, axis=-1), jnp.all(step <= 0, axis=-1)
