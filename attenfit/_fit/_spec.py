"""What a compiled solve depends on: a model's static structure (a family class and its
pytree, or a user's `(fn, params)` pair) and where each free parameter lies in the fitted
vector."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array

from .._curves import AREA_INPUTS, AreaModel, Family
from .._errors import BadTypeError, BadValueError, UnknownNameError

CONSTRAINT_WORDS = {
    "positive": "> 0",
    "nonnegative": ">= 0",
    "unit": "strictly between 0 and 1",
    "real": "finite",
}


# ----------------------------------------------------------------------------- the model
@dataclasses.dataclass(frozen=True)
class Spec:
    """The static structure of a model: what a compiled solve depends on."""

    key: Any  # hashable: family treedef or the user's fn
    evaluate: Callable[[Array, dict[str, Array]], Array] = dataclasses.field(compare=False)
    names: tuple[str, ...]
    kinds: tuple[str, ...]
    shapes: tuple[tuple[int, ...], ...]  # per-problem shape of each parameter
    family: str | None
    length_params: tuple[str, ...]
    #: the family's range parameter (a window's end), if it has one
    range_param: str | None = None
    #: the model's pytree leaves are exactly its parameters, in `names` order, so a fitted
    #: model is `tree_unflatten(treedef, values)` (20x cheaper than `eqx.tree_at`)
    leaves_are_params: bool = False
    #: rows of `d` (an area model's inputs, `_area`); 0: `d` is a vector of distances
    inputs: int = 0
    #: the parameter leaves of a model (`eqx.tree_at`'s `where`), where not its fields by name
    where: Callable[[Any], list[Any]] | None = dataclasses.field(default=None, compare=False)


def _family_spec(model: Family, batched: bool) -> tuple[Spec, dict[str, np.ndarray]]:
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
_FAMILY_SPECS: dict[Any, Spec] = {}


def _new_family_spec(model: Family, treedef: Any) -> Spec:
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

    return Spec(
        key=(cls, treedef),
        evaluate=evaluate,
        names=names,
        kinds=tuple(cls.constraint(n) for n in names),
        shapes=(),  # set by _prepare, which knows the batch size
        family=getattr(cls, "name", None),
        length_params=tuple(getattr(cls, "length_params", ())),
        range_param=getattr(cls, "range_param", None),
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


def rebuild(spec: Spec, template: Any, fields: Sequence[Any]) -> Any:
    """`template` with its parameters replaced by `fields` (in `spec.names` order)."""
    if spec.where is not None:
        return eqx.tree_at(spec.where, template, list(fields), is_leaf=lambda x: x is None)
    if spec.leaves_are_params:
        return jax.tree_util.tree_unflatten(spec.key[1], list(fields))
    return eqx.tree_at(
        lambda m: [getattr(m, nm) for nm in spec.names],
        template,
        list(fields),
        is_leaf=lambda x: x is None,
    )


def _pair_spec(model: tuple, batched: bool) -> tuple[Spec, dict[str, np.ndarray]]:
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
        if kind not in CONSTRAINT_WORDS:
            raise BadValueError(
                f"constraint {kind!r} of {n!r} is not one of {list(CONSTRAINT_WORDS)}"
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

    spec = Spec(
        key=(fn, tuple(sorted(constraints.items()))),
        evaluate=evaluate,
        names=names,
        kinds=tuple(constraints.get(n, "real") for n in names),
        shapes=shapes,
        family=None,
        length_params=(),
    )
    return spec, values


_AREA_SPECS: dict[Any, Spec] = {}


def area_spec(model: AreaModel, batched: bool) -> tuple[Spec, dict[str, np.ndarray]]:
    """The static structure of an area model and its parameter values."""
    _, treedef = jax.tree_util.tree_flatten(model)
    key = (type(model), treedef)
    spec = _AREA_SPECS.get(key)
    names = model.param_names()
    if spec is None:
        template = model

        def where(m: AreaModel) -> list[Any]:
            return m.param_leaves()

        def evaluate(x, params):
            m = eqx.tree_at(
                where, template, [params[n] for n in names], is_leaf=lambda v: v is None
            )
            return m.evaluate(x)

        spec = _AREA_SPECS[key] = Spec(
            key=key,
            evaluate=evaluate,
            names=names,
            kinds=tuple(model.constraint(n) for n in names),
            shapes=(),
            family=model.name,
            length_params=model.length_params(),
            inputs=len(AREA_INPUTS),
            where=where,
        )
    values = {n: np.asarray(v) for n, v in zip(names, model.param_leaves(), strict=True)}
    for n, v in values.items():
        if v.dtype.kind not in "fiu":
            raise BadTypeError(
                f"parameter {n!r} of {model.name!r} must be a real number, got dtype {v.dtype}"
            )
    return spec, values


def spec_of(model: Any, batched: bool) -> tuple[Spec, dict[str, np.ndarray]]:
    if isinstance(model, AreaModel):
        return area_spec(model, batched)
    if isinstance(model, Family):
        return _family_spec(model, batched)
    if isinstance(model, type) and issubclass(model, Family):
        raise BadTypeError(
            f"model must be a Family instance, got the class {model.__name__}; call it: {model.__name__}()"
        )
    if isinstance(model, tuple):
        return _pair_spec(model, batched)
    raise BadTypeError(
        "model must be a Family or area model instance or a pair (fn, params), got "
        f"{type(model).__name__}"
    )


@functools.lru_cache(maxsize=256)
def free_values(spec: Spec, free: tuple[str, ...]) -> tuple[str, ...]:
    """The name of each fitted value, in `free` order (an array parameter once per element)."""
    shapes = dict(zip(spec.names, spec.shapes, strict=True))
    return tuple(p for p in free for _ in range(math.prod(shapes[p])))


def free_size(spec: Spec, free: tuple[str, ...]) -> int:
    """The number of fitted values: the free parameters' sizes summed."""
    return len(free_values(spec, free))


@functools.lru_cache(maxsize=256)
def free_slices(spec: Spec, free: tuple[str, ...]) -> dict[str, slice]:
    """Where each free parameter's values lie in the fitted vector (`free` order)."""
    shapes = dict(zip(spec.names, spec.shapes, strict=True))
    out, i = {}, 0
    for p in free:
        out[p] = slice(i, i + math.prod(shapes[p]))
        i = out[p].stop
    return out


def free_kinds(spec: Spec, free: tuple[str, ...]) -> tuple[str, ...]:
    """The constraint of each fitted value, free parameters flattened in order."""
    kinds = dict(zip(spec.names, spec.kinds, strict=True))
    return tuple(kinds[p] for p in free_values(spec, free))


SHAPED_SPECS: dict[Any, Spec] = {}  # (spec, parameter shapes) -> the spec with those shapes
