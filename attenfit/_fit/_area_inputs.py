"""Fitting area-light models: their inputs checked (the fit's `d` is the stacked `AreaInputs`,
one row per input, `AreaModel.inputs`), and `fit_dataset` for them.

An area model's samples are receivers, not distances: `fit(model, x, target)` takes
`x = attenfit.area_inputs(...)` (or its `stack()`, shape `(6, n)`; `(batch, 6, n)` for
`fit_many`) and `target = E / I`. The solve is the families' (`_problem`): only the model
evaluation reads the six rows.
"""

from __future__ import annotations

from typing import Any

import jax
import numpy as np

from .._curves import AREA_INPUTS, AreaInputs, AreaModel
from .._errors import BadTypeError, BadValueError
from .._truth import area_inputs

__all__ = ["dataset_problem", "stack_inputs"]

#: Rows of an area model's `d`.
ROWS = len(AREA_INPUTS)


def stack_inputs(x: Any, ndim: int) -> np.ndarray:
    """The inputs of an area model as a float array `(6, n)` (`ndim` 1) or `(batch, 6, n)`,
    checked: finite, `d >= 0`, cosines in [-1, 1], `r > 0`, `g >= 0`."""
    if isinstance(x, AreaInputs):
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
    if arr.ndim not in (2, 3) or arr.shape[axis] != ROWS or (ndim == 1 and arr.ndim != 2):
        raise BadValueError(
            f"an area model's inputs must be attenfit.area_inputs(...) or an array ({ROWS}, n)"
            f"{' or (batch, 6, n)' if ndim == 2 else ''}, got shape {arr.shape}"
        )
    rows = np.moveaxis(arr, axis, 0)
    if not np.all(np.isfinite(arr)):
        raise BadValueError("an area model's inputs must be finite")
    checks = {
        "d": rows[0] >= 0,
        "cos_r": np.abs(rows[1]) <= 1,
        "cos_e": np.abs(rows[2]) <= 1,
        "r": rows[3] > 0,
        "cos_n": np.abs(rows[4]) <= 1,
        "g": rows[5] >= 0,
    }
    for name, ok in checks.items():
        if not ok.all():
            bad = np.asarray(rows[AREA_INPUTS.index(name)])[~ok].flat[0].item()
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
    x = area_inputs(emitter, points, normals)
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
