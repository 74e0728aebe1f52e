"""What `export` and the compiled costs accept as a model: a family, a family name, a fit
result, its dict, or a fit file (`load_model`)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._curves import Family, get_family
from .._errors import BadTypeError, BadValueError, DataFileError, UnknownNameError
from .._input import LIMITS, load_json, read_text

__all__ = ["load_model", "param_value"]


def load_model(source: Any, *, family: str | None = None) -> tuple[Family, dict[str, Any]]:
    """Resolve what `export` accepts into `(family instance, fit information)`.

    `source` is a `Family` instance or class, a registered family name, a `FitResult`
    (anything with a `model` that is a `Family`), a dict as written by
    `FitResult.to_dict()` (a family name under "family" and parameter values under
    "params"), a list of such dicts, or the path of such a JSON file (`attenfit fit --out
    DIR` writes `DIR/fits.json`; the folder is accepted too). When the source holds several
    fits, `family` names the one to use. The fit information is empty except for a fit,
    where it holds what the fit reported (metrics, loss, converged, configuration, file).
    """
    if isinstance(source, Family):
        return source, {}
    if isinstance(source, type) and issubclass(source, Family):
        return source(), {}
    if isinstance(source, str | os.PathLike) and (
        str(source).endswith(".json") or os.sep in str(source) or Path(source).exists()
    ):
        path = Path(source)
        if path.is_dir():
            path = path / "fits.json"
        what = f"fit file {str(path)!r}"
        data = load_json(read_text(path, what, LIMITS["fits"]), what)
        model, info = _from_dict(data, where=f"fit file {str(path)!r}", family=family)
        info["file"] = str(path)
        return model, info
    if isinstance(source, str):
        return get_family(source)(), {}
    if isinstance(source, Mapping | list):
        return _from_dict(source, where="fit dict", family=family)
    model = getattr(source, "model", None)
    if isinstance(model, Family):
        info = {
            key: _plain(getattr(source, key))
            for key in ("metrics", "loss", "converged")
            if getattr(source, key, None) is not None
        }
        return model, info
    raise BadTypeError(
        "export takes a Family, a family name, a FitResult, a FitResult.to_dict() dict or a "
        f"FIT.json path, got {type(source).__name__}"
    )


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    arr = np.asarray(value)
    if arr.dtype.kind in "fiub":
        return arr.item()
    return value


def _from_dict(
    data: Any, *, where: str, family: str | None = None
) -> tuple[Family, dict[str, Any]]:
    if isinstance(data, Mapping) and isinstance(data.get("fits"), list):
        data = data["fits"]
    if isinstance(data, list):
        names = [d.get("family") if isinstance(d, Mapping) else None for d in data]
        if family is not None:
            if family not in names:
                raise UnknownNameError(f"{where} holds no fit of family {family!r}; it has {names}")
            data = data[names.index(family)]
        elif len(data) != 1:
            raise BadValueError(
                f"{where} holds {len(data)} fits ({', '.join(map(str, names))}); name one "
                "(family=..., or --family on the command line)"
            )
        else:
            data = data[0]
    if not isinstance(data, Mapping):
        raise DataFileError(f"{where} is not a fit result (expected a JSON object)")
    name = data.get("family", data.get("model"))
    if isinstance(name, Mapping):
        name = name.get("name")
    if not isinstance(name, str):
        raise DataFileError(f"{where} names no family (expected a string under 'family')")
    try:
        cls = get_family(name)
    except UnknownNameError as exc:
        raise DataFileError(f"{where}: {exc}") from None
    params = data.get("params", {})
    if not isinstance(params, Mapping):
        raise DataFileError(f"{where}: 'params' must be an object of parameter values")
    try:
        model = cls().replace(**{k: param_value(v, k, where) for k, v in params.items()})
    except UnknownNameError as exc:
        raise DataFileError(f"{where}: {exc}") from None
    info = {
        k: _plain(data[k]) for k in ("metrics", "loss", "converged", "configuration") if k in data
    }
    return model, info


def param_value(value: Any, name: str, where: str) -> Any:
    try:
        arr = np.asarray(value)
    except ValueError:  # a ragged list
        raise DataFileError(
            f"{where}: parameter {name}={value!r} is not a number or a list of numbers"
        ) from None
    if arr.dtype.kind not in "fi" or not np.all(np.isfinite(arr)):
        raise DataFileError(f"{where}: parameter {name}={value!r} is not a finite number")
    return float(arr) if arr.ndim == 0 else arr.astype(np.float64)
