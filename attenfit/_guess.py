"""Starting guesses from the data, computed inside the compiled solve (batchable).

A fit starts from the best (lowest loss) of a few candidates: the caller's start, that
start with every free length parameter scaled by one common factor over a log grid
(families declare their `length_params`; under d -> s d the curve's shape only depends on
d / length), and, for families whose reciprocal is linear in their parameters
(`1/f = kc + kl d + kq d^2` for `polynomial`, `1/f = d^2 + eps` for `unreal_epsilon`), the
weighted linear least-squares solution of `1/f = 1/target`, then refined by a few
Gauss-Newton steps on the loss itself (cheap: the Jacobian of `1/g` with `g` linear is
explicit), which usually lands on the optimum before the solver starts. A good start is what makes a batch of
thousands of fits cheap: a vmapped solve runs until its slowest problem has finished.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import jax
import jax.numpy as jnp
from jaxtyping import Array, Float

__all__ = ["INVERSE_LINEAR", "linear_candidate", "scale_candidates"]

#: Gauss-Newton steps refining the linear start of an inverse-linear family. Each one
#: costs about as much as a solver step, and saves one (1,000 polynomial fits: 8 solver
#: steps from the plain linear start, 4 after 4 refinements, 2 after 6: 90 ms against 103).
GAUSS_NEWTON_STEPS = 6

#: Scale factors tried for the free length parameters (1 is the caller's start).
SCALES = tuple(float(2.0**k) for k in range(-8, 9) if k != 0)

_Basis = Callable[[Array], Array]

#: family name -> (offset(d), {param: basis(d)}) with 1/f = offset + sum_p p * basis_p(d).
INVERSE_LINEAR: dict[str, tuple[_Basis, dict[str, _Basis]]] = {
    "polynomial": (
        jnp.zeros_like,
        {"kc": jnp.ones_like, "kl": lambda d: d, "kq": lambda d: d * d},
    ),
    "unreal_epsilon": (lambda d: d * d, {"eps": jnp.ones_like}),
}


def scale_candidates(
    start: Mapping[str, Array], free_lengths: tuple[str, ...]
) -> list[dict[str, Array]]:
    """The start with all free length parameters multiplied by each factor in `SCALES`."""
    if not free_lengths:
        return []
    out = []
    for s in SCALES:
        cand = dict(start)
        for name in free_lengths:
            cand[name] = start[name] * s
        out.append(cand)
    return out


def spd_solve(a: Float[Array, "k k"], b: Float[Array, " k"]) -> Float[Array, " k"]:
    """Solve `a x = b` for a small symmetric positive definite `a` by an unrolled Cholesky.

    Elementwise arithmetic only: under `vmap` it vectorises over the batch, where a batched
    LAPACK call per 3x3 system costs several times more on CPU (measured 0.07 ms against
    0.44 ms for 1,000 systems). A non-positive pivot gives NaN, which the caller's
    finiteness checks reject.
    """
    k = a.shape[0]
    chol = [[None] * k for _ in range(k)]
    for i in range(k):
        for j in range(i + 1):
            acc = a[i, j] - sum((chol[i][m] * chol[j][m] for m in range(j)), start=0 * a[i, j])
            chol[i][j] = jnp.sqrt(acc) if i == j else acc / chol[j][j]
    y = []
    for i in range(k):
        y.append((b[i] - sum((chol[i][m] * y[m] for m in range(i)), start=0 * b[i])) / chol[i][i])
    x = [None] * k
    for i in reversed(range(k)):
        x[i] = (y[i] - sum((chol[m][i] * x[m] for m in range(i + 1, k)), start=0 * b[i])) / chol[i][
            i
        ]
    return jnp.stack(x)


def linear_candidate(
    family: str,
    start: Mapping[str, Array],
    free: tuple[str, ...],
    kinds: Mapping[str, str],
    d: Float[Array, " n"],
    target: Float[Array, " n"],
    weights: Float[Array, " n"],
    loss: str,
) -> dict[str, Array] | None:
    """The reweighted linear least-squares start of an inverse-linear family, or None.

    Only the free parameters are solved for; fixed ones move to the offset. Solutions
    outside a parameter's constraint fall back to the start (positive) or to 0
    (nonnegative); the caller keeps whichever candidate has the lowest loss.
    """
    if family not in INVERSE_LINEAR:
        return None
    offset_fn, basis = INVERSE_LINEAR[family]
    solve_for = [p for p in basis if p in free]
    if not solve_for or any(p not in start for p in basis):
        return None
    dtype = d.dtype
    h = jnp.where(target > 0, 1 / jnp.where(target > 0, target, 1), 0)  # 1/target
    rhs = h - offset_fn(d)
    for p in basis:
        if p not in free:
            rhs = rhs - start[p] * basis[p](d)
    cols = jnp.stack([basis[p](d).astype(dtype) for p in solve_for], axis=-1)
    fixed_part = h - rhs  # offset and fixed terms of the reciprocal
    norms = jnp.sqrt(jnp.sum(cols * cols, axis=0))
    cols = cols / jnp.where(norms > 0, norms, 1)[None, :]  # unit columns: better conditioned
    eye = jnp.eye(len(solve_for), dtype=dtype)

    def solve_normal(a, b):
        ata = a.T @ a
        return spd_solve(ata + eye * (jnp.finfo(dtype).eps * jnp.trace(ata)), a.T @ b)

    # 1. Linear least squares for 1/f = 1/target, rows weighted so that |g - h| reads as
    #    the relative (log) error |g - h| / g ~ |g - h| f, or |g - h| f^2 (absolute).
    power = 2 if loss == "absolute" else 1
    scale = target**power * weights
    coef = solve_normal(cols * scale[:, None], rhs * scale)

    # 2. Gauss-Newton on the loss itself (the model is 1/g, g linear in the coefficients);
    #    a step is kept only where g stays positive and the loss drops.
    def normal_equations(c):
        """`J^T J`, `J^T r` and the loss (x2) of the residuals at coefficients `c`."""
        g = cols @ c + fixed_part
        ok = jnp.all(g > 0) & jnp.all(jnp.isfinite(g))
        gs = jnp.where(g > 0, g, 1)
        if loss == "relative":
            r, dr_dg = h / gs - 1, -h / (gs * gs)
        elif loss == "log":
            r, dr_dg = -jnp.log(gs) + jnp.log(jnp.where(target > 0, target, 1)), -1 / gs
        else:
            r, dr_dg = 1 / gs - target, -1 / (gs * gs)
        r, jac = weights * r, (weights * dr_dg)[:, None] * cols
        cost = jnp.where(ok, jnp.sum(r * r), jnp.inf)
        return jac.T @ jac, jac.T @ r, cost

    def gauss_newton(_, carry):
        # the normal equations of the kept coefficients ride along (k x k, cheap to
        # carry): one evaluation, of the trial point, per iteration
        coef, jtj, jtr, cost = carry
        trial = coef - spd_solve(jtj + eye * (jnp.finfo(dtype).eps * jnp.trace(jtj)), jtr)
        trial_jtj, trial_jtr, trial_cost = normal_equations(trial)
        better = trial_cost < cost
        keep = lambda new, old: jnp.where(better, new, old)  # noqa: E731
        return keep(trial, coef), keep(trial_jtj, jtj), keep(trial_jtr, jtr), keep(trial_cost, cost)

    # a loop, not unrolled: the compiled graph (and compile time) stays small
    carry = (coef, *normal_equations(coef))
    coef = jax.lax.fori_loop(0, GAUSS_NEWTON_STEPS, gauss_newton, carry)[0]
    coef = coef / jnp.where(norms > 0, norms, 1)
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
