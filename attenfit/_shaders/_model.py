"""What `export`, the costs and the traces accept as a model: a model (a family or an area
model, instance or class), a registered name, a fit result, its dict, or a fit file
(`load_model`)."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._curves import Model, get_area_model, get_family, list_area_models, list_families
from .._errors import BadTypeError, BadValueError, DataFileError, UnknownNameError
from .._input import LIMITS, load_json, read_text

__all__ = ["as_family", "as_model", "load_model", "model_class", "param_value"]

#: What a fit records beside its model (its error), quoted in an export's header.
_FIT_KEYS = ("metrics", "loss", "converged")


def model_class(name: str) -> type[Model]:
    """The model class registered as `name`: a family, else an area model."""
    if not isinstance(name, str):
        raise BadTypeError(f"model name must be a string, got {name!r}")
    if name in list_families():
        return get_family(name)
    if name in list_area_models():
        return get_area_model(name)
    raise UnknownNameError(
        f"unknown family {name!r} (nor area model); known families: "
        f"{', '.join(list_families())}; area models: {', '.join(list_area_models())}"
    )


def as_model(source: Any) -> Model:
    """A model instance from a model, a model class or a registered name."""
    if isinstance(source, Model):
        return source
    if isinstance(source, type) and issubclass(source, Model):
        return source()
    if isinstance(source, str):
        return model_class(source)()
    raise BadTypeError(
        f"expected a family or area model (instance, class or name), got {type(source).__name__}"
    )


def as_family(source: Any) -> Model:
    """`as_model`, refused (`BadTypeError`) unless the model reads the distance alone (a
    family: what is traced, counted and timed; an area model has its shader form only)."""
    model = as_model(source)
    if model.inputs:
        raise BadTypeError(
            f"{model.kind} {model.name!r} reads {model.inputs} inputs, not the distance "
            "alone: only a family is traced, counted and timed (its shader form is costed "
            "by area_compiled_cost)"
        )
    return model


def load_model(source: Any, *, family: str | None = None) -> tuple[Model, dict[str, Any]]:
    """Resolve what `export` accepts into `(model instance, fit information)`.

    `source` is a model (a `Family` or an `AreaModel`, instance or class), a registered
    name, a `FitResult` (anything with a `model`), a dict as written by `FitResult.to_dict()`
    (the model's name under "family" and parameter values under "params"), a list of such
    dicts, or the path of such a JSON file (`attenfit fit --out DIR` writes `DIR/fits.json`;
    the folder is accepted too). When the source holds several fits, `family` names the one
    to use (refused for any other source). The fit information is empty except for a fit,
    where it holds what the fit reported (metrics, loss, converged, configuration, file).
    """
    if isinstance(source, str | os.PathLike) and _path_like(str(source)):
        path = Path(source)
        if path.is_dir():
            path = path / "fits.json"
        what = f"fit file {str(path)!r}"
        data = load_json(read_text(path, what, LIMITS["fits"]), what)
        model, info = _from_dict(data, where=what, family=family)
        info["file"] = str(path)
        return model, info
    if isinstance(source, Mapping | list):
        return _from_dict(source, where="fit dict", family=family)
    fitted = getattr(source, "model", None)
    if isinstance(fitted, Model):  # a FitResult
        model = fitted
        info = {k: _plain(getattr(source, k)) for k in _FIT_KEYS if getattr(source, k, None) is not None}  # fmt: skip
    else:
        try:
            model, info = as_model(source), {}
        except BadTypeError:
            raise BadTypeError(
                "export takes a Family or an AreaModel (instance or class), a model's name, a "
                "FitResult, a FitResult.to_dict() dict or a FIT.json path, got "
                f"{type(source).__name__}"
            ) from None
    if family is not None:
        article = "an" if model.kind[0] in "aeiou" else "a"
        raise BadValueError(
            f"family={family!r} (--family) picks one fit of a fit file; {model.name!r} is "
            f"{article} {model.kind}, not a fit file"
        )
    return model, info


def _path_like(text: str) -> bool:
    """Whether `text` names a fit file rather than a model."""
    return text.endswith(".json") or os.sep in text or Path(text).exists()


def _plain(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    arr = np.asarray(value)
    if arr.dtype.kind in "fiub":
        return arr.item()
    return value


def _from_dict(data: Any, *, where: str, family: str | None = None) -> tuple[Model, dict[str, Any]]:
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
    params = data.get("params", {})
    if not isinstance(params, Mapping):
        raise DataFileError(f"{where}: 'params' must be an object of parameter values")
    try:
        model = model_class(name)().replace(
            **{k: param_value(v, k, where) for k, v in params.items()}
        )
    except UnknownNameError as exc:
        raise DataFileError(f"{where}: {exc}") from None
    info = {k: _plain(data[k]) for k in (*_FIT_KEYS, "configuration") if k in data}
    return model, info


def param_value(value: Any, name: str, where: str) -> Any:
    """A parameter value read from outside (a fit file, `--param`): a finite number or array."""
    try:
        arr = np.asarray(value)
    except ValueError:  # a ragged list
        raise DataFileError(
            f"{where}: parameter {name}={value!r} is not a number or a list of numbers"
        ) from None
    if arr.dtype.kind not in "fi" or not np.all(np.isfinite(arr)):
        raise DataFileError(f"{where}: parameter {name}={value!r} is not a finite number")
    return float(arr) if arr.ndim == 0 else arr.astype(np.float64)
