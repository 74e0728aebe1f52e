"""The solve of one problem, or of a batch under `vmap`, as one traced function: candidate
starts, the optimistix solve, and a final pass for the end point, bounds and metrics, its
outputs packed into one vector (`layout`)."""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array

from ._guess import clamp_candidate, in_order, linear_candidate, scale_candidates
from ._layout import SOLVE_LAYOUT, finish_layout
from ._reparam import by_kind, param_slope, to_internal, to_param
from ._solvers import (
    LevenbergMarquardt,
    gradient_cosines,
    gram,
    jacobian_rows,
    reduce_samples,
    sums,
)
from ._spec import Spec, free_kinds, free_slices


# ----------------------------------------------------------------------------- compiled solve
def _residual_of_values(loss: str):
    """`prepare(target, weights)`: the residual function `f -> r` of model values against
    `target` for `loss` (see the module docstring), with its per-sample constants (w / t,
    log t) computed once per solve rather than at every step. `weights` None: all 1;
    `inv_target`: 1 / target where it is > 0, else 0."""

    def prepare(target, weights, inv_target):
        w = 1 if weights is None else weights
        if loss == "relative":
            w = w * inv_target
            return lambda f: (f - target) * w
        if loss == "log":
            tiny = jnp.finfo(target.dtype).tiny
            log_t = jnp.log(target)
            return lambda f: w * (jnp.log(jnp.where(f > tiny, f, tiny)) - log_t)
        return lambda f: w * (f - target)

    return prepare


def _on_bound(kind: str, u: Array) -> Array:
    """Whether coordinate `u` puts a parameter of constraint `kind` on its bound."""
    eps = jnp.finfo(u.dtype).eps
    if kind == "nonnegative":
        return u == 0
    if kind == "positive":  # exp(u) cannot reach 0; a parameter that ran towards it is on it
        return jnp.exp(u) < eps**1.5
    if kind == "unit":
        q = jax.nn.sigmoid(u)
        return (q < eps) | (q > 1 - eps)
    return jnp.zeros(u.shape, bool)


#: Samples the start scan compares its candidates on (every (n // this)-th sample, when
#: that skips any): 1,000 fits of `yuksel` (17 candidates, 256 samples) spent 60-75% of
#: their time comparing candidates on every sample, against 8 solver steps at most.
_SCAN_SAMPLES = 32

#: Up to this many free nonnegative parameters are tried at 0 in the fit's final pass over
#: the samples (every way of zeroing some of them: 2^m points); more take a pass each.
_SUBSETS_MAX = 3

#: A nonnegative parameter is tried at 0 when the solver's linear model of the residuals
#: puts the loss there within this many times the tolerance of the fitted loss (`finish`).
#: The model is the solver's own (exact for a linear parameter); this margin covers its
#: error over the move to 0, so the test is skipped (a pass over the samples per way of
#: zeroing) only where 0 is far out of reach.
_SNAP_MARGIN = 1e6


class _Plan:
    """The static structure of one solve: what `build_problem`'s passes share (the model's
    spec, the free parameters, their constraints and places in the fitted vector, and the
    options)."""

    def __init__(self, spec: Spec, free, loss, solver_obj, max_steps, guess, rtol, atol, batched):
        self.spec, self.free, self.loss = spec, free, loss
        self.solver_obj, self.max_steps, self.guess = solver_obj, max_steps, guess
        self.rtol, self.atol, self.batched = rtol, atol, batched
        self.of_values = _residual_of_values(loss)
        self.shapes = dict(zip(spec.names, spec.shapes, strict=True))
        self.where = free_slices(spec, free)  # each free parameter's place in the fitted vector
        self.kinds = kinds = dict(zip(spec.names, spec.kinds, strict=True))
        self.free_lengths = tuple(
            p for p in spec.length_params if p in free and kinds[p] == "positive"
        )
        self.flat_kinds = free_kinds(spec, free)
        self.linear_coord = np.array([k in ("nonnegative", "real") for k in self.flat_kinds])
        self.nonneg = [j for j, kind in enumerate(self.flat_kinds) if kind == "nonnegative"]
        self.is_lm = isinstance(solver_obj, LevenbergMarquardt)
        # a clamped distance's parameter (`Family.clamp_param`), free and scalar, under a
        # loss affine in the model's values: its exact start (`_guess.clamp_candidate`)
        clamp = spec.clamp_param
        usable = clamp in free and self.shapes[clamp] == () and kinds[clamp] == "positive"
        self.clamp = clamp if guess and usable and loss != "log" and not spec.inputs else None
        self.clamp_alone = self.clamp is not None and tuple(free) == (clamp,)

    def split(self, vec, values):
        """`values` with the free parameters read from the parameter vector `vec`."""
        out = dict(values)
        for p in self.free:
            out[p] = vec[self.where[p]].reshape(self.shapes[p])
        return out

    def to_u(self, blocks):
        """The coordinates of parameter sets, one row each. `blocks`: dicts of the free
        parameters' values with a leading axis of rows; each parameter's rows are stacked
        first, so that each map is one operation on all of them."""
        cols = [
            jnp.concatenate([jnp.reshape(b[p], (b[p].shape[0], -1)) for b in blocks])
            for p in self.free
        ]
        return jnp.concatenate(
            [to_internal(self.kinds[p], x) for p, x in zip(self.free, cols, strict=True)], axis=1
        )

    def from_u(self, u, values):
        """`values` with the free parameters at the coordinates `u`."""
        out = dict(values)
        for p in self.free:
            out[p] = to_param(self.kinds[p], u[self.where[p]].reshape(self.shapes[p]))
        return out

    def threshold(self, best, n):
        """0 fits as well within the tolerances: the loss rises by at most rtol relative
        plus an RMS residual change of atol."""
        return best * (1 + self.rtol) + 0.5 * n * self.atol**2


def _inverse(target):
    """1 / target where it is > 0, else 0."""
    pos = target > 0
    return jnp.where(pos, 1 / jnp.where(pos, target, 1), 0)


class _Passes:
    """Residuals and losses of one problem: `values` (the fixed ones), d, target, ..."""

    def __init__(self, plan: _Plan, values, d, target, weights, inv_target):
        self.plan = plan
        self.values, self.d, self.target, self.inv_target = values, d, target, inv_target
        self.weights = weights
        self.residual = plan.of_values(target, weights, inv_target)
        self.plain_relative = plan.loss == "relative" and weights is None

    def every(self, stride):
        """The same problem on every `stride`-th sample (the start scan's)."""

        def every(x):  # along the samples (an area model's d has rows of them)
            return None if x is None else x[..., ::stride]

        return _Passes(
            self.plan,
            self.values,
            every(self.d),
            every(self.target),
            every(self.weights),
            every(self.inv_target),
        )

    def model_at(self, u):
        values = self.plan.from_u(u, self.values)
        return self.plan.spec.evaluate(self.d, values).astype(self.d.dtype)

    def res_u(self, u, _=None):
        return self.residual(self.model_at(u))

    def losses(self, us):
        """0.5 |r|^2 at each row (point) of `us`, in one pass (inf where not finite)."""
        (sq,) = reduce_samples([jnp.square(jax.vmap(self.res_u)(us))])
        c = 0.5 * sq
        return jnp.where(jnp.isfinite(c), c, jnp.inf)

    def losses_and_errors(self, us):
        """...with the sums of squares and maxima of the relative errors |f - t| / t."""
        fs = jax.vmap(self.model_at)(us)
        rs = jax.vmap(self.residual)(fs)
        if self.plain_relative:  # the residuals are the relative errors
            sq, max_err = reduce_samples([rs * rs], [jnp.abs(rs)])
            sq_err = sq
        else:
            rels = jnp.abs(fs - self.target[None]) * self.inv_target[None]
            sq, sq_err, max_err = reduce_samples([rs * rs, rels * rels], [rels])
        c = 0.5 * sq
        return jnp.where(jnp.isfinite(c), c, jnp.inf), sq_err, max_err


def _scan_start(plan: _Plan, ps: _Passes, extra=None):
    """The best of the caller's values, the data-derived candidates (`_guess`) and `extra`
    (the free parameters' values, a row each), and its loss."""
    values, d, n = ps.values, ps.d, ps.d.shape[-1]
    free, where = plan.free, plan.where
    # the candidates, as blocks of rows (see `_Plan.to_u`)
    cands = [{p: values[p][None] for p in free}]
    if plan.guess:
        scaled = scale_candidates(values, free, plan.free_lengths)
        if scaled:
            cands.append(scaled)
        lin = linear_candidate(
            plan.spec.inverse_linear,
            values,
            free,
            plan.kinds,
            d,
            ps.target,
            ps.inv_target,
            ps.weights,
            plan.loss,
            plan.batched,
        )
        if lin is not None:
            cands.append({p: lin[p][None] for p in free})
    if extra is not None:
        cands.append(extra)
    us = plan.to_u(cands)
    stride = n // _SCAN_SAMPLES
    scan = ps if us.shape[0] <= 3 or stride < 2 else ps.every(stride)
    scan_costs = scan.losses(us)
    if plan.spec.range_param in plan.free_lengths:
        # a window's range is scanned beyond the farthest sample only: a range inside
        # the data cuts the curve to 0 there, a basin of its own (1,000 just_cause_2
        # fits: 437 ended worse than scipy's from the same starts before this, 0 after)
        col = where[plan.spec.range_param].start
        inside = (jnp.exp(us[:, col]) < jnp.max(d)).at[0].set(False)
        scan_costs = jnp.where(inside, jnp.inf, scan_costs)
    best = jnp.argmin(scan_costs)
    if scan is ps:
        return us[best], scan_costs[best]  # (the start is never masked)
    # the best on the subsample and the caller's start, on every sample: the start is
    # never worse than the caller's, and the scan costs a fraction of a full pass per
    # candidate
    pair = jnp.stack([us[best], us[0]])
    costs = ps.losses(pair)
    take = jnp.argmin(costs)
    return pair[take], costs[take]


def _start(plan: _Plan, ps: _Passes, all_in_order):
    """The start and its loss, and whether it is known optimal (the solve then ends there).

    A family with a free clamp parameter (`_Plan.clamp`) adds its exact optimum given the
    other parameters' starts (`_guess.clamp_candidate`); freed alone, with the samples in
    order of distance (either way), that is the optimum: the start is then the better of it and the
    caller's values, without the scan, and known optimal in float64 (in float32 the loss
    of the intervals it compares is rounded at 1e-5 of the sum of squares, so the solver
    polishes it). `all_in_order`: every problem of the batch has its samples in order (a
    branch on the whole batch, which skips the scan where none needs it; each problem's
    start depends on its own samples only).
    """
    free, values = plan.free, ps.values
    no = jnp.zeros((), bool)
    if plan.clamp is None:
        return (*_scan_start(plan, ps), no)
    caller = {p: values[p][None] for p in free}
    f0 = ps.model_at(plan.to_u([caller])[0])
    p_c, ordered = clamp_candidate(ps.d, f0, values[plan.clamp], ps.residual)
    clamped = {**caller, plan.clamp: p_c[None]}
    if not plan.clamp_alone:
        return (*_scan_start(plan, ps, clamped), no)
    exact64 = ps.d.dtype == jnp.float64

    def exact():
        r0 = ps.residual(f0)
        (sq,) = reduce_samples([r0 * r0])
        c0 = jnp.where(jnp.isfinite(sq), 0.5 * sq, jnp.inf)
        us = plan.to_u([caller, clamped])
        c1 = ps.losses(us[1:])[0]
        take = c1 <= c0
        return jnp.where(take, us[1], us[0]), jnp.minimum(c0, c1), take & ordered & exact64

    def mixed():
        u_e, c_e, known = exact()
        u_s, c_s = _scan_start(plan, ps)
        return jnp.where(ordered, u_e, u_s), jnp.where(ordered, c_e, c_s), known

    return jax.lax.cond(all_in_order, exact, mixed)


def _solve(plan: _Plan, values, d, target, weights, inv_target, all_in_order=True):
    """The optimistix solve of one problem from its start: what `_finish` reads."""
    dtype, n = d.dtype, d.shape[-1]
    ps = _Passes(plan, values, d, target, weights, inv_target)
    u0, start_loss, known = _start(plan, ps, all_in_order)
    # The solver moves z = u / scale: nonnegative and real coordinates are scaled by
    # their start's magnitude, so a problem and its rescaled copy (another radius) take
    # the same steps; exp and sigmoid coordinates are scale-free already.
    scale = jnp.where(plan.linear_coord & (jnp.abs(u0) > 0), jnp.abs(u0), 1).astype(dtype)
    scale = jax.lax.stop_gradient(scale)

    def res_z(z, _):
        return ps.res_u(z * scale)

    # the loss of residuals at rounding level: an exact fit, where relative tests and
    # the gradient's direction are noise
    w_max = 1 if weights is None else jnp.max(weights)
    exact_loss = 0.5 * n * (64 * jnp.finfo(dtype).eps * w_max) ** 2
    # ...or a start known optimal (`_start`): the solve ends there, its rounding allowed
    known_loss = start_loss * (1 + 1024 * jnp.finfo(dtype).eps)
    exact_loss = jnp.where(known, jnp.maximum(exact_loss, known_loss), exact_loss)
    options = {"exact_loss": exact_loss} if plan.is_lm else {}
    sol = optx.least_squares(
        res_z, plan.solver_obj, u0 / scale, None, options, max_steps=plan.max_steps, throw=False
    )
    mid = dict(
        z=sol.value,
        scale=scale,
        result=sol.result._value,
        steps=sol.stats["num_steps"],
        start_loss=start_loss,
        exact_loss=exact_loss,
    )
    if plan.is_lm:
        # attenfit's LM ends with the loss and normal equations of the last point it
        # evaluated (`z_eval`; its end point `z` may be one Gauss-Newton step beyond)
        z, jtj, jtr = sol.state.evaluated, sol.state.jtj, sol.state.jtr
        mid.update(z_eval=z, jtj_z=jtj, jtr_z=jtr)
        # the linear model's loss with one nonnegative coordinate moved to 0
        near = [
            -z[j] * jtr[j] + 0.5 * z[j] ** 2 * jtj[j, j]
            <= _SNAP_MARGIN * (plan.threshold(sol.state.loss, n) - sol.state.loss)
            for j in plan.nonneg
        ]
        mid["try_zero"] = jnp.any(jnp.stack(near)) if near else jnp.zeros((), bool)
    else:
        mid["try_zero"] = jnp.asarray(bool(plan.nonneg))
    return mid


def _end_point(plan: _Plan, mid, ps: _Passes, try_zero: bool):
    """The end point, or (attenfit's LM, which does not evaluate its final step) the last
    point it evaluated, where that is better: `(u, z_end, best[, sq_err, max_err])`, the
    errors only when `try_zero` is off (else `_zero_nonneg` finds them)."""
    scale = mid["scale"]
    zs = jnp.stack([mid["z"], mid["z_eval"]] if plan.is_lm else [mid["z"]])
    ends = zs * scale[None]
    if try_zero:
        cost = ps.losses(ends)
    else:
        cost, sq_err, max_err = ps.losses_and_errors(ends)
    take_end = cost[0] <= cost[-1]

    def pick(*xs):
        """Each of `xs` (a row per end point) at the end point taken, in one selection."""
        rows = jnp.concatenate([jnp.reshape(x, (x.shape[0], -1)) for x in xs], axis=1)
        chosen = jnp.where(take_end, rows[0], rows[-1])
        cuts = np.cumsum([0] + [x[0].size for x in xs])
        return [
            chosen[a:b].reshape(x.shape[1:])
            for a, b, x in zip(cuts[:-1], cuts[1:], xs, strict=True)
        ]

    if try_zero:
        return pick(ends, zs, cost)
    return pick(ends, zs, cost, sq_err, max_err)


def _zero_nonneg(plan: _Plan, ps: _Passes, u, best, n):
    """Each nonnegative parameter in turn set to 0 where that fits as well (`threshold`,
    against the loss reached so far): `(u, best, sq_err, max_err)` at the point kept."""
    nonneg = plan.nonneg
    if len(nonneg) <= _SUBSETS_MAX:
        # Every way of zeroing them is evaluated in the one pass: bit b of a mask zeroes
        # nonneg[b].
        zeroed = np.zeros((2 ** len(nonneg), len(plan.flat_kinds)), bool)
        for mask in range(2 ** len(nonneg)):
            for b, j in enumerate(nonneg):
                zeroed[mask, j] = mask >> b & 1
        points = jnp.where(zeroed, 0, u[None])  # one row per way of zeroing
        cost, sq_err, max_err = ps.losses_and_errors(points)
        mask, best = jnp.zeros((), np.int32), cost[0]
        for b in range(len(nonneg)):
            c0 = cost[mask | (1 << b)]
            ok = c0 <= plan.threshold(best, n)
            best = jnp.where(ok, jnp.minimum(c0, best), best)
            mask = jnp.where(ok, mask | (1 << b), mask)
        u = jnp.where(jnp.asarray(zeroed)[mask], 0, u)
        return u, best, sq_err[mask], max_err[mask]
    for j in nonneg:
        c0 = ps.losses(u.at[j].set(0)[None])[0]
        ok = c0 <= plan.threshold(best, n)
        best = jnp.where(ok, jnp.minimum(c0, best), best)
        u = u.at[j].set(jnp.where(ok, 0, u[j]))
    _, sq_err, max_err = (x[0] for x in ps.losses_and_errors(u[None]))
    return u, best, sq_err, max_err


def _normal_equations(plan: _Plan, mid, ps: _Passes, u, z_end, pvec):
    """`J^T J` and `J^T r` with respect to the parameters at the fitted point."""
    flat_kinds, d, dtype = plan.flat_kinds, ps.d, ps.d.dtype
    if plan.is_lm:
        # the solver's J^T J and J^T r at its last point (a parameter snapped to its
        # bound above moved within the tolerances), taken to the parameters: J with
        # respect to them is J_z diag(dz/dp), z = u / scale
        slope = mid["scale"] * by_kind(param_slope, flat_kinds, u)
        # (at the end point beyond `z_eval`, J^T r by the solver's linear model)
        jtr_z = mid["jtr_z"] + mid["jtj_z"] @ (z_end - mid["z_eval"])
        jtj = mid["jtj_z"] / (slope[:, None] * slope[None, :])
        return jtj, jtr_z / slope

    # model values, residuals and their Jacobian rows in one forward-mode pass
    def model_values(pv):
        return plan.spec.evaluate(d, plan.split(pv, ps.values)).astype(dtype), None

    f, _, f_rows = jacobian_rows(model_values, pvec, batched=plan.batched)
    r_fin, dr_df = jax.jvp(ps.residual, (f,), (jnp.ones_like(f),))
    return gram([dr_df * row.astype(dtype) for row in f_rows], r_fin, plan.batched)


def _finish(plan: _Plan, mid, values, d, target, weights, inv_target, try_zero: bool):
    """The final pass: end point, bounds, covariance inputs and metrics, packed."""
    dtype, n = d.dtype, d.shape[-1]
    ps = _Passes(plan, values, d, target, weights, inv_target)
    try_zero = bool(try_zero and plan.nonneg)
    if not try_zero:
        u, z_end, best, sq_err, max_err = _end_point(plan, mid, ps, False)
    else:
        u, z_end, best = _end_point(plan, mid, ps, True)
        u, best, sq_err, max_err = _zero_nonneg(plan, ps, u, best, n)
    flat_kinds = plan.flat_kinds
    at_bound = by_kind(_on_bound, flat_kinds, u)
    pvec = by_kind(to_param, flat_kinds, u)
    jtj, jtr = _normal_equations(plan, mid, ps, u, z_end, pvec)
    # First-order optimality (MINPACK's gtol test, as scipy's least_squares): the
    # cosine between the residual vector and each Jacobian column, ignoring parameters
    # on their bound. optimistix's BFGS, for one, never stops at an exact optimum.
    rnorm = jnp.sqrt(2 * best)
    cos = jnp.where(at_bound, 0, gradient_cosines(jtj, jtr, rnorm))
    grad_ok = jnp.all(jnp.isfinite(cos)) & (jnp.max(cos, initial=0) <= plan.rtol)
    # ...or residuals at rounding level (an exact fit: the cosine is then noise)
    grad_ok = grad_ok | (best <= mid["exact_loss"])
    npos = n if plan.loss != "absolute" else jnp.maximum(sums((target > 0).astype(dtype))[0], 1)
    out = dict(
        pvec=pvec,
        loss=best,
        jtj=jtj,
        max_rel=max_err,
        rms_rel=jnp.sqrt(sq_err / npos),
        at_bound=at_bound,
        grad_ok=grad_ok,
    )
    return _pack(out, finish_layout(len(flat_kinds)), dtype)


def _solve_outputs(mid):
    """The outputs read off the solve alone, packed apart from `_finish`'s (so that its
    branches do not each start with them: see `_read_in_order`)."""
    out = dict(
        result=mid["result"],
        steps=mid["steps"],
        start_finite=jnp.isfinite(mid["start_loss"]),
        start_loss=mid["start_loss"],
    )
    return _pack(out, SOLVE_LAYOUT, mid["start_loss"].dtype)


def build_problem(spec: Spec, free, loss, solver_obj, max_steps, guess, rtol, atol, batched):
    """The solve: arrays in, arrays out, for one problem or (`batched`) a batch of them.

    Its passes over the samples, each one fused loop (`attenfit._fit._solvers.sums`): the linear
    start (inverse-linear models), the candidates' losses, one per solver step, and a
    final one for the metrics, which also tries nonnegative parameters at 0 when any
    problem of the batch may have its optimum there.
    """
    plan = _Plan(spec, free, loss, solver_obj, max_steps, guess, rtol, atol, batched)
    each = jax.vmap if batched else (lambda fn: fn)

    def run(values, d, target, weights=None):
        """The packed outputs of `_finish` (`_pack`), for one problem or (`batched`) with a
        leading batch axis.

        The final pass tries nonnegative parameters at 0 only when some problem may have
        its optimum there (a branch on the whole batch: under `vmap` a per-problem `cond`
        would evaluate both sides for every problem).
        """
        inv_target = each(_inverse)(target)
        # every problem's samples in order of distance (`_start`; a family's d only)
        ordered = True if plan.clamp is None else jnp.all(jnp.logical_or(*in_order(d)))
        solve = functools.partial(_solve, plan, all_in_order=ordered)
        mid = each(solve)(values, d, target, weights, inv_target)

        def fin(try_zero):
            return lambda: each(functools.partial(_finish, plan, try_zero=try_zero))(
                mid, values, d, target, weights, inv_target
            )

        if not plan.nonneg:
            packed = fin(False)()
        else:
            packed = jax.lax.cond(jnp.any(mid["try_zero"]), fin(True), fin(False))
        return jnp.concatenate([packed, each(_solve_outputs)(mid)], axis=-1)

    return run


def _pack(out: dict[str, Array], layout: list[tuple[str, tuple[int, ...]]], dtype) -> Array:
    """Outputs of one problem as one vector of the fit's float `dtype` (one transfer)."""
    return jnp.concatenate([jnp.ravel(out[name]).astype(dtype) for name, _ in layout])
