"""Least-squares fits of attenuation families with optimistix: one curve, a dataset, or a batch.

`fit` fits a family instance (its field values are the start) or a user's `(fn, params)`
pair to attenuation samples `target` at distances `d`; `fit_dataset` fits the point-light
model `E = I g f(d) max(0, n.l)` to a dataset's irradiance; `fit_many` solves thousands of
independent problems in one jitted, vmapped solve.

How (DESIGN.md section 4):
- The solver moves unconstrained coordinates (`attenfit._reparam`): `exp` for positive
  parameters, a reflection for nonnegative ones (so an optimum on 0 is reached exactly),
  a sigmoid for unit ones. After the solve, a nonnegative parameter whose value 0 fits as
  well within the tolerances is set to exactly 0 and reported as on its bound (tried where
  the solver's linear model puts 0 within `_SNAP_MARGIN` times the tolerance).
- The start is the best of the caller's start and a few data-derived candidates
  (`attenfit._guess`), evaluated inside the compiled solve.
- Residuals: `relative` = w (f - t)/t, `log` = w (log f - log t), `absolute` = w (f - t);
  `weights` w multiply residuals (like `1/sigma` in `scipy.optimize.curve_fit`). The
  reported `loss` is `0.5 * sum(residual^2)`, as optimistix and
  `scipy.optimize.least_squares` define it.
- Failure is data: the solve runs with `throw=False` and a non-converged fit comes back
  with `converged=False` and optimistix's message.
- Compiled solves are cached by (model structure, free, solver, loss, tolerances, shapes,
  dtype), so a second fit of the same kind does not re-trace.
- Covariance as `curve_fit(absolute_sigma=False)`: `pinv(J^T J) * sum(r^2) / (n - k)`, with
  J the Jacobian of the residuals with respect to the free parameters (not the internal
  coordinates) at the solution.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
import optimistix as optx
from jaxtyping import Array, ArrayLike, Float

from ._errors import BadTypeError, BadValueError, UnknownNameError
from ._family import Family
from ._guess import linear_candidate, scale_candidates
from ._reparam import by_kind, param_slope, to_internal, to_param
from ._solvers import (
    SOLVERS,
    LevenbergMarquardt,
    gradient_cosines,
    gram,
    jacobian_rows,
    make_solver,
    reduce_samples,
    sums,
)

__all__ = ["LOSSES", "SOLVERS", "FitResult", "FitResults", "fit", "fit_dataset", "fit_many"]

#: Loss names accepted by `fit` (see the module docstring for the residuals).
LOSSES = ("relative", "log", "absolute")


_CONSTRAINT_WORDS = {
    "positive": "> 0",
    "nonnegative": ">= 0",
    "unit": "strictly between 0 and 1",
    "real": "finite",
}


# ----------------------------------------------------------------------------- the model
@dataclasses.dataclass(frozen=True)
class _Spec:
    """The static structure of a model: what a compiled solve depends on."""

    key: Any  # hashable: family treedef or the user's fn
    evaluate: Callable[[Array, dict[str, Array]], Array] = dataclasses.field(compare=False)
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    shapes: tuple[tuple[int, ...], ...]  # per-problem shape of each parameter
    family: str | None
    length_params: tuple[str, ...]
    #: the model's pytree leaves are exactly its parameters, in `names` order, so a fitted
    #: model is `tree_unflatten(treedef, values)` (20x cheaper than `eqx.tree_at`)
    leaves_are_params: bool = False


def _family_spec(model: Family, batched: bool) -> tuple[_Spec, dict[str, np.ndarray]]:
    cls = type(model)
    leaves, treedef = jax.tree_util.tree_flatten(model)
    spec = _FAMILY_SPECS.get((cls, treedef))
    if spec is None:
        spec = _FAMILY_SPECS[cls, treedef] = _new_family_spec(model, treedef)
    if spec.leaves_are_params:
        values = {n: np.asarray(v) for n, v in zip(spec.names, leaves, strict=True)}
    else:
        values = {n: np.asarray(getattr(model, n)) for n in spec.names}
    for n, v in values.items():
        if v.dtype.kind not in "fiu":
            raise BadTypeError(
                f"parameter {n!r} of {cls.name!r} must be a real number, got dtype {v.dtype}"
            )
    return spec, values


#: The static structure of each (family class, pytree structure) seen, built once: a
#: repeated `fit` of the same kind of model skips the class introspection.
_FAMILY_SPECS: dict[Any, _Spec] = {}


def _new_family_spec(model: Family, treedef: Any) -> _Spec:
    cls = type(model)
    names = cls.param_names()
    template = model

    def evaluate(d, params):
        m = eqx.tree_at(
            lambda m: [getattr(m, n) for n in names],
            template,
            [params[n] for n in names],
            is_leaf=lambda x: x is None,
        )
        return m(d)

    return _Spec(
        key=(cls, treedef),
        evaluate=evaluate,
        names=names,
        kinds=tuple(cls.constraint(n) for n in names),
        shapes=(),  # set by _prepare, which knows the batch size
        family=getattr(cls, "name", None),
        length_params=tuple(getattr(cls, "length_params", ())),
        leaves_are_params=_leaves_are_params(model, names),
    )


_LEAVES_ARE_PARAMS: dict[Any, bool] = {}


def _leaves_are_params(model: Family, names: tuple[str, ...]) -> bool:
    treedef = jax.tree_util.tree_structure(model)
    key = (type(model), treedef)
    if key not in _LEAVES_ARE_PARAMS:
        leaves = jax.tree_util.tree_leaves(model)
        _LEAVES_ARE_PARAMS[key] = len(leaves) == len(names) and all(
            leaf is getattr(model, n) for leaf, n in zip(leaves, names, strict=False)
        )
    return _LEAVES_ARE_PARAMS[key]


def _rebuild(spec: _Spec, template: Family, fields: Sequence[Any]) -> Family:
    """`template` with its parameters replaced by `fields` (in `spec.names` order)."""
    if spec.leaves_are_params:
        return jax.tree_util.tree_unflatten(spec.key[1], list(fields))
    return eqx.tree_at(
        lambda m: [getattr(m, nm) for nm in spec.names],
        template,
        list(fields),
        is_leaf=lambda x: x is None,
    )


def _pair_spec(model: tuple, batched: bool) -> tuple[_Spec, dict[str, np.ndarray]]:
    if len(model) not in (2, 3):
        raise BadTypeError(
            "model must be a Family instance or a pair (fn, params) (optionally with a "
            f"third item, constraints), got a tuple of length {len(model)}"
        )
    fn, params = model[0], model[1]
    constraints = dict(model[2]) if len(model) == 3 else {}
    if not callable(fn):
        raise BadTypeError(f"model's first item must be a function fn(d, params), got {fn!r}")
    if not isinstance(params, Mapping) or not params:
        raise BadTypeError(
            f"model's second item must be a non-empty dict of parameter start values, got {params!r}"
        )
    names = tuple(params)
    for n in names:
        if not isinstance(n, str):
            raise BadTypeError(f"parameter names must be strings, got {n!r}")
    for n, kind in constraints.items():
        if n not in names:
            raise UnknownNameError(
                f"constraint given for {n!r}, which is not in params {list(names)}"
            )
        if kind not in _CONSTRAINT_WORDS:
            raise BadValueError(
                f"constraint {kind!r} of {n!r} is not one of {list(_CONSTRAINT_WORDS)}"
            )
    values = {}
    for n in names:
        try:
            v = np.asarray(params[n])
        except Exception as exc:
            raise BadTypeError(f"parameter {n!r} must be a number, got {params[n]!r}") from exc
        if not (np.issubdtype(v.dtype, np.floating) or np.issubdtype(v.dtype, np.integer)):
            raise BadTypeError(f"parameter {n!r} must be a real number, got {params[n]!r}")
        values[n] = v
    shapes = ()  # set by _prepare, which knows the batch size

    def evaluate(d, p):
        return fn(d, p)

    spec = _Spec(
        key=(fn, tuple(sorted(constraints.items()))),
        evaluate=evaluate,
        names=names,
        kinds=tuple(constraints.get(n, "real") for n in names),
        shapes=shapes,
        family=None,
        length_params=(),
    )
    return spec, values


def _spec_of(model: Any, batched: bool) -> tuple[_Spec, dict[str, np.ndarray]]:
    if isinstance(model, Family):
        return _family_spec(model, batched)
    if isinstance(model, type) and issubclass(model, Family):
        raise BadTypeError(
            f"model must be a Family instance, got the class {model.__name__}; call it: {model.__name__}()"
        )
    if isinstance(model, tuple):
        return _pair_spec(model, batched)
    raise BadTypeError(
        f"model must be a Family instance or a pair (fn, params), got {type(model).__name__}"
    )


# ----------------------------------------------------------------------------- validation
def _float_array(name: str, x: Any) -> np.ndarray:
    try:
        arr = np.asarray(x)
    except Exception as exc:
        raise BadTypeError(f"{name} must be an array of floats, got {type(x).__name__}") from exc
    if arr.dtype.kind in "iu":  # whole metres, counts: exact in JAX's float
        arr = arr.astype(jax.dtypes.canonicalize_dtype(np.float64))
    if arr.dtype.kind != "f":
        raise BadTypeError(f"{name} must be a floating-point array, got dtype {arr.dtype}")
    return arr


def _validate_data(
    d: Any, target: Any, weights: Any, loss: str, ndim: int
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    d = _float_array("d", d)
    target = _float_array("target", target)
    what = "(n,)" if ndim == 1 else "(batch, n)"
    if target.ndim != ndim:
        raise BadValueError(f"target must have shape {what}, got shape {target.shape}")
    if target.size == 0:
        raise BadValueError(f"target is empty (shape {target.shape}); nothing to fit")
    if d.shape != target.shape and not (ndim == 2 and d.shape == target.shape[1:]):
        raise BadValueError(
            f"d has shape {d.shape} but target has shape {target.shape}; they must match"
        )
    # the common case in two reductions per array (NaN fails every comparison); the
    # messages below find the offending value
    if not (d.min() >= 0 and d.max() < math.inf):
        bad = d[~(np.isfinite(d) & (d >= 0))].flat[0].item()
        raise BadValueError(f"d must be finite distances >= 0, got {bad!r}")
    t_lo, t_hi = target.min(), target.max()
    if not (-math.inf < t_lo and t_hi < math.inf):
        raise BadValueError(
            f"target must be finite, got {target[~np.isfinite(target)].flat[0].item()!r}"
        )
    if loss == "absolute":
        if t_lo < 0:
            raise BadValueError(f"target must be >= 0, got {target[target < 0].flat[0].item()!r}")
    elif t_lo <= 0:
        raise BadValueError(
            f"target must be > 0 for the {loss!r} loss, got {target[target <= 0].flat[0].item()!r} "
            "(use loss='absolute' for zero targets)"
        )
    if weights is not None:
        weights = _float_array("weights", weights)
        if weights.shape != target.shape and not (ndim == 2 and weights.shape == target.shape[1:]):
            raise BadValueError(
                f"weights has shape {weights.shape} but target has shape {target.shape}; they must match"
            )
        if not (weights.min() >= 0 and weights.max() < math.inf):
            bad = weights[~(np.isfinite(weights) & (weights >= 0))].flat[0].item()
            raise BadValueError(f"weights must be finite and >= 0, got {bad!r}")
        if not np.all(np.any(weights > 0, axis=-1)):
            raise BadValueError("weights are all 0 (in at least one problem); nothing to fit")
    return d, target, weights


def _validate_options(
    spec: _Spec,
    values: Mapping[str, np.ndarray],
    free: Any,
    loss: str,
    solver: Any,
    max_steps: Any,
    n: int,
    batch: int | None,
) -> tuple[str, ...]:
    if isinstance(free, str):
        free = (free,)
    free = tuple(free)
    args = (spec, free, loss, solver, type(max_steps), max_steps, n)
    try:
        hash(args)
    except TypeError:  # an unhashable argument (a solver instance, say): checked every time
        free = _checked_options.__wrapped__(*args)
    else:  # the same options again (a fit in a loop): checked once
        free = _checked_options(*args)
    for name, kind in zip(spec.names, spec.kinds, strict=True):
        v = values[name]
        lo, hi = (float(v), float(v)) if v.ndim == 0 else (float(v.min()), float(v.max()))
        if not (math.isfinite(lo) and math.isfinite(hi)):
            raise BadValueError(f"start value of {name!r} is not finite: {v!r}")
        if not (kind == "real" or (lo >= 0 and (kind != "unit" or hi <= 1))):
            ok = (v >= 0) & (v <= 1) if kind == "unit" else v >= 0
            raise BadValueError(
                f"start value of {name!r} must be {_CONSTRAINT_WORDS[kind]}, got {v[~ok].flat[0].item()!r}"
            )
    return free


@functools.lru_cache(maxsize=256)
def _checked_options(spec, free, loss, solver, max_steps_type, max_steps, n) -> tuple[str, ...]:
    """`free`, once `free`, `loss`, `solver` and `max_steps` are checked (see `fit`)."""
    if not isinstance(loss, str) or loss not in LOSSES:
        raise UnknownNameError(f"unknown loss {loss!r}; known losses: {', '.join(LOSSES)}")
    if isinstance(solver, str):
        if solver not in SOLVERS:
            raise UnknownNameError(
                f"unknown solver {solver!r}; known solvers: {', '.join(SOLVERS)}"
            )
    elif not isinstance(solver, (optx.AbstractLeastSquaresSolver, optx.AbstractMinimiser)):
        raise BadTypeError(
            f"solver must be one of {list(SOLVERS)} or an optimistix least-squares solver or "
            f"minimiser, got {solver!r}"
        )
    if isinstance(max_steps, bool) or not isinstance(max_steps, (int, np.integer)) or max_steps < 1:
        raise BadValueError(f"max_steps must be a positive integer, got {max_steps!r}")
    if not free:
        raise BadValueError("free is empty: name at least one parameter to fit")
    for name in free:
        if name not in spec.names:
            raise UnknownNameError(
                f"free names {name!r}, which the model does not have; its parameters are {list(spec.names)}"
            )
    if len(set(free)) != len(free):
        raise BadValueError(f"free names a parameter twice: {list(free)}")
    k = _free_size(spec, free)
    if n < k:
        raise BadValueError(f"{n} samples cannot determine {k} free parameter values")
    return free


def _dtype_of(*arrays: np.ndarray) -> np.dtype:
    """The JAX float dtype a fit runs in: the widest input float, as JAX will hold it."""
    return np.dtype(jax.dtypes.canonicalize_dtype(np.result_type(*arrays)))


@functools.cache
def _default_tolerance(dtype: np.dtype) -> float:
    """1e-8 in float64, 1e-5 in float32 (100 eps where that is larger)."""
    eps = float(np.finfo(dtype).eps)
    return 1e-8 if eps < 1e-10 else max(1e-5, 100 * eps)


def _default_tolerances(dtype: np.dtype, rtol: float | None, atol: float | None):
    default = _default_tolerance(dtype)
    for name, tol in (("rtol", rtol), ("atol", atol)):
        if tol is not None and not (
            isinstance(tol, int | float | np.floating | np.integer) and 0 <= tol < math.inf
        ):
            raise BadValueError(f"{name} must be a finite number >= 0 (or None), got {tol!r}")
    return (default if rtol is None else float(rtol)), (default if atol is None else float(atol))


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


def _flat_kinds(spec: _Spec, free: tuple[str, ...]) -> tuple[str, ...]:
    """The constraint of each fitted value, free parameters flattened in order."""
    kinds = dict(zip(spec.names, spec.kinds, strict=True))
    return tuple(kinds[p] for p in _free_values(spec, free))


#: Up to this many free nonnegative parameters are tried at 0 in the fit's final pass over
#: the samples (every way of zeroing some of them: 2^m points); more take a pass each.
_SUBSETS_MAX = 3

#: A nonnegative parameter is tried at 0 when the solver's linear model of the residuals
#: puts the loss there within this many times the tolerance of the fitted loss (`finish`).
#: The model is the solver's own (exact for a linear parameter); this margin covers its
#: error over the move to 0, so the test is skipped (a pass over the samples per way of
#: zeroing) only where 0 is far out of reach.
_SNAP_MARGIN = 1e6


def _build_problem(spec: _Spec, free, loss, solver_obj, max_steps, guess, rtol, atol, batched):
    """The solve: arrays in, arrays out, for one problem or (`batched`) a batch of them.

    Its passes over the samples, each one fused loop (`attenfit._solvers.sums`): the linear
    start (inverse-linear families), the candidates' losses, one per solver step, and a
    final one for the metrics, which also tries nonnegative parameters at 0 when any
    problem of the batch may have its optimum there.
    """
    of_values = _residual_of_values(loss)
    shapes = dict(zip(spec.names, spec.shapes, strict=True))
    where = _free_slices(spec, free)  # each free parameter's place in the fitted vector
    kinds = dict(zip(spec.names, spec.kinds, strict=True))
    free_lengths = tuple(p for p in spec.length_params if p in free and kinds[p] == "positive")
    flat_kinds = _flat_kinds(spec, free)
    linear_coord = np.array([k in ("nonnegative", "real") for k in flat_kinds])
    nonneg = [j for j, kind in enumerate(flat_kinds) if kind == "nonnegative"]
    is_lm = isinstance(solver_obj, LevenbergMarquardt)

    def split(vec, values):
        out = dict(values)
        for p in free:
            out[p] = vec[where[p]].reshape(shapes[p])
        return out

    def to_u(blocks):
        """The coordinates of parameter sets, one row each. `blocks`: dicts of the free
        parameters' values with a leading axis of rows; each parameter's rows are stacked
        first, so that each map is one operation on all of them."""
        cols = [
            jnp.concatenate([jnp.reshape(b[p], (b[p].shape[0], -1)) for b in blocks]) for p in free
        ]
        return jnp.concatenate(
            [to_internal(kinds[p], x) for p, x in zip(free, cols, strict=True)], axis=1
        )

    def from_u(u, values):
        out = dict(values)
        for p in free:
            out[p] = to_param(kinds[p], u[where[p]].reshape(shapes[p]))
        return out

    def inverse(target):
        pos = target > 0
        return jnp.where(pos, 1 / jnp.where(pos, target, 1), 0)

    class Passes:
        """Residuals and losses of one problem: `values` (the fixed ones), d, target, ..."""

        def __init__(self, values, d, target, weights, inv_target):
            self.values, self.d, self.target, self.inv_target = values, d, target, inv_target
            self.residual = of_values(target, weights, inv_target)
            self.plain_relative = loss == "relative" and weights is None

        def model_at(self, u):
            return spec.evaluate(self.d, from_u(u, self.values)).astype(self.d.dtype)

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

    def threshold(best, n):
        """0 fits as well within the tolerances: the loss rises by at most rtol relative
        plus an RMS residual change of atol."""
        return best * (1 + rtol) + 0.5 * n * atol**2

    def solve(values, d, target, weights, inv_target):
        dtype, n = d.dtype, d.shape[-1]
        ps = Passes(values, d, target, weights, inv_target)
        # the candidates, as blocks of rows (see `to_u`)
        cands = [{p: values[p][None] for p in free}]
        if guess:
            scaled = scale_candidates(values, free, free_lengths)
            if scaled:
                cands.append(scaled)
            lin = linear_candidate(
                spec.family or "",
                values,
                free,
                kinds,
                d,
                target,
                inv_target,
                weights,
                loss,
                batched,
            )
            if lin is not None:
                cands.append({p: lin[p][None] for p in free})
        us = to_u(cands)
        costs = ps.losses(us)
        best_cand = jnp.argmin(costs)
        u0, start_loss = us[best_cand], costs[best_cand]
        # The solver moves z = u / scale: nonnegative and real coordinates are scaled by
        # their start's magnitude, so a problem and its rescaled copy (another radius) take
        # the same steps; exp and sigmoid coordinates are scale-free already.
        scale = jnp.where(linear_coord & (jnp.abs(u0) > 0), jnp.abs(u0), 1).astype(dtype)
        scale = jax.lax.stop_gradient(scale)

        def res_z(z, _):
            return ps.res_u(z * scale)

        # the loss of residuals at rounding level: an exact fit, where relative tests and
        # the gradient's direction are noise
        w_max = 1 if weights is None else jnp.max(weights)
        exact_loss = 0.5 * n * (64 * jnp.finfo(dtype).eps * w_max) ** 2
        options = {"exact_loss": exact_loss} if is_lm else {}
        sol = optx.least_squares(
            res_z, solver_obj, u0 / scale, None, options, max_steps=max_steps, throw=False
        )
        mid = dict(
            z=sol.value,
            scale=scale,
            result=sol.result._value,
            steps=sol.stats["num_steps"],
            start_loss=start_loss,
            exact_loss=exact_loss,
        )
        if is_lm:
            # attenfit's LM ends with the loss and normal equations of the last point it
            # evaluated (`z_eval`; its end point `z` may be one Gauss-Newton step beyond)
            z, jtj, jtr = sol.state.evaluated, sol.state.jtj, sol.state.jtr
            mid.update(z_eval=z, jtj_z=jtj, jtr_z=jtr)
            # the linear model's loss with one nonnegative coordinate moved to 0
            near = [
                -z[j] * jtr[j] + 0.5 * z[j] ** 2 * jtj[j, j]
                <= _SNAP_MARGIN * (threshold(sol.state.loss, n) - sol.state.loss)
                for j in nonneg
            ]
            mid["try_zero"] = jnp.any(jnp.stack(near)) if near else jnp.zeros((), bool)
        else:
            mid["try_zero"] = jnp.asarray(bool(nonneg))
        return mid

    def finish(mid, values, d, target, weights, inv_target, try_zero: bool):
        dtype, n = d.dtype, d.shape[-1]
        ps = Passes(values, d, target, weights, inv_target)
        scale = mid["scale"]
        # The end point, or (attenfit's LM, which does not evaluate its final step) the
        # last point it evaluated, where that is better.
        zs = jnp.stack([mid["z"], mid["z_eval"]] if is_lm else [mid["z"]])
        ends = zs * scale[None]
        if try_zero and nonneg:
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

        if not (try_zero and nonneg):
            u, z_end, best, sq_err, max_err = pick(ends, zs, cost, sq_err, max_err)
        else:
            u, z_end, best = pick(ends, zs, cost)
            if len(nonneg) <= _SUBSETS_MAX:
                # Each nonnegative parameter in turn is set to 0 where that fits as well
                # (`threshold`, against the loss reached so far). Every way of zeroing them is
                # evaluated in the one pass: bit b of a mask zeroes nonneg[b].
                zeroed = np.zeros((2 ** len(nonneg), len(flat_kinds)), bool)
                for mask in range(2 ** len(nonneg)):
                    for b, j in enumerate(nonneg):
                        zeroed[mask, j] = mask >> b & 1
                points = jnp.where(zeroed, 0, u[None])  # one row per way of zeroing
                cost, sq_err, max_err = ps.losses_and_errors(points)
                mask, best = jnp.zeros((), np.int32), cost[0]
                for b in range(len(nonneg)):
                    c0 = cost[mask | (1 << b)]
                    ok = c0 <= threshold(best, n)
                    best = jnp.where(ok, jnp.minimum(c0, best), best)
                    mask = jnp.where(ok, mask | (1 << b), mask)
                u = jnp.where(jnp.asarray(zeroed)[mask], 0, u)
                sq_err, max_err = sq_err[mask], max_err[mask]
            else:
                for j in nonneg:
                    c0 = ps.losses(u.at[j].set(0)[None])[0]
                    ok = c0 <= threshold(best, n)
                    best = jnp.where(ok, jnp.minimum(c0, best), best)
                    u = u.at[j].set(jnp.where(ok, 0, u[j]))
                _, sq_err, max_err = (x[0] for x in ps.losses_and_errors(u[None]))
        at_bound = by_kind(_on_bound, flat_kinds, u)
        pvec = by_kind(to_param, flat_kinds, u)
        if is_lm:
            # the solver's J^T J and J^T r at its last point (a parameter snapped to its
            # bound above moved within the tolerances), taken to the parameters: J with
            # respect to them is J_z diag(dz/dp), z = u / scale
            slope = scale * by_kind(param_slope, flat_kinds, u)
            # (at the end point beyond `z_eval`, J^T r by the solver's linear model)
            jtr_z = mid["jtr_z"] + mid["jtj_z"] @ (z_end - mid["z_eval"])
            jtj = mid["jtj_z"] / (slope[:, None] * slope[None, :])
            jtr = jtr_z / slope
        else:
            # model values, residuals and their Jacobian rows in one forward-mode pass
            def model_values(pv):
                return spec.evaluate(d, split(pv, values)).astype(dtype), None

            f, _, f_rows = jacobian_rows(model_values, pvec, batched=batched)
            r_fin, dr_df = jax.jvp(ps.residual, (f,), (jnp.ones_like(f),))
            jtj, jtr = gram([dr_df * row.astype(dtype) for row in f_rows], r_fin, batched)
        # First-order optimality (MINPACK's gtol test, as scipy's least_squares): the
        # cosine between the residual vector and each Jacobian column, ignoring parameters
        # on their bound. optimistix's BFGS, for one, never stops at an exact optimum.
        rnorm = jnp.sqrt(2 * best)
        cos = jnp.where(at_bound, 0, gradient_cosines(jtj, jtr, rnorm))
        grad_ok = jnp.all(jnp.isfinite(cos)) & (jnp.max(cos, initial=0) <= rtol)
        # ...or residuals at rounding level (an exact fit: the cosine is then noise)
        grad_ok = grad_ok | (best <= mid["exact_loss"])
        npos = n if loss != "absolute" else jnp.maximum(sums((target > 0).astype(dtype))[0], 1)
        out = dict(
            pvec=pvec,
            loss=best,
            jtj=jtj,
            max_rel=max_err,
            rms_rel=jnp.sqrt(sq_err / npos),
            at_bound=at_bound,
            grad_ok=grad_ok,
        )
        return _pack(out, _finish_layout(len(flat_kinds)), dtype)

    def solve_outputs(mid):
        """The outputs read off the solve alone, packed apart from `finish`'s (so that its
        branches, below, do not each start with them: see `_read_in_order`)."""
        out = dict(
            result=mid["result"],
            steps=mid["steps"],
            start_finite=jnp.isfinite(mid["start_loss"]),
            start_loss=mid["start_loss"],
        )
        return _pack(out, _SOLVE_LAYOUT, mid["start_loss"].dtype)

    each = jax.vmap if batched else (lambda fn: fn)

    def run(values, d, target, weights=None):
        """The packed outputs of `finish` (`_pack`), for one problem or (`batched`) with a
        leading batch axis.

        The final pass tries nonnegative parameters at 0 only when some problem may have
        its optimum there (a branch on the whole batch: under `vmap` a per-problem `cond`
        would evaluate both sides for every problem).
        """
        inv_target = each(inverse)(target)
        mid = each(solve)(values, d, target, weights, inv_target)

        def fin(try_zero):
            return lambda: each(functools.partial(finish, try_zero=try_zero))(
                mid, values, d, target, weights, inv_target
            )

        if not nonneg:
            packed = fin(False)()
        else:
            packed = jax.lax.cond(jnp.any(mid["try_zero"]), fin(True), fin(False))
        return jnp.concatenate([packed, each(solve_outputs)(mid)], axis=-1)

    return run


def _finish_layout(k: int) -> list[tuple[str, tuple[int, ...]]]:
    """Name and per-problem shape of each output `finish` packs, `k` free values."""
    return [
        ("pvec", (k,)),
        ("jtj", (k, k)),
        ("at_bound", (k,)),
        ("loss", ()),
        ("max_rel", ()),
        ("rms_rel", ()),
        ("grad_ok", ()),
    ]


#: ...and of those packed from the solve alone, after them.
_SOLVE_LAYOUT = [("result", ()), ("steps", ()), ("start_finite", ()), ("start_loss", ())]


def _layout(k: int) -> list[tuple[str, tuple[int, ...]]]:
    """Name and per-problem shape of every packed output, in order."""
    return _finish_layout(k) + _SOLVE_LAYOUT


def _pack(out: dict[str, Array], layout: list[tuple[str, tuple[int, ...]]], dtype) -> Array:
    """Outputs of one problem as one vector of the fit's float `dtype` (one transfer)."""
    return jnp.concatenate([jnp.ravel(out[name]).astype(dtype) for name, _ in layout])


class _OnHost:
    """A jitted packed solve, returning its outputs as one numpy array (`_layout` along
    the last axis, after any batch axis).

    A float32 solve is traced and run with JAX's x64 mode off, as JAX runs float32 by
    default, whatever the caller's mode: with it on, optimistix's dogleg mixes float64 into
    a float32 solve and fails to trace (its `newton_norm` and `cauchy_norm` state).
    """

    def __init__(self, fn: Callable, dtype: np.dtype):
        self.fn, self.x64 = fn, np.dtype(dtype).itemsize == 8

    def __call__(self, *args) -> np.ndarray:
        if self.x64:
            out = self.fn(*args)
        else:
            with jax.enable_x64(False):
                out = self.fn(*args)
        # + 0.0 turns -0.0 into 0.0: the solve's fast math (`_COMPILER_OPTIONS`) may drop
        # the sign of a zero, so a parameter on its bound could come back as -0.0
        return np.asarray(out) + 0.0


@functools.cache
def _slices(k: int) -> dict[str, slice]:
    """Where each output of `_layout(k)` lies along the packed axis."""
    out, i = {}, 0
    for name, shape in _layout(k):
        out[name] = slice(i, i + math.prod(shape))
        i += math.prod(shape)
    return out


def _columns(flat: np.ndarray, k: int) -> dict[str, np.ndarray]:
    """The packed outputs of a batch, by name, each with the batch axis first."""
    out = {}
    for name, shape in _layout(k):
        piece = flat[:, _slices(k)[name]].reshape((len(flat), *shape))
        if name in ("result", "steps"):
            piece = piece.astype(np.int64)
        elif name in ("start_finite", "at_bound", "grad_ok"):
            piece = piece.astype(bool)
        out[name] = piece
    return out


#: Problems per vmapped chunk in `fit_many`: chunks run one after another (`lax.map`), and
#: each stops when its own slowest problem does, so one straggler holds up its chunk only.
#: Every operation of a step has a fixed cost per chunk, so small chunks pay it many times:
#: 1,000 polynomial fits (4 steps each), median wall time: 26.5 ms in chunks of 64, 24.2 ms
#: of 128, 24.1 ms of 256, 25.9 ms of 512 (two chunks), 19.6 ms in one. (With optimistix's
#: own Gauss-Newton state, 64 was best: its steps cost four times more per problem.)
_CHUNK = 1024


def _chunked(vfn: Callable, chunk: int) -> Callable:
    """`vfn` (vmapped over axis 0) applied chunk by chunk with `lax.map`; pads the batch."""

    def run(*args):
        batch = jax.tree_util.tree_leaves(args)[0].shape[0]
        if batch <= chunk:
            return vfn(*args)
        n_chunks = -(-batch // chunk)
        pad = n_chunks * chunk - batch

        def split(x):
            x = jnp.concatenate([x, jnp.repeat(x[:1], pad, axis=0)]) if pad else x
            return x.reshape((n_chunks, chunk, *x.shape[1:]))

        out = jax.lax.map(lambda a: vfn(*a), jax.tree_util.tree_map(split, args))
        return out.reshape((n_chunks * chunk, *out.shape[2:]))[:batch]

    return run


_COMPILED: dict[Any, Callable] = {}

#: XLA options of every compiled solve: the CPU backend's fast math less what XLA keeps
#: exact by default (NaN and infinity semantics, division, math functions), which leaves
#: reassociation, contraction into FMAs, and ignoring the sign of zero (outputs are made
#: +0.0 in `_OnHost`). Reassociation lets LLVM vectorise the sums over the samples (a
#: strict reduction is a chain of scalar adds): the compiled solve of 1,000 polynomial
#: fits of 256 samples took 4.4-5.0 ms instead of 8.4-10.3. Results move within the
#: tolerances: the 19 parameterised families fitted to their own curves over d from 1e-3
#: to 1e3 and 1e12 times a scale of 1e-6, 1 or 1e6, float32 and float64 (227 fits),
#: converge as with a strict compilation, parameters within 2e-6 relative of its
#: (`tests/test_fit.py::test_compiled_solve_options_keep_the_answer`). An exact fit's
#: residuals are rounding noise rather than exact zeros (f / t - 1 is one FMA), which the
#: solver's rounding-level loss (`exact_loss`) ends at once.
_COMPILER_OPTIONS = {"xla_cpu_enable_fast_math": True}


def _read_in_order(flat: Array) -> Array:
    """`flat` as every kernel of a single fit reads it: after one reduction over it.

    XLA's CPU runtime runs a compiled computation as a graph of small kernels, and hands
    half of the ready ones to another thread whenever more than eight are ready at once.
    A single fit is a few hundred kernels of microseconds each, so such a hand-off costs
    more than the work it shares: one per call, at the start, where some fifteen kernels
    read the inputs independently (slices, reciprocals, the candidates' setup), cost the
    benchmark's polynomial fit 0.13 ms of its 0.19 ms compiled solve (measured with the
    solve run inline, `jax_cpu_enable_async_dispatch=False`; 0.23 -> 0.19 ms dispatched as
    by default). Reading the inputs through one reduction makes every reader wait for it,
    so they become ready a few at a time. The same concern keeps the solve's other
    independent pieces few and wide: the candidates are evaluated as one batch, the end
    point's outputs picked in one selection, the constraints mapped as one vector.

    The inputs are validated finite, so the selection never changes them (a non-finite
    one would make every input NaN).
    """
    return jnp.where(jnp.max(jnp.abs(flat)) < jnp.inf, flat, jnp.nan)


def _unflatten_inputs(
    spec: _Spec, flat: Array, weighted: bool
) -> tuple[dict[str, Array], Array, Array, Array]:
    """Start values, d, target and weights from `fit`'s one input vector (their concatenation;
    without weights when not `weighted`: None, all 1)."""
    values, off = {}, 0
    for name, shape in zip(spec.names, spec.shapes, strict=True):
        size = math.prod(shape)
        values[name] = flat[off : off + size].reshape(shape)
        off += size
    n = (flat.shape[0] - off) // (3 if weighted else 2)
    d, target = flat[off : off + n], flat[off + n : off + 2 * n]
    return values, d, target, flat[off + 2 * n :] if weighted else None


def _compiled(spec, free, loss, solver, max_steps, rtol, atol, guess, batched, dtype, weighted):
    """The jitted solve for this configuration, from the cache (jit re-specialises on shapes).

    Called as `fn(flat)` for one problem (`_unflatten_inputs`), and as `fn(values, d,
    target, weights)` (or without `weights` when not `weighted`) for a batch.
    """
    key = (
        dtype,
        weighted,
        spec.key,
        spec.names,
        spec.shapes,
        free,
        loss,
        solver,
        max_steps,
        rtol,
        atol,
        guess,
        batched,
    )
    fn = _COMPILED.get(key)
    if fn is None:
        reflected = tuple(kind == "nonnegative" for kind in _flat_kinds(spec, free))
        solver_obj = (
            make_solver(solver, rtol, atol, float(np.finfo(dtype).eps), batched, reflected)
            if isinstance(solver, str)
            else solver
        )
        run = _build_problem(spec, free, loss, solver_obj, max_steps, guess, rtol, atol, batched)
        if batched:
            fn = jax.jit(_chunked(run, _CHUNK), compiler_options=_COMPILER_OPTIONS)
        else:
            fn = jax.jit(
                lambda flat: run(*_unflatten_inputs(spec, _read_in_order(flat), weighted)),
                compiler_options=_COMPILER_OPTIONS,
            )
        fn = _OnHost(fn, dtype)
        _COMPILED[key] = fn
    return fn


# ----------------------------------------------------------------------------- results
_MESSAGES = tuple(optx.RESULTS._index_to_message)
_RESULT_NAMES = {item._value.item(): name for name, item in optx.RESULTS._name_to_item.items()}


_MAX_STEPS = optx.RESULTS.nonlinear_max_steps_reached._value.item()


def _converged(code, start_finite, loss, grad_ok):
    """Converged: optimistix succeeded, or stopped at max steps on a first-order optimum."""
    code = np.asarray(code)
    ok = (code == 0) | ((code == _MAX_STEPS) & np.asarray(grad_ok))
    return ok & np.asarray(start_finite) & np.isfinite(loss)


def _message(
    code: int, start_finite: bool, loss: float, at_bound: Sequence[str], grad_ok: bool
) -> tuple[bool, str]:
    notes = []
    if at_bound:
        notes.append(f"on its bound: {', '.join(at_bound)}")
    if not start_finite:
        msg = "the residuals are not finite (NaN or inf) at the starting parameters"
        if code:
            msg += f"; optimistix: {_MESSAGES[code].splitlines()[0]}"
        return False, msg
    if not math.isfinite(loss):
        return False, "the loss at the solution is not finite"
    if code == _MAX_STEPS and grad_ok:
        note = "converged (first-order optimal: residuals orthogonal to the Jacobian within rtol, or at rounding level; optimistix reached max_steps)"
        return True, "; ".join([note, *notes])
    if code:
        return False, "; ".join([f"optimistix: {' '.join(_MESSAGES[code].split())}", *notes])
    return True, "; ".join(["converged", *notes])


def _covariance(jtj: np.ndarray, loss: float, n: int, k: int) -> np.ndarray:
    """`pinv(J^T J) * sum(r^2) / (n - k)`, as `scipy.optimize.curve_fit` (inf if n == k)."""
    jtj = np.asarray(jtj, dtype=np.float64)
    if not np.all(np.isfinite(jtj)):
        return np.full((k, k), np.inf)
    w, v = np.linalg.eigh(jtj)
    smax = math.sqrt(max(w.max(initial=0.0), 0.0))
    keep = np.sqrt(np.clip(w, 0, None)) > np.finfo(np.float64).eps * max(n, k) * smax
    if smax == 0 or not keep.any():
        return np.full((k, k), np.inf)
    inv = (v[:, keep] / w[keep]) @ v[:, keep].T
    if n <= k:
        return np.full((k, k), np.inf)
    return inv * (2 * loss / (n - k))


@dataclasses.dataclass(frozen=True)
class FitResult:
    """The outcome of one fit: fitted model and parameters, whether and how it converged.

    Attributes:
        model: the fitted model: a family instance with the fitted values, or for a
            `(fn, params)` model the pair `(fn, fitted params)`.
        params: every parameter (fitted and fixed) as Python floats (lists for arrays).
        converged: whether optimistix reported success with finite residuals.
        message: "converged", or why not (optimistix's message); notes parameters on bound.
        steps: solver steps taken.
        loss: `0.5 * sum(residual^2)` at the solution.
        metrics: `max_rel_error`, `rms_rel_error` (unweighted |f - t| / t over the fitted
            samples with t > 0), `start_loss`, `n` (samples), `k` (free values).
        covariance: `(k, k)` covariance of the free parameters, in `free` order (curve_fit's),
            computed on first use from `normal_matrix`.
        free: the fitted parameter names. at_bound: those that ended on a bound.
        objective: the loss kind; solver: its name; dtype: the float dtype of the fit.
        normal_matrix: `J^T J`, J the Jacobian of the residuals with respect to the free
            parameters at the solution.
    """

    model: Any
    params: dict[str, Any]
    converged: bool
    message: str
    steps: int
    loss: float
    metrics: dict[str, float]
    free: tuple[str, ...]
    at_bound: tuple[str, ...] = ()
    objective: str = "relative"
    solver: str = "levenberg_marquardt"
    dtype: str = "float64"
    normal_matrix: np.ndarray = dataclasses.field(default=None, repr=False)  # type: ignore[assignment]

    @functools.cached_property
    def covariance(self) -> np.ndarray:
        """`(k, k)` covariance of the free parameters (`scipy.optimize.curve_fit`'s)."""
        k = len(self.normal_matrix)
        return _covariance(self.normal_matrix, self.loss, int(self.metrics["n"]), k)

    @property
    def stderr(self) -> dict[str, float]:
        """Standard errors of the free (scalar) parameters: sqrt of the covariance diagonal."""
        diag = np.sqrt(np.abs(np.diag(self.covariance)))
        out, i = {}, 0
        for p in self.free:
            size = np.size(self.params[p])
            out[p] = float(diag[i]) if size == 1 else diag[i : i + size].tolist()
            i += size
        return out

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no model object; `family` names the family, if any)."""

        def plain(x):
            x = float(x)
            return x if math.isfinite(x) else str(x)

        def plain_tree(v):  # strict JSON: NaN/inf parameters and errors become strings
            return [plain_tree(x) for x in v] if isinstance(v, list | tuple) else plain(v)

        name = getattr(self.model, "name", None) if isinstance(self.model, Family) else None
        return {
            "family": name,
            "params": {k: plain_tree(v) for k, v in self.params.items()},
            "free": list(self.free),
            "stderr": {k: plain_tree(v) for k, v in self.stderr.items()},
            "converged": self.converged,
            "message": self.message,
            "steps": self.steps,
            "loss": plain(self.loss),
            "objective": self.objective,
            "solver": self.solver,
            "dtype": self.dtype,
            "at_bound": list(self.at_bound),
            "metrics": {k: plain(v) for k, v in self.metrics.items()},
            "covariance": [[plain(x) for x in row] for row in np.asarray(self.covariance)],
        }

    def __str__(self) -> str:
        name = (
            getattr(self.model, "name", "custom model")
            if isinstance(self.model, Family)
            else "custom model (fn, params)"
        )
        m = self.metrics
        lines = [
            f"[[Fit]] {name}",
            f"    solver     = {self.solver}, loss = {self.objective}, dtype = {self.dtype}",
            f"    converged  = {self.converged} ({self.message.splitlines()[0]})",
            f"    steps      = {self.steps}",
            f"    samples    = {int(m.get('n', 0))}, free values = {int(m.get('k', 0))}",
            f"    loss       = {self.loss:.6g}  (0.5 * sum of squared residuals)",
            f"    rel. error = max {m.get('max_rel_error', math.nan):.3g}, rms {m.get('rms_rel_error', math.nan):.3g}",
            "[[Parameters]]",
        ]
        se = self.stderr
        for p, v in self.params.items():
            if p in self.free and np.size(v) == 1:
                s = se[p]
                rel = f" ({100 * s / abs(v):.2f}%)" if v != 0 and math.isfinite(s) else ""
                bound = "  (on bound)" if p in self.at_bound else ""
                lines.append(f"    {p:<10} = {v:.8g} +/- {s:.3g}{rel}{bound}")
            elif p in self.free:
                lines.append(f"    {p:<10} = {v}")
            else:
                lines.append(f"    {p:<10} = {v if np.size(v) > 1 else format(v, '.8g')}  (fixed)")
        k = len(self.covariance)
        if k > 1 and all(np.size(self.params[p]) == 1 for p in self.free):
            cov = np.asarray(self.covariance)
            sd = np.sqrt(np.abs(np.diag(cov)))
            pairs = []
            for i in range(k):
                for j in range(i + 1, k):
                    if sd[i] > 0 and sd[j] > 0 and np.isfinite(sd[i] * sd[j]):
                        pairs.append(
                            (abs(cov[i, j] / (sd[i] * sd[j])), cov[i, j] / (sd[i] * sd[j]), i, j)
                        )
            shown = [p for p in sorted(pairs, reverse=True) if p[0] > 0.1]
            if shown:
                lines.append("[[Correlations]] (|corr| > 0.1)")
                for _, c, i, j in shown:
                    lines.append(f"    C({self.free[i]}, {self.free[j]}) = {c:+.4f}")
        return "\n".join(lines)


def _field_value(v: np.ndarray, dtype) -> Any:
    """A fitted family field: a Python float for a scalar, else an array of the fit's dtype."""
    return v if isinstance(v, float) else float(v) if np.ndim(v) == 0 else jnp.asarray(v, dtype)


def _python_value(v: np.ndarray) -> Any:
    return float(v) if v.ndim == 0 else v.tolist()


@functools.cache
def _dtype_name(dtype: np.dtype) -> str:
    return np.dtype(dtype).name


@functools.lru_cache(maxsize=256)
def _free_values(spec: _Spec, free: tuple[str, ...]) -> tuple[str, ...]:
    """The name of each fitted value, in `free` order (an array parameter once per element)."""
    shapes = dict(zip(spec.names, spec.shapes, strict=True))
    return tuple(p for p in free for _ in range(math.prod(shapes[p])))


def _free_size(spec: _Spec, free: tuple[str, ...]) -> int:
    """The number of fitted values: the free parameters' sizes summed."""
    return len(_free_values(spec, free))


@functools.lru_cache(maxsize=256)
def _free_slices(spec: _Spec, free: tuple[str, ...]) -> dict[str, slice]:
    """Where each free parameter's values lie in the fitted vector (`free` order)."""
    shapes = dict(zip(spec.names, spec.shapes, strict=True))
    out, i = {}, 0
    for p in free:
        out[p] = slice(i, i + math.prod(shapes[p]))
        i = out[p].stop
    return out


def _make_result(
    spec, template, values, free, row, i, n, loss_kind, solver_name, dtype
) -> FitResult:
    """One FitResult from one problem's packed outputs `row` (`_layout`); `i`: the
    problem's index in batched `values`, or None."""
    k = _free_size(spec, free)
    at = _slices(k)
    out = row.tolist()
    pvec = out[at["pvec"]]
    where = _free_slices(spec, free)
    params, fitted = {}, {}
    for nm, shape in zip(spec.names, spec.shapes, strict=True):
        if nm in free:
            if shape == ():
                params[nm] = fitted[nm] = pvec[where[nm].start]
            else:
                fitted[nm] = np.asarray(pvec[where[nm]]).reshape(shape)
                params[nm] = fitted[nm].tolist()
        else:
            v = values[nm]
            v = np.asarray(v[i] if i is not None and np.ndim(v) > len(shape) else v)
            fitted[nm] = v
            params[nm] = _python_value(v)
    bound = zip(_free_values(spec, free), out[at["at_bound"]], strict=True)
    at_bound = tuple(dict.fromkeys(p for p, b in bound if b))
    (code,), (loss,) = out[at["result"]], out[at["loss"]]
    converged, message = _message(
        int(code), bool(out[at["start_finite"]][0]), loss, at_bound, bool(out[at["grad_ok"]][0])
    )
    metrics = {
        "max_rel_error": out[at["max_rel"]][0],
        "rms_rel_error": out[at["rms_rel"]][0],
        "start_loss": out[at["start_loss"]][0],
        "n": n,
        "k": k,
    }
    if isinstance(template, Family):
        model = _rebuild(spec, template, [_field_value(fitted[nm], dtype) for nm in spec.names])
    else:
        model = (template[0], {nm: params[nm] for nm in spec.names})
    return FitResult(
        model=model,
        params=params,
        converged=converged,
        message=message,
        steps=int(out[at["steps"]][0]),
        loss=loss,
        metrics=metrics,
        normal_matrix=np.array(row[at["jtj"]]).reshape(k, k),
        free=free,
        at_bound=at_bound,
        objective=loss_kind,
        solver=solver_name,
        dtype=_dtype_name(dtype),
    )


def _solver_name(solver) -> str:
    return solver if isinstance(solver, str) else type(solver).__name__


_SHAPED_SPECS: dict[Any, _Spec] = {}  # (spec, parameter shapes) -> the spec with those shapes


def _prepare(model, d, target, weights, free, loss, solver, max_steps, rtol, atol, batched):
    ndim = 2 if batched else 1
    d, target, weights = _validate_data(d, target, weights, loss, ndim)
    spec, values = _spec_of(model, batched)
    batch = target.shape[0] if batched else None
    shapes = tuple(
        v.shape[1:] if batched and v.ndim >= 1 and v.shape[0] == batch else v.shape
        for v in (values[nm] for nm in spec.names)
    )
    shaped = _SHAPED_SPECS.get((spec, shapes))
    if shaped is None:
        shaped = _SHAPED_SPECS[spec, shapes] = dataclasses.replace(spec, shapes=shapes)
    spec = shaped
    if batched:
        values = {
            nm: np.broadcast_to(values[nm], (batch, *shape))
            for nm, shape in zip(spec.names, spec.shapes, strict=True)
        }
    if free is None:
        free = (
            tuple(getattr(type(model), "default_free", ()))
            if isinstance(model, Family)
            else spec.names
        )
    n = target.shape[-1]
    free = _validate_options(spec, values, free, loss, solver, max_steps, n, batch)
    dtype = _dtype_of(d, target, *(() if weights is None else (weights,)))
    rtol, atol = _default_tolerances(dtype, rtol, atol)
    return spec, values, free, d, target, weights, dtype, rtol, atol


#: JAX's CPU backend reads a numpy array in place (no copy, no transfer thread) when it is
#: C-contiguous and aligned to this many bytes; numpy aligns large arrays to 16 only.
#: One 1,000 x 256 float64 argument: 231 us to pass unaligned, 8 us aligned. (`fit_many`
#: passes its arrays as they come: an aligned copy made here costs more than JAX's.)
_ALIGN = 64


def _aligned_empty(size: int, dtype: np.dtype) -> np.ndarray:
    """An uninitialised 1-D array of `size` elements whose data is `_ALIGN`-byte aligned."""
    itemsize = np.dtype(dtype).itemsize
    buf = np.empty(size * itemsize + _ALIGN, np.uint8)
    start = -buf.ctypes.data % _ALIGN
    return buf[start : start + size * itemsize].view(dtype)


# ----------------------------------------------------------------------------- public API
def fit(
    model: Family | tuple,
    d: Float[ArrayLike, " n"],
    target: Float[ArrayLike, " n"],
    *,
    loss: str = "relative",
    solver: str | Any = "levenberg_marquardt",
    free: Sequence[str] | str | None = None,
    weights: Float[ArrayLike, " n"] | None = None,
    max_steps: int = 256,
    rtol: float | None = None,
    atol: float | None = None,
    guess: bool = True,
) -> FitResult:
    """Fit `model` to attenuation samples `target` (1/length^2) at distances `d` (length).

    Args:
        model: a family instance (its field values are the start), or a pair `(fn, params)`
            with `fn(d, params) -> f` any JAX function of a dict of parameters and `params`
            a dict of start values (unconstrained unless a third item, a dict of
            constraints "positive" | "nonnegative" | "unit" | "real", says otherwise).
        d, target: samples, shape `(n,)`; `target > 0` (`>= 0` for the absolute loss).
        loss: "relative" (default; attenuation spans decades), "log" or "absolute".
        solver: "levenberg_marquardt" (default), "dogleg", "gauss_newton", "bfgs", or an
            optimistix least-squares solver or minimiser instance.
        free: the parameters to fit (default: the family's `default_free`, or every
            parameter of a `(fn, params)` model); the others stay at their values.
        weights: non-negative factors multiplying each residual (like `1/sigma`).
        max_steps, rtol, atol: optimistix's; tolerances default to 1e-8 in float64 and
            1e-5 in float32 (on the solver's internal coordinates).
        guess: start from the best of the given start and data-derived candidates
            (`attenfit._guess`); False starts exactly at the given values.

    Returns:
        A `FitResult`. Non-convergence is reported there, never raised. Bad arguments
        raise `BadValueError`, `BadTypeError` or `UnknownNameError` before any compilation.
    """
    spec, values, free, d, target, weights, dtype, rtol, atol = _prepare(
        model, d, target, weights, free, loss, solver, max_steps, rtol, atol, batched=False
    )
    w = () if weights is None else (weights,)
    fn = _compiled(
        spec, free, loss, solver, int(max_steps), rtol, atol, bool(guess), False, dtype, bool(w)
    )
    # one numpy vector in (start values, d, target, weights), which the CPU backend reads
    # in place
    parts = [*(np.ravel(values[k]) for k in spec.names), d, target, *w]
    flat = _aligned_empty(sum(p.size for p in parts), dtype)
    np.concatenate(parts, out=flat, casting="unsafe")
    out = fn(flat)
    return _make_result(
        spec, model, values, free, out, None, target.shape[-1], loss, _solver_name(solver), dtype
    )


class FitResults(Sequence):
    """Per-problem results of `fit_many`: a sequence of `FitResult` plus batched arrays.

    `results[i]` builds the i-th `FitResult` on demand; `params` (name -> array with a
    leading batch axis), `converged`, `steps` and `loss` are arrays over the batch.
    """

    def __init__(self, spec, template, values, free, flat, n, loss_kind, solver_name, dtype):
        self._args = (spec, template, values, free, flat, n, loss_kind, solver_name, dtype)
        out = _columns(flat, _free_size(spec, free))
        self._out = out
        self.free = free
        batch = len(out["loss"])
        where = _free_slices(spec, free)
        self.params: dict[str, np.ndarray] = {}
        for nm, shape in zip(spec.names, spec.shapes, strict=True):
            if nm in free:
                self.params[nm] = out["pvec"][:, where[nm]].reshape((batch, *shape))
            else:
                self.params[nm] = np.broadcast_to(values[nm], (batch, *shape))
        codes = out["result"]
        self.converged: np.ndarray = _converged(
            codes, out["start_finite"], out["loss"], out["grad_ok"]
        )
        self.steps: np.ndarray = out["steps"]
        self.loss: np.ndarray = out["loss"]

    def __len__(self) -> int:
        return len(self._out["loss"])

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        i = range(len(self))[i]
        spec, template, values, free, flat, n, loss_kind, solver_name, dtype = self._args
        if isinstance(template, Family):
            one = _rebuild(spec, template, [np.asarray(values[nm][i]) for nm in spec.names])
        else:
            one = (template[0], {nm: values[nm][i] for nm in spec.names})
        return _make_result(spec, one, values, free, flat[i], i, n, loss_kind, solver_name, dtype)

    def __repr__(self) -> str:
        return f"FitResults({len(self)} fits, {int(self.converged.sum())} converged)"


def fit_many(
    model: Family | tuple,
    d: Float[ArrayLike, "batch n"] | Float[ArrayLike, " n"],
    target: Float[ArrayLike, "batch n"],
    *,
    loss: str = "relative",
    solver: str | Any = "levenberg_marquardt",
    free: Sequence[str] | str | None = None,
    weights: Float[ArrayLike, "batch n"] | None = None,
    max_steps: int = 256,
    rtol: float | None = None,
    atol: float | None = None,
    guess: bool = True,
) -> FitResults:
    """Fit `batch` independent problems in one jitted, vmapped solve.

    The model's fields (or the `(fn, params)` values) carry a leading batch axis, or are
    scalars shared by every problem as the start; `d` is `(batch, n)` or `(n,)` (shared),
    `target` and `weights` are `(batch, n)`. Options as `fit`. Returns `FitResults`:
    `results[i]` is the i-th problem's `FitResult`, equal to what `fit` gives for it.
    """
    spec, values, free, d, target, weights, dtype, rtol, atol = _prepare(
        model, d, target, weights, free, loss, solver, max_steps, rtol, atol, batched=True
    )
    batch, n = target.shape
    bvalues = values
    d = np.broadcast_to(d, (batch, n))
    w = () if weights is None else (np.broadcast_to(weights, (batch, n)),)
    fn = _compiled(
        spec, free, loss, solver, int(max_steps), rtol, atol, bool(guess), True, dtype, bool(w)
    )
    nvalues = {k: np.ascontiguousarray(v, dtype) for k, v in bvalues.items()}
    out = fn(nvalues, *(np.ascontiguousarray(a, dtype) for a in (d, target, *w)))
    return FitResults(spec, model, bvalues, free, out, n, loss, _solver_name(solver), dtype)


def fit_dataset(
    model: Family | tuple,
    dataset: Any,
    *,
    loss: str = "relative",
    **options: Any,
) -> FitResult:
    """Fit the point-light model `E = weight * f(d)` to a dataset's irradiance.

    `weight = I g max(0, n.l)` and `d` come from `dataset.weight()` and
    `dataset.distance()` (the emitter's `point_light`); receivers with weight 0 (facing
    away, or outside a spot's cone) are dropped. The residuals are those of `E`: for the
    relative and log losses that is the relative error of `f` against `E / weight`; for the
    absolute loss, `weight * (f - E / weight)`. Where the dataset has standard errors
    (`stderr > 0`, Monte Carlo), each residual is divided by its standard error (samples
    with stderr 0 in a partly noisy dataset get the smallest positive one). Other
    options as `fit`; a `weights` option multiplies these.
    """
    try:
        d = np.asarray(dataset.distance())
        wgt = np.asarray(dataset.weight())
        E = np.asarray(dataset.E)
        stderr = np.asarray(dataset.stderr)
    except AttributeError as exc:
        raise BadTypeError(
            f"dataset must be an attenfit.Dataset (with distance(), weight(), E, stderr), got {type(dataset).__name__}"
        ) from exc
    d, wgt, E, stderr = (a.reshape(-1) for a in (d, wgt, E, stderr))
    keep = (wgt > 0) & np.isfinite(wgt)
    if not keep.any():
        raise BadValueError("no receiver in the dataset sees the light (every weight is 0)")
    user_w = options.pop("weights", None)
    if user_w is not None:
        user_w = _float_array("weights", user_w).reshape(-1)
        if user_w.shape != E.shape:
            raise BadValueError(
                f"weights has shape {user_w.shape}, the dataset has {E.shape[0]} receivers"
            )
    d, wgt, E, stderr = d[keep], wgt[keep], E[keep], stderr[keep]
    target = E / wgt
    if loss == "absolute":
        w = wgt.copy()
    else:
        w = np.ones_like(E)
    if np.any(stderr > 0):
        s = np.where(stderr > 0, stderr, stderr[stderr > 0].min())
        w = w / s * (E if loss != "absolute" else 1)
    if user_w is not None:
        w = w * user_w[keep]
    weights = None if np.all(w == 1) else w
    return fit(model, d, target, loss=loss, weights=weights, **options)
