"""What a compiled solve depends on: a model's static structure (a `Model` class and its
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

from .._curves import Model
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

    key: Any  # hashable: (model class, pytree structure) or the user's fn
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
    #: their names (`AreaModel.input_names`); () for a family
    input_names: tuple[str, ...] = ()
    #: `1/f` linear in some parameters (`Model.inverse_linear`): the linear start
    inverse_linear: Any = dataclasses.field(default=None, compare=False)
    #: a family's clamped-distance parameter (`Family.clamp_param`): the exact start
    clamp_param: str | None = None


def _model_spec(model: Model, batched: bool) -> tuple[Spec, dict[str, np.ndarray]]:
    cls = type(model)
    leaves, treedef = jax.tree_util.tree_flatten(model)
    spec = _MODEL_SPECS.get((cls, treedef))
    if spec is None:
        spec = _MODEL_SPECS[cls, treedef] = _new_model_spec(model, treedef)
    if spec.leaves_are_params:
        values = {n: np.asarray(v) for n, v in zip(spec.names, leaves, strict=True)}
    else:
        values = {n: np.asarray(v) for n, v in model.params().items()}
    for n, v in values.items():
        if v.dtype.kind not in "fiu":
            raise BadTypeError(
                f"parameter {n!r} of {cls.name!r} must be a real number, got dtype {v.dtype}"
            )
    return spec, values


#: The static structure of each (model class, pytree structure) seen, built once: a
#: repeated `fit` of the same kind of model skips the class introspection.
_MODEL_SPECS: dict[Any, Spec] = {}


def _new_model_spec(model: Model, treedef: Any) -> Spec:
    cls = type(model)
    names = cls.param_names()
    template = model

    def evaluate(x, params):
        return rebuild(spec, template, [params[n] for n in names]).evaluate(x)

    spec = Spec(
        key=(cls, treedef),
        evaluate=evaluate,
        names=names,
        kinds=tuple(cls.constraint(n) for n in names),
        shapes=(),  # set by _prepare, which knows the batch size
        family=cls.name,
        length_params=tuple(cls.length_params),
        range_param=cls.range_param,
        leaves_are_params=_leaves_are_params(model, names),
        inputs=cls.inputs,
        input_names=tuple(getattr(cls, "input_names", ())) if cls.inputs else (),
        inverse_linear=cls.inverse_linear,
        clamp_param=getattr(cls, "clamp_param", None),
    )
    return spec


def _leaves_are_params(model: Model, names: tuple[str, ...]) -> bool:
    leaves = jax.tree_util.tree_leaves(model)
    return len(leaves) == len(names) and all(
        leaf is value for leaf, value in zip(leaves, model.param_leaves(), strict=False)
    )


def rebuild(spec: Spec, template: Any, fields: Sequence[Any]) -> Any:
    """`template` with its parameters replaced by `fields` (in `spec.names` order)."""
    if spec.leaves_are_params:
        return jax.tree_util.tree_unflatten(spec.key[1], list(fields))
    return eqx.tree_at(
        lambda m: m.param_leaves(), template, list(fields), is_leaf=lambda x: x is None
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
        # a function may declare what a `Model` class does (`_guess`: the scaled starts,
        # the range scanned beyond the data, the linear start), as attenfit's own
        # combined solves of several families do (`attenfit._scenes._family_solves`)
        length_params=tuple(getattr(fn, "length_params", ())),
        range_param=getattr(fn, "range_param", None),
        inverse_linear=getattr(fn, "inverse_linear", None),
    )
    return spec, values


def spec_of(model: Any, batched: bool) -> tuple[Spec, dict[str, np.ndarray]]:
    if isinstance(model, Model):
        return _model_spec(model, batched)
    if isinstance(model, type) and issubclass(model, Model):
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
