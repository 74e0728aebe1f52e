"""Eager checks of `fit`'s arguments, before anything is traced or compiled, with one-line
messages that name the bad value; the dtype and default tolerances of a fit."""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import jax
import numpy as np

from .._errors import BadTypeError, BadValueError, UnknownNameError
from ._spec import CONSTRAINT_WORDS, Spec, free_size

#: Loss names accepted by `fit` (see the module docstring for the residuals).
LOSSES = ("relative", "log", "absolute")

#: Solver names accepted by `fit`: the keys of `attenfit._fit._solvers.SOLVERS`, whose module
#: (optimistix's solvers) is imported only when a solve is traced.
SOLVER_NAMES = ("levenberg_marquardt", "dogleg", "gauss_newton", "bfgs", "optimistix_lm")


# ----------------------------------------------------------------------------- validation
def float_array(name: str, x: Any) -> np.ndarray:
    try:
        arr = np.asarray(x)
    except Exception as exc:
        raise BadTypeError(f"{name} must be an array of floats, got {type(x).__name__}") from exc
    if arr.dtype.kind in "iu":  # whole metres, counts: exact in JAX's float
        arr = arr.astype(jax.dtypes.canonicalize_dtype(np.float64))
    if arr.dtype.kind != "f":
        raise BadTypeError(f"{name} must be a floating-point array, got dtype {arr.dtype}")
    return arr


def validate_data(
    d: Any, target: Any, weights: Any, loss: str, ndim: int, rows: tuple[str, ...] = ()
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """`d`, `target` and `weights` checked; `rows`: the names of an area model's inputs
    (`AreaModel.input_names`), whose stack is `d`."""
    if rows:
        from ._area_inputs import stack_inputs

        x = stack_inputs(d, ndim, rows)
        shape = np.shape(target)
        if not shape or shape[-1] != x.shape[-1] or (x.ndim == 3 and shape[0] != x.shape[0]):
            raise BadValueError(
                f"the inputs hold {x.shape[-1]} receivers, target has shape {shape}"
            )
        _, target, weights = validate_data(np.zeros_like(x[..., 0, :]), target, weights, loss, ndim)
        return x, target, weights
    d = float_array("d", d)
    target = float_array("target", target)
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
    # values whose squares (absolute loss) or inverses (relative loss) leave the float range
    # would judge any fit "exact" at 0 steps (residuals flushed to 0): refuse them
    fi = np.finfo(target.dtype)
    tiny, big = float(fi.tiny), float(fi.max)
    lo, hi = tiny**0.5 * 1e4, big**0.5 / 1e4  # for squares: weights, absolute targets
    if loss == "relative" and not (1e4 / big <= t_lo and t_hi <= 1 / (1e4 * tiny)):
        bad = float(t_lo if t_lo < 1e4 / big else t_hi)
        raise BadValueError(
            f"target values must lie within [{1e4 / big:.0e}, {1 / (1e4 * tiny):.0e}] in "
            f"{target.dtype} for a relative fit to be judged (1 / target must be a normal "
            f"float), got {bad!r}; rescale the target (the fitted shape does not depend on it)"
        )
    if loss == "absolute" and t_hi > 0 and not (lo <= t_hi <= hi):
        raise BadValueError(
            f"target values must reach into [{lo:.0e}, {hi:.0e}] in {target.dtype} for an "
            f"absolute fit to be judged (their squares must be normal floats), got a largest "
            f"of {float(t_hi)!r}; rescale the target"
        )
    if weights is not None:
        weights = _checked_weights(weights, target.shape, ndim, lo, hi)
    return d, target, weights


def _checked_weights(
    weights: Any, shape: tuple[int, ...], ndim: int, lo: float, hi: float
) -> np.ndarray:
    """`weights` checked against the target's `shape`: finite, >= 0, some positive in each
    problem, and the positive ones within [lo, hi] (their squares normal floats)."""
    weights = float_array("weights", weights)
    if weights.shape != shape and not (ndim == 2 and weights.shape == shape[1:]):
        raise BadValueError(
            f"weights has shape {weights.shape} but target has shape {shape}; they must match"
        )
    if not (weights.min() >= 0 and weights.max() < math.inf):
        bad = weights[~(np.isfinite(weights) & (weights >= 0))].flat[0].item()
        raise BadValueError(f"weights must be finite and >= 0, got {bad!r}")
    if not np.all(np.any(weights > 0, axis=-1)):
        raise BadValueError("weights are all 0 (in at least one problem); nothing to fit")
    w_pos = weights[weights > 0]
    if not (lo <= w_pos.min() and w_pos.max() <= hi):
        bad = w_pos[(w_pos < lo) | (w_pos > hi)].flat[0].item()
        raise BadValueError(
            f"weights must lie within [{lo:.0e}, {hi:.0e}] (or be 0) for a fit to be judged, "
            f"got {bad!r}; rescale them (only their ratios matter)"
        )
    return weights


def validate_options(
    spec: Spec,
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
                f"start value of {name!r} must be {CONSTRAINT_WORDS[kind]}, got {v[~ok].flat[0].item()!r}"
            )
    return free


def _is_optimistix_solver(solver: Any) -> bool:
    import optimistix as optx

    return isinstance(solver, (optx.AbstractLeastSquaresSolver, optx.AbstractMinimiser))


@functools.lru_cache(maxsize=256)
def _checked_options(spec, free, loss, solver, max_steps_type, max_steps, n) -> tuple[str, ...]:
    """`free`, once `free`, `loss`, `solver` and `max_steps` are checked (see `fit`)."""
    if not isinstance(loss, str) or loss not in LOSSES:
        raise UnknownNameError(f"unknown loss {loss!r}; known losses: {', '.join(LOSSES)}")
    if isinstance(solver, str):
        if solver not in SOLVER_NAMES:
            raise UnknownNameError(
                f"unknown solver {solver!r}; known solvers: {', '.join(SOLVER_NAMES)}"
            )
    elif not _is_optimistix_solver(solver):
        raise BadTypeError(
            f"solver must be one of {list(SOLVER_NAMES)} or an optimistix least-squares solver or "
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
    k = free_size(spec, free)
    if n < k:
        raise BadValueError(f"{n} samples cannot determine {k} free parameter values")
    return free


def dtype_of(*arrays: np.ndarray) -> np.dtype:
    """The JAX float dtype a fit runs in: the widest input float, as JAX will hold it."""
    return np.dtype(jax.dtypes.canonicalize_dtype(np.result_type(*arrays)))


@functools.cache
def _default_tolerance(dtype: np.dtype) -> float:
    """1e-8 in float64, 1e-5 in float32 (100 eps where that is larger)."""
    eps = float(np.finfo(dtype).eps)
    return 1e-8 if eps < 1e-10 else max(1e-5, 100 * eps)


def default_tolerances(dtype: np.dtype, rtol: float | None, atol: float | None):
    default = _default_tolerance(dtype)
    for name, tol in (("rtol", rtol), ("atol", atol)):
        if tol is not None and not (
            isinstance(tol, int | float | np.floating | np.integer) and 0 <= tol < math.inf
        ):
            raise BadValueError(f"{name} must be a finite number >= 0 (or None), got {tol!r}")
    return (default if rtol is None else float(rtol)), (default if atol is None else float(atol))


def solver_name(solver) -> str:
    return solver if isinstance(solver, str) else type(solver).__name__
