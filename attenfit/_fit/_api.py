"""Least-squares fits of attenuation families with optimistix: one curve, a dataset, or a batch.

`fit` fits a family instance (its field values are the start) or a user's `(fn, params)`
pair to attenuation samples `target` at distances `d`; `fit_dataset` fits the point-light
model `E = I g f(d) max(0, n.l)` (or an area model, `_area`) to a dataset's irradiance; `fit_many` solves thousands of
independent problems in one jitted, vmapped solve.

How (docs/fitting.md):
- The solver moves unconstrained coordinates (`_reparam`): `exp` for positive
  parameters, a reflection for nonnegative ones (so an optimum on 0 is reached exactly),
  a sigmoid for unit ones. After the solve, a nonnegative parameter whose value 0 fits as
  well within the tolerances is set to exactly 0 and reported as on its bound (tried where
  the solver's linear model puts 0 within `_SNAP_MARGIN` times the tolerance).
- The start is the best of the caller's start and a few data-derived candidates
  (`_guess`), evaluated inside the compiled solve.
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
from collections.abc import Sequence
from typing import Any

import numpy as np
from jaxtyping import ArrayLike, Float

from .._curves import Model
from .._errors import BadTypeError, BadValueError
from ._area_inputs import dataset_problem
from ._compiled import compiled_solve
from ._result import FitResult, FitResults, make_result
from ._spec import SHAPED_SPECS, spec_of
from ._validate import (
    default_tolerances,
    dtype_of,
    float_array,
    solver_name,
    validate_data,
    validate_options,
)

__all__ = ["fit", "fit_dataset", "fit_many"]


def _prepare(model, d, target, weights, free, loss, solver, max_steps, rtol, atol, batched):
    ndim = 2 if batched else 1
    spec, values = spec_of(model, batched)
    d, target, weights = validate_data(d, target, weights, loss, ndim, spec.input_names)
    batch = target.shape[0] if batched else None
    shapes = tuple(
        v.shape[1:] if batched and v.ndim >= 1 and v.shape[0] == batch else v.shape
        for v in (values[nm] for nm in spec.names)
    )
    shaped = SHAPED_SPECS.get((spec, shapes))
    if shaped is None:
        shaped = SHAPED_SPECS[spec, shapes] = dataclasses.replace(spec, shapes=shapes)
    spec = shaped
    if batched:
        values = {
            nm: np.broadcast_to(values[nm], (batch, *shape))
            for nm, shape in zip(spec.names, spec.shapes, strict=True)
        }
    if free is None:
        free = tuple(type(model).default_free) if isinstance(model, Model) else spec.names
    n = target.shape[-1]
    free = validate_options(spec, values, free, loss, solver, max_steps, n, batch)
    dtype = dtype_of(d, target, *(() if weights is None else (weights,)))
    rtol, atol = default_tolerances(dtype, rtol, atol)
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
    model: Model | tuple,
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
        model: a family instance (its field values are the start), an area model (its `d`
            is the receivers' `attenfit.area_inputs(...)`, its target `E / I`), or a pair
            `(fn, params)` with `fn(d, params) -> f` any JAX function of a dict of
            parameters and `params` a dict of start values (unconstrained unless a third
            item, a dict of constraints "positive" | "nonnegative" | "unit" | "real", says
            otherwise).
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
            (`attenfit._fit._guess`); False starts exactly at the given values.

    Returns:
        A `FitResult`. Non-convergence is reported there, never raised. Bad arguments
        raise `BadValueError`, `BadTypeError` or `UnknownNameError` before any compilation.
    """
    spec, values, free, d, target, weights, dtype, rtol, atol = _prepare(
        model, d, target, weights, free, loss, solver, max_steps, rtol, atol, batched=False
    )
    w = () if weights is None else (weights,)
    fn = compiled_solve(
        spec, free, loss, solver, int(max_steps), rtol, atol, bool(guess), False, dtype, bool(w)
    )
    # one numpy vector in (start values, d, target, weights), which the CPU backend reads
    # in place
    parts = [*(np.ravel(values[k]) for k in spec.names), np.ravel(d), target, *w]
    flat = _aligned_empty(sum(p.size for p in parts), dtype)
    np.concatenate(parts, out=flat, casting="unsafe")
    out = fn(flat)
    return make_result(
        spec, model, values, free, out, None, target.shape[-1], loss, solver_name(solver), dtype
    )


def fit_many(
    model: Model | tuple,
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
    d = np.broadcast_to(d, (batch, *d.shape[-1 - (spec.inputs > 0) :]))
    w = () if weights is None else (np.broadcast_to(weights, (batch, n)),)
    fn = compiled_solve(
        spec, free, loss, solver, int(max_steps), rtol, atol, bool(guess), True, dtype, bool(w)
    )
    nvalues = {k: np.ascontiguousarray(v, dtype) for k, v in bvalues.items()}
    out = fn(nvalues, *(np.ascontiguousarray(a, dtype) for a in (d, target, *w)))
    return FitResults(spec, model, bvalues, free, out, n, loss, solver_name(solver), dtype)


def fit_dataset(
    model: Model | tuple,
    dataset: Any,
    *,
    loss: str = "relative",
    **options: Any,
) -> FitResult:
    """Fit the point-light model `E = weight * f(d)` to a dataset's irradiance (an area
    model: `E = I * model(area_inputs)`, receivers with E = 0 left out unless the loss is
    absolute, `attenfit._fit._area_inputs.dataset_problem`).

    `weight = I g max(0, n.l)` and `d` come from `dataset.weight()` and
    `dataset.distance()` (the emitter's `point_light`); receivers with weight 0 (facing
    away, or outside a spot's cone) are dropped. The residuals are those of `E`: for the
    relative and log losses that is the relative error of `f` against `E / weight`; for the
    absolute loss, `weight * (f - E / weight)`. Where the dataset has standard errors
    (`stderr > 0`, Monte Carlo), each residual is divided by its standard error (samples
    with stderr 0 in a partly noisy dataset get the smallest positive one). Other
    options as `fit`; a `weights` option multiplies these.
    """
    user_w = options.pop("weights", None)
    if user_w is not None:
        user_w = float_array("weights", user_w).reshape(-1)
    # the samples the model reads (`Model.inputs`): receivers' geometry, or distances
    inputs = type(model).inputs if isinstance(model, Model) else 0
    problem = dataset_problem if inputs else _distance_problem
    x, target, weights = problem(model, dataset, loss, user_w)
    return fit(model, x, target, loss=loss, weights=weights, **options)


def _distance_problem(
    model: Any, dataset: Any, loss: str, user_w: np.ndarray | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """`(d, target, weights)` that fit the point-light model `E = weight * f(d)` to a
    dataset's irradiance (see `fit_dataset`)."""
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
    if user_w is not None:
        if user_w.shape != E.shape:
            raise BadValueError(
                f"weights has shape {user_w.shape}, the dataset has {E.shape[0]} receivers"
            )
    d, wgt, E, stderr = d[keep], wgt[keep], E[keep], stderr[keep]
    with np.errstate(over="ignore"):  # an attenuation past the float range: refused below
        target = E / wgt
    if not np.all(np.isfinite(target)):
        bad = float(E[~np.isfinite(target)][0])
        raise BadValueError(
            f"the dataset's E = {bad!r} gives an attenuation E / (I g n.l) beyond the float "
            "range; attenfit cannot judge a fit to it"
        )
    if loss == "absolute":
        w = wgt.copy()
    else:
        w = np.ones_like(E)
    if np.any(stderr > 0):
        s = np.where(stderr > 0, stderr, stderr[stderr > 0].min())
        with np.errstate(over="ignore"):  # weights past the float range: refused by `fit`
            w = w / s * (E if loss != "absolute" else 1)
    if user_w is not None:
        w = w * user_w[keep]
    weights = None if np.all(w == 1) else w
    return d, target, weights
