"""The optimistix solvers a fit uses, by name, and attenfit's Levenberg-Marquardt.

Every solver is an optimistix solver run by `optimistix.least_squares` (or
`optimistix.minimise` for BFGS). The default, `LevenbergMarquardt` below, is written
against optimistix's `AbstractLeastSquaresSolver` interface (optimistix's "Custom solvers"
documentation) rather than composed from its descents and searches, for two measured
reasons:

- optimistix's Gauss-Newton family carries the residual vector and a linearised Jacobian
  (the intermediate arrays of `jax.linearize`) in its loop state. Under `vmap` every step
  then selects and copies each of those n-length arrays for every problem: on 1,000
  polynomial fits of 256 samples that bookkeeping was 27 of the 50 ms of a 4-step solve
  (XLA CPU profile). This solver's state is the normal equations (k x k), the loss and
  the damping: O(k^2) per problem.
- optimistix's `LevenbergMarquardt` tests for convergence only after an accepted step,
  and at an optimum the acceptance ratio is rounding noise: a fit started on its optimum
  measured 16 rejected steps. Here a step whose predicted reduction is below rounding
  noise is accepted and ends the solve, and a first-order optimum ends it too.

optimistix's own LM stays available as "optimistix_lm", and the tests compare the two.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import optimistix as optx
from jaxtyping import Array, Float, PyTree, Scalar

__all__ = [
    "SOLVERS",
    "LevenbergMarquardt",
    "gradient_cosines",
    "gram",
    "gram_and_norm",
    "jacobian_rows",
    "make_solver",
    "normal_equations",
    "reduce_samples",
    "spd_solve",
    "sums",
]

#: Largest k solved by the unrolled Cholesky; larger systems use LAPACK's.
UNROLL_MAX = 8


def spd_solve(a: Float[Array, "k k"], b: Float[Array, " k"]) -> Float[Array, " k"]:
    """Solve `a x = b` for a small symmetric positive definite `a`.

    Up to `UNROLL_MAX` unknowns by an unrolled Cholesky: elementwise arithmetic only, so
    under `vmap` it vectorises over the batch, where a batched LAPACK call per 3x3 system
    costs several times more on CPU (measured 0.07 ms against 0.44 ms for 1,000 systems).
    A non-positive pivot gives NaN, which callers treat as a failed step.
    """
    k = a.shape[0]
    if k > UNROLL_MAX:
        return jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(a), b)
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


def sums(*xs: Float[Array, " n"]) -> tuple[Scalar, ...]:
    """The sums of several equal-length arrays, as one reduction (`reduce_samples`)."""
    return reduce_samples(xs)


def reduce_samples(
    sum_of: Sequence[Float[Array, "*m n"]], max_of: Sequence[Float[Array, "*m n"]] = ()
) -> tuple[Float[Array, "*m"], ...]:
    """The sums of the arrays `sum_of`, then the maxima of `max_of`, as one reduction
    over their last axis (the samples; leading axes are kept).

    One variadic `lax.reduce`: XLA's CPU backend fuses it with the elementwise work that
    produces its operands into one loop over the samples, where separate `jnp.sum`s are
    separate kernels, each with its own pass over memory (measured on 1,000 problems of
    256 samples: residuals, 3 Jacobian rows and their 10 sums, 0.85 ms against 2.0 ms).
    NaN propagates through both (XLA's max propagates NaN).
    """
    xs = (*sum_of, *max_of)
    m = len(sum_of)
    init = tuple(
        jnp.zeros((), x.dtype) if i < m else jnp.full((), -jnp.inf, x.dtype)
        for i, x in enumerate(xs)
    )

    def combine(a, b):
        return tuple(
            u + v if i < m else jax.lax.max(u, v) for i, (u, v) in enumerate(zip(a, b, strict=True))
        )

    return jax.lax.reduce(xs, init, combine, (xs[0].ndim - 1,))


def gram(
    rows: Sequence[Float[Array, " n"]], b: Float[Array, " n"], batched: bool = False
) -> tuple[Float[Array, "k k"], Float[Array, " k"]]:
    """`(A A^T, A b)` for the k rows of a wide matrix `A`.

    One matrix product for a single problem (fewest kernels). Under `vmap`
    (`batched=True`) the k (k + 1) / 2 + k row-pair sums as one reduction (`sums`): XLA's
    CPU backend runs the batched (k, n) x (n, k) matmul about twice as slowly.
    """
    ata, atb, _ = gram_and_norm(rows, b, batched)
    return ata, atb


def gram_and_norm(
    rows: Sequence[Float[Array, " n"]], b: Float[Array, " n"], batched: bool = False
) -> tuple[Float[Array, "k k"], Float[Array, " k"], Scalar]:
    """`(A A^T, A b, b . b)`, in the same one product or one reduction as `gram`."""
    k = len(rows)
    if not batched:
        m = jnp.stack([*rows, b])
        full = m @ m.T
        return full[:k, :k], full[:k, k], full[k, k]
    pairs = [(i, j) for i in range(k) for j in range(i, k)]
    out = sums(*(rows[i] * rows[j] for i, j in pairs), *(row * b for row in rows), b * b)
    pair_sum = dict(zip(pairs, out, strict=False))
    ata = jnp.stack(
        [jnp.stack([pair_sum[min(i, j), max(i, j)] for j in range(k)]) for i in range(k)]
    )
    return ata, jnp.stack(out[len(pairs) : len(pairs) + k]), out[-1]


#: Under `vmap`, up to this many parameters take a `jvp` each (`jacobian_rows`).
_JVP_EACH_MAX = 3


def jacobian_rows(
    fn: Callable, y: Float[Array, " k"], *args: Any, batched: bool = False
) -> tuple[Any, Any, list]:
    """`fn(y, *args) = (out, aux)`, and the rows `d out / d y_i`, i = 1..k (forward mode).

    For one problem, one `jvp` with the k unit tangents batched (`vmap`, as `jax.jacfwd`):
    the primal and every tangent-independent factor (a reciprocal's 1/y^2, say) are
    computed once, in the fewest kernels (one polynomial fit: 0.17 ms a solve, against
    0.22 ms with a `jvp` per parameter). Under `vmap` (`batched`), one `jvp` per parameter:
    with batched tangents a tangent-independent factor is broadcast over them, and XLA then
    writes an expensive one (a division) to memory before the pass over the samples instead
    of fusing it into that pass; separately, each step is one fused pass, divisions repeated
    (1,000 polynomial fits of 256 samples: 4.8 -> 4.3 ms a solve back to back, 6.5 -> 5.7-6.2
    ms right after other work). Past 3 parameters the batched tangents win again: a `jvp`
    each is k copies of the model in the program (1,000 `spline` fits, 6 knots: 183 ms
    against 247 ms, `python -m benchmarks fit`, same run; its solve compiles in 3.4 s against
    4.4 s).
    """
    eye = jnp.eye(y.shape[0], dtype=y.dtype)

    def push(tangent):
        return jax.jvp(lambda v: fn(v, *args), (y,), (tangent,), has_aux=True)

    if batched and y.shape[0] <= _JVP_EACH_MAX:
        pushed = [push(tangent) for tangent in eye]
        out, _, aux = pushed[0]
        return out, aux, [row for _, row, _ in pushed]
    out, rows, aux = jax.vmap(push, out_axes=(None, 0, None))(eye)
    return out, aux, list(rows)


class _LMState(eqx.Module):
    evaluated: Array  # the last point evaluated and accepted: the current point, except
    # after a final Gauss-Newton step (see `LevenbergMarquardt`)
    loss: Array  # 0.5 |r|^2 at `evaluated` (inf where not finite)
    jtj: Array  # J^T J at `evaluated`
    jtr: Array  # J^T r at `evaluated`
    scale: Array  # Marquardt's damping scale: running max of diag(J^T J)
    lam: Array  # damping, relative to `scale`
    nu: Array  # Nielsen's growth factor for rejected steps
    crossing_rejected: Array  # the last step crossed 0 in a reflected coordinate, rejected
    terminate: Array
    result: optx.RESULTS


def normal_equations(fn, y, args, batched: bool = False):
    """`(loss, J^T J, J^T r, aux, n)` of the residuals `fn(y, args)` at `y` (a 1-D array).

    One forward-mode pass (`jacobian_rows`). Non-finite residuals give an infinite loss.
    `batched`: traced under `vmap` (see `gram`).
    """

    def res(v):
        r, aux = fn(v, args)
        return jnp.ravel(r).astype(y.dtype), aux

    r, aux, rows = jacobian_rows(res, y, batched=batched)
    rows = [row.astype(y.dtype) for row in rows]
    jtj, jtr, rr = gram_and_norm(rows, r, batched)
    loss = 0.5 * rr
    ok = jnp.isfinite(loss) & jnp.all(jnp.isfinite(jtj)) & jnp.all(jnp.isfinite(jtr))
    return (
        jnp.where(ok, loss, jnp.inf),
        jnp.where(ok, jtj, 0),
        jnp.where(ok, jtr, 0),
        aux,
        r.shape[0],
    )


def gradient_cosines(jtj: Float[Array, "k k"], jtr: Float[Array, " k"], rnorm: Array) -> Array:
    """|cos| of the angle between the residual vector (norm `rnorm`) and each Jacobian column.

    All 0 at a first-order optimum; invariant to rescaling a parameter.
    """
    denom = jnp.sqrt(jnp.maximum(jnp.diagonal(jtj), 0)) * rnorm
    return jnp.abs(jtr) / jnp.where(denom > 0, denom, 1)  # denom 0 means jtr 0; inf stays


def first_order_optimal(loss, jtj, jtr, gtol):
    """MINPACK's gtol test: the cosine between r and every Jacobian column is <= gtol."""
    cos = gradient_cosines(jtj, jtr, jnp.sqrt(2 * loss))
    return jnp.isfinite(loss) & (jnp.max(cos) <= gtol)


class LevenbergMarquardt(optx.AbstractLeastSquaresSolver):
    """Levenberg-Marquardt on the normal equations, as an optimistix least-squares solver.

    Each step solves `(J^T J + lam D) delta = -J^T r` (D: Marquardt's scaling, the running
    maximum of diag(J^T J), floored at `FLOOR` of its largest entry; an unrolled Cholesky for
    small k) and evaluates the residuals
    and Jacobian once, at the trial point. The step is accepted when the loss drops by at
    least 1e-4 of the predicted reduction, or when the predicted reduction is below
    rounding noise (`noise` x loss) and the loss did not rise (the solve has settled);
    `lam` follows Nielsen's update (H. B. Nielsen, "Damping parameter in Marquardt's method",
    IMM-REP-1999-05: `lam *= max(1/3, 1 - (2 rho - 1)^3)` on acceptance, `lam *= nu, nu *= 2`
    on rejection), except that it may fall 10x per step, not 3x (a far polynomial start
    measured 21 steps against 26, Yuksel's curve from r = 1e4 20 against 27, and a fit from
    the data-derived start the same 4). The solve
    stops on an accepted step that is small in `y` (each |delta_i| < atol + rtol |y_i|) and
    in the residuals (|J delta| < atol sqrt(n) + rtol |r|; optimistix's Cauchy test), or
    whose actual and predicted relative reductions of the loss are both at most rtol
    (MINPACK's ftol test, as scipy's `least_squares`), or at a first-order optimum
    (MINPACK's gtol test with gtol = rtol), or at a loss at most `options["exact_loss"]`
    (residuals at rounding level, where those tests read noise); it stops with
    `nonlinear_divergence` when the
    damping has grown past 1/eps^2 (no step can reduce the loss), and with `nonfinite`
    when the start's residuals are not finite.

    `reflected` marks coordinates on which the residuals depend through `|y_i|` (attenfit's
    nonnegative parameters, `attenfit._fit._reparam`). Their linear model holds on one side of 0
    only. A step may cross 0 (the parameter is reflected back, which speeds far starts:
    21 steps against 37 when stopping on 0), but after a rejected crossing step the next
    one stops on 0; and a coordinate on 0 whose step heads below it stays there while the
    others are solved for without it (an active set, as in projected Gauss-Newton).
    Without this a fit whose optimum is on 0 in two parameters stalled at a loss of 31
    (rejected steps, damping growing until the ftol test ended it; now 15 steps).
    """

    rtol: float
    atol: float
    norm: Callable[[PyTree], Scalar] = optx.max_norm
    noise: float = 1e-13
    initial_damping: float = 1e-3
    batched: bool = False  # traced under vmap: sets how the normal equations are summed
    reflected: tuple[bool, ...] = ()  # coordinates u of a reflection p = |u| (see class)

    def init(self, fn, y, args, options, f_struct, aux_struct, tags):
        loss, jtj, jtr, _, _ = normal_equations(fn, y, args, self.batched)
        exact = loss <= options.get("exact_loss", 0)
        diag = jnp.diagonal(jtj)
        scale = _damping_scale(diag, jnp.zeros_like(diag))
        finite = jnp.isfinite(loss)
        return _LMState(
            evaluated=y,
            loss=loss,
            jtj=jtj,
            jtr=jtr,
            scale=scale,
            lam=jnp.asarray(self.initial_damping, y.dtype),
            nu=jnp.asarray(2.0, y.dtype),
            crossing_rejected=jnp.zeros((), bool),
            terminate=jnp.invert(finite) | exact | first_order_optimal(loss, jtj, jtr, self.rtol),
            result=optx.RESULTS.where(finite, optx.RESULTS.successful, optx.RESULTS.nonfinite),
        )

    def _step(self, y, jtj, jtr, lam, scale, stop_at_zero):
        """The damped step from `y`; on `reflected` coordinates it may stop at 0 (see class).

        Returns the step and whether it crosses 0 in a reflected coordinate (before being
        stopped there: a stopped step is no Levenberg-Marquardt step, so no convergence test
        is read from it).
        """
        a = jtj + lam * jnp.diag(scale)
        delta = -spd_solve(a, jtr)
        if not any(self.reflected):
            return delta, jnp.zeros((), bool)
        reflected = jnp.asarray(self.reflected)
        # on 0 and heading below it: held there, the others solved for without it
        held = reflected & (y == 0) & (delta < 0)
        free = jnp.invert(held)
        both = free[:, None] & free[None, :]
        a = jnp.where(both, a, jnp.eye(a.shape[0], dtype=a.dtype))
        delta = -spd_solve(a, jnp.where(free, jtr, 0))
        crossing = reflected & (y * (y + delta) < 0)
        return jnp.where(crossing & stop_at_zero, -y, delta), jnp.any(crossing)

    def step(self, fn, y, args, options, state, tags):
        dtype = y.dtype
        eps = jnp.finfo(dtype).eps
        delta, crossed = self._step(
            y, state.jtj, state.jtr, state.lam, state.scale, state.crossing_rejected
        )
        trial = y + delta
        loss_t, jtj_t, jtr_t, aux, n = normal_equations(fn, trial, args, self.batched)
        predicted = -(state.jtr @ delta + 0.5 * delta @ (state.jtj @ delta))
        actual = state.loss - loss_t
        finite = jnp.all(jnp.isfinite(delta)) & jnp.isfinite(loss_t)
        rho = actual / jnp.where(predicted > 0, predicted, 1)
        settled = (predicted <= self.noise * state.loss) & (
            loss_t <= state.loss * (1 + 8 * self.noise)
        )
        accept = finite & (((predicted > 0) & (rho > 1e-4)) | settled)
        rho = jnp.clip(rho, 0, 1)
        lam = jnp.where(
            accept,
            state.lam * jnp.maximum(0.1, 1 - (2 * rho - 1) ** 3),
            state.lam * state.nu,
        )
        nu = jnp.where(accept, 2, 2 * state.nu).astype(dtype)
        # Cauchy's test on the accepted step, as optimistix's (y: elementwise; residuals:
        # the 2-norm of their linearised change J delta)
        small_y = jnp.all(jnp.abs(delta) < self.atol + self.rtol * jnp.abs(y))
        jd = jnp.sqrt(jnp.maximum(delta @ (state.jtj @ delta), 0))
        small_f = jd < self.atol * jnp.sqrt(jnp.asarray(n, dtype)) + self.rtol * jnp.sqrt(
            2 * state.loss
        )
        keep = lambda new, old: jnp.where(accept, new, old)  # noqa: E731
        loss, jtj, jtr = keep(loss_t, state.loss), keep(jtj_t, state.jtj), keep(jtr_t, state.jtr)
        optimal = first_order_optimal(loss, jtj, jtr, self.rtol) | (
            loss <= options.get("exact_loss", 0)
        )
        stuck = lam > 1 / eps**2
        # MINPACK's ftol test (scipy's least_squares): actual and predicted relative
        # reductions of the loss both at most rtol
        small_reduction = (actual <= self.rtol * state.loss) & (predicted <= self.rtol * state.loss)
        scale = keep(_damping_scale(jnp.diagonal(jtj_t), state.scale), state.scale)
        # The next step, from the normal equations just evaluated: when it predicts a
        # relative reduction of at most rtol (the next step would end the solve by the ftol
        # test), it is taken unevaluated and the solve ends; the caller evaluates the end
        # point and keeps `evaluated` if that is better.
        step_next, crossing_next = self._step(trial, jtj_t, jtr_t, lam, scale, False)
        predicted_next = -(jtr_t @ step_next + 0.5 * step_next @ (jtj_t @ step_next))
        last = (
            accept
            & jnp.invert(crossing_next)
            & jnp.all(jnp.isfinite(step_next))
            & (predicted_next >= 0)
            & (predicted_next <= self.rtol * loss_t)
        )
        stopped = crossed & state.crossing_rejected  # stopped on 0: no test reads it
        terminate = (
            accept
            & (
                (jnp.invert(stopped) & ((small_y & small_f) | small_reduction | settled))
                | optimal
                | last
            )
        ) | stuck
        result = optx.RESULTS.where(
            stuck & jnp.invert(accept), optx.RESULTS.nonlinear_divergence, optx.RESULTS.successful
        )
        new_y = keep(trial, y)
        new_state = _LMState(
            evaluated=new_y,
            loss=loss,
            jtj=jtj,
            jtr=jtr,
            scale=scale,
            lam=lam,
            nu=nu,
            crossing_rejected=crossed & jnp.invert(accept),
            terminate=terminate,
            result=result,
        )
        return jnp.where(last, trial + step_next, new_y), new_state, aux

    def terminate(self, fn, y, args, options, state, tags):
        return state.terminate, state.result

    def postprocess(self, fn, y, aux, args, options, state, tags, result):
        return y, aux, {}


#: Floor of Marquardt's scaling, relative to its largest entry. With no floor a coordinate
#: the residuals barely see (a window's range far beyond the data) is barely damped and
#: can run off to infinity in a few steps and stop there on a vanishing gradient: fitting
#: `just_cause_2` to its own curve from a start 256x too long went to r_max = 1e126. At
#: 1e-4 it converges (13 steps) and a far polynomial start takes 21 steps (23 without);
#: 1e-3 and 1e-2 converge too, in 19-24 and 27-28 steps.
FLOOR = 1e-4


def _damping_scale(diag, previous):
    """Marquardt's scaling: the running max of diag(J^T J), floored at `FLOOR` of its max."""
    scale = jnp.maximum(diag, previous)
    top = jnp.max(scale)
    floor = jnp.where(top > 0, FLOOR * top, 1)
    return jnp.maximum(scale, floor)


def make_solver(
    name: str,
    rtol: float,
    atol: float,
    eps: float,
    batched: bool = False,
    reflected: tuple[bool, ...] = (),
) -> Any:
    """The solver called `name` (see `SOLVERS`) with tolerances, for a dtype of epsilon `eps`.

    `batched`: the solve is traced under `vmap` (attenfit's LM sums differently then);
    `reflected`: the coordinates that are reflections p = |u| (attenfit's LM steps stop
    on 0 in them).
    """
    return SOLVERS[name](rtol, atol, eps, batched, reflected)


#: Solver names accepted by `attenfit.fit`, each a factory `(rtol, atol, eps, batched,
#: reflected)` (see `make_solver`). "levenberg_marquardt" is the solver above;
#: "optimistix_lm" is optimistix's own, unchanged.
SOLVERS: dict[str, Callable[..., Any]] = {
    "levenberg_marquardt": lambda rtol, atol, eps, batched, reflected: LevenbergMarquardt(
        rtol, atol, noise=64 * eps, batched=batched, reflected=reflected
    ),
    "dogleg": lambda rtol, atol, eps, batched, reflected: optx.Dogleg(rtol=rtol, atol=atol),
    "gauss_newton": lambda rtol, atol, eps, batched, reflected: optx.GaussNewton(
        rtol=rtol, atol=atol
    ),
    "bfgs": lambda rtol, atol, eps, batched, reflected: optx.BFGS(rtol=rtol, atol=atol),
    "optimistix_lm": lambda rtol, atol, eps, batched, reflected: optx.LevenbergMarquardt(
        rtol=rtol, atol=atol
    ),
}
