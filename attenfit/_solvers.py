"""The optimistix solvers a fit uses, by name, and attenfit's Levenberg-Marquardt variant.

optimistix's `LevenbergMarquardt` is a Gauss-Newton solver composed of a damped-Newton
descent and a classical trust-region search, and it tests for convergence (Cauchy: small
change in `y` and in the residuals) only after an *accepted* step. At an optimum the
predicted reduction of the loss is below rounding noise, so the acceptance ratio is noise
and steps are rejected one after another while the trust region shrinks by 4x each time:
a fit that started on its optimum measured 16 wasted steps (and a vmapped batch waits for
its slowest problem). `SettlingTrustRegion` is the same classical trust region, except that
a step whose predicted reduction is below rounding noise of the loss is accepted (the loss
cannot meaningfully go down any more), so the Cauchy test runs and the solve stops. It also
starts from a larger trust region: the coordinates a fit moves are scale-free (logs, or
values divided by their start), and a fit usually starts close to its optimum
(`attenfit._guess`), so the first step should be nearly undamped Gauss-Newton.

Composing a solver from a descent and a search is optimistix's intended way to customise
one (see optimistix's "Custom solvers" documentation); nothing here patches optimistix.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import lineax as lx
import optimistix as optx
from jaxtyping import PyTree, Scalar

__all__ = ["NORMAL_CHOLESKY", "SOLVERS", "LevenbergMarquardt", "SettlingTrustRegion", "make_solver"]


#: The damped Gauss-Newton step solves `[J; sqrt(lambda) I] x = [r; 0]` in the least-squares
#: sense. optimistix's default, QR, factorises the tall `(n + k) x k` matrix with a LAPACK
#: call per problem; the normal equations `(J^T J + lambda I) x = J^T r` need one `(k, n)
#: x (n, k)` product and a `k x k` Cholesky (lineax's `Normal(Cholesky())`). With
#: `lambda > 0` the system is positive definite; squaring the condition number costs
#: digits only in the step, not in the solution (the trust region checks every step
#: against the true loss). Measured on 1,000 polynomial fits: about 10% less CPU time
#: per solve, and the same losses (tests/test_fit.py compares it with QR).
NORMAL_CHOLESKY = lx.Normal(lx.Cholesky())


class SettlingTrustRegion(optx.AbstractSearch):
    """optimistix's `ClassicalTrustRegion`, accepting steps with no reduction left to make.

    A step is also accepted when the predicted reduction is at most `noise` times the
    loss (rounding level); the search then keeps its step size.
    """

    inner: optx.ClassicalTrustRegion
    initial_step_size: float
    noise: float

    def init(self, y, f_info_struct):
        state = self.inner.init(y, f_info_struct)
        dtype = jnp.result_type(*jax.tree_util.tree_leaves(y))  # float32 fits stay float32
        return eqx.tree_at(lambda s: s.step_size, state, jnp.asarray(self.initial_step_size, dtype))

    def step(self, first_step, y, y_eval, f_info, f_eval_info, state):
        step_size, accept, result, new_state = self.inner.step(
            first_step, y, y_eval, f_info, f_eval_info, state
        )
        y_diff = jnp.asarray(y_eval) - jnp.asarray(y)
        predicted = self.inner.predict_reduction(y_diff, f_info)
        loss = f_info.as_min()
        settled = jnp.invert(first_step) & (predicted >= -self.noise * loss)
        settled = settled & (f_eval_info.as_min() <= loss * (1 + 8 * self.noise))
        keep = settled & jnp.invert(accept)
        new_state = eqx.tree_at(
            lambda s: s.step_size, new_state, jnp.where(keep, state.step_size, new_state.step_size)
        )
        return jnp.where(keep, state.step_size, step_size), accept | settled, result, new_state


class LevenbergMarquardt(optx.AbstractGaussNewton):
    """Levenberg-Marquardt: optimistix's damped-Newton descent with `SettlingTrustRegion`."""

    rtol: float
    atol: float
    norm: Callable[[PyTree], Scalar]
    descent: optx.DampedNewtonDescent
    search: SettlingTrustRegion
    verbose: Callable[..., None]

    def __init__(
        self,
        rtol: float,
        atol: float,
        *,
        noise: float = 1e-13,
        initial_step_size: float = 100.0,
        linear_solver: lx.AbstractLinearSolver | None = None,
    ):
        self.rtol = rtol
        self.atol = atol
        self.norm = optx.max_norm
        self.descent = optx.DampedNewtonDescent(linear_solver=linear_solver or NORMAL_CHOLESKY)
        self.search = SettlingTrustRegion(optx.ClassicalTrustRegion(), initial_step_size, noise)
        self.verbose = lambda **kwargs: None


def make_solver(name: str, rtol: float, atol: float, eps: float) -> Any:
    """The solver called `name` (see `SOLVERS`) with tolerances, for a dtype of epsilon `eps`."""
    return SOLVERS[name](rtol, atol, eps)


#: Solver names accepted by `attenfit.fit`. "levenberg_marquardt" is the variant above;
#: "optimistix_lm" is optimistix's own, unchanged.
SOLVERS: dict[str, Callable[[float, float, float], Any]] = {
    "levenberg_marquardt": lambda rtol, atol, eps: LevenbergMarquardt(rtol, atol, noise=64 * eps),
    "dogleg": lambda rtol, atol, eps: optx.Dogleg(rtol=rtol, atol=atol),
    "gauss_newton": lambda rtol, atol, eps: optx.GaussNewton(rtol=rtol, atol=atol),
    "bfgs": lambda rtol, atol, eps: optx.BFGS(rtol=rtol, atol=atol),
    "optimistix_lm": lambda rtol, atol, eps: optx.LevenbergMarquardt(rtol=rtol, atol=atol),
}
