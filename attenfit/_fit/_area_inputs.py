"""Fitting area-light models: their inputs checked (the fit's `d` is the stacked inputs, one
row per input the model's class names, `AreaModel.input_names`), and `fit_dataset` for them.

An area model's samples are receivers, not distances: `fit(model, x, target)` takes
`x = attenfit.area_inputs(...)` (or its `stack()`, shape `(6, n)`; `(batch, 6, n)` for
`fit_many`; a rectangle's or a tube's models: `model_inputs(...)`, 8 rows) and
`target = E / I`. The solve is the families' (`_problem`): only the model evaluation reads
the rows.
"""

from __future__ import annotations

from typing import Any

import jax
import numpy as np

from .._curves import AREA_INPUTS, INPUT_RANGES, AreaInputs, AreaModel
from .._errors import BadTypeError, BadValueError
from .._truth import model_inputs

__all__ = ["dataset_problem", "stack_inputs"]

_RANGE_OK = {
    "nonnegative": lambda v: v >= 0,
    "positive": lambda v: v > 0,
    "cosine": lambda v: np.abs(v) <= 1,
}


def stack_inputs(x: Any, ndim: int, names: tuple[str, ...] = AREA_INPUTS) -> np.ndarray:
    """The inputs `names` of an area model (its class's `input_names`) as a float array
    `(k, n)` (`ndim` 1) or `(batch, k, n)`, checked: finite, and each in its range
    (`INPUT_RANGES`: `d >= 0`, cosines and normal components in [-1, 1], sizes > 0,
    `g >= 0`)."""
    rows_n = len(names)
    if isinstance(x, AreaInputs | tuple):
        x = np.stack(np.broadcast_arrays(*(np.asarray(v) for v in x)))
    try:
        arr = np.asarray(x)
    except Exception as exc:
        raise BadTypeError(
            f"an area model's inputs must be AreaInputs, got {type(x).__name__}"
        ) from exc
    if arr.dtype.kind in "iu":
        arr = arr.astype(jax.dtypes.canonicalize_dtype(np.float64))
    if arr.dtype.kind != "f":
        raise BadTypeError(f"an area model's inputs must be floats, got dtype {arr.dtype}")
    axis = arr.ndim - 2
    if arr.ndim not in (2, 3) or arr.shape[axis] != rows_n or (ndim == 1 and arr.ndim != 2):
        raise BadValueError(
            f"an area model's inputs must be attenfit.area_inputs(...) or an array ({rows_n}, n)"
            f"{f' or (batch, {rows_n}, n)' if ndim == 2 else ''}, got shape {arr.shape}"
        )
    rows = np.moveaxis(arr, axis, 0)
    if not np.all(np.isfinite(arr)):
        raise BadValueError("an area model's inputs must be finite")
    for k, name in enumerate(names):
        test = _RANGE_OK.get(INPUT_RANGES.get(name, ""))
        ok = np.ones(rows[k].shape, bool) if test is None else test(rows[k])
        if not ok.all():
            bad = np.asarray(rows[k])[~ok].flat[0].item()
            raise BadValueError(f"area model input {name} out of range: {bad!r}")
    return arr


def dataset_problem(
    model: AreaModel, dataset: Any, loss: str, user_weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """`(x, target, weights)` that fit `model` to a dataset's irradiance: `target = E / I`.

    Receivers whose irradiance is 0 (behind a disk, below the horizon) are left out for the
    relative and log losses (their relative error is undefined) and kept for the absolute
    one. With standard errors (Monte Carlo), each residual is divided by its own; a
    caller's `user_weights` (one per receiver) multiply the residuals.
    """
    try:
        emitter, points, normals = dataset.emitter, dataset.points, dataset.normals
        E = np.asarray(dataset.E, dtype=np.float64).reshape(-1)
        stderr = np.asarray(dataset.stderr, dtype=np.float64).reshape(-1)
    except AttributeError as exc:
        raise BadTypeError(
            f"dataset must be an attenfit.Dataset, got {type(dataset).__name__}"
        ) from exc
    x = model_inputs(model, emitter, points, normals)
    dt = np.asarray(dataset.E).dtype
    xs = np.stack([np.asarray(v, dtype=dt).reshape(-1) for v in x])
    intensity = float(emitter.intensity)
    keep = np.isfinite(E) & ((E > 0) if loss != "absolute" else np.ones_like(E, bool))
    if not keep.any():
        raise BadValueError("no receiver in the dataset is lit (every irradiance is 0)")
    target = (E / intensity)[keep].astype(dt)
    w = None
    if np.any(stderr > 0):
        s = stderr[keep]
        s = np.where(s > 0, s, s[s > 0].min() if np.any(s > 0) else 1.0)
        w = (E[keep] / s if loss != "absolute" else intensity / s).astype(dt)
    if user_weights is not None:
        if user_weights.shape != E.shape:
            raise BadValueError(
                f"weights has shape {user_weights.shape}, the dataset has {E.shape[0]} receivers"
            )
        w = user_weights[keep].astype(dt) * (1 if w is None else w)
    return xs[:, keep], target, w
