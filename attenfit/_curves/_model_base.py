"""`Model`, the one abstract base of every model attenfit fits: the distance families
(`Family`, `_family`) and the area-light models (`AreaModel`, `_area`).

A model is a small immutable `eqx.Module` whose parameters are its non-static fields (or,
for `PointLight(family)`, its family's: `params_field`). What a model *is* lives on its
class: name, formula, source, the parameters a fit frees, each parameter's constraint and
power of length; and how it is written in a shader (`shader_form`, an expression of
`attenfit._ir`). Everything here reads those facts and is final (subclasses override only
the abstract members, `evaluate`, `shader_form` and the class variables).
"""

import abc
import dataclasses
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import equinox as eqx
import jax
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadTypeError, BadValueError, UnknownNameError
from .._ir import ShaderForm

__all__ = ["CONSTRAINTS", "Model", "no_shader_form"]

#: The kinds of constraint a parameter can carry (see `Model.constraints`).
CONSTRAINTS = ("positive", "nonnegative", "unit", "real")


class Model(eqx.Module):
    """A differentiable, parameterised model of a light's irradiance, fitted by `attenfit.fit`.

    Subclasses: `Family` (`f(d)` from the distance) and `AreaModel` (`E / I` from the
    receiver geometry). Their final subclasses declare the parameters as fields with
    defaults, the abstract class variables below, and how they evaluate.
    """

    #: Registry name, e.g. ``"yuksel"``.
    name: eqx.AbstractClassVar[str]
    #: The formula as text, in the stable form the code evaluates.
    formula: eqx.AbstractClassVar[str]
    #: Citation: paper and equation, or engine file and function.
    source: eqx.AbstractClassVar[str]
    #: Parameters a fit frees when the caller does not say (`fit(..., free=None)`).
    default_free: eqx.AbstractClassVar[tuple[str, ...]]
    #: What the model is called in messages ("family", "area model").
    kind: eqx.AbstractClassVar[str]
    #: Rows of the samples' inputs `evaluate` reads: 0, a vector of distances; k, an array
    #: `(k, n)` (an area model's stacked `AreaInputs`).
    inputs: eqx.AbstractClassVar[int]

    #: Parameter -> one of "positive" (the default), "nonnegative" (0 allowed and reachable
    #: by a fit), "unit" (strictly between 0 and 1), "real" (unconstrained).
    constraints: ClassVar[Mapping[str, str]] = {}
    #: Parameters with units of length: a fit's start candidates scale them together, and
    #: under d -> s d and p -> s p for each of them a family scales as f -> f / s^2.
    length_params: ClassVar[tuple[str, ...]] = ()
    #: Powers of length of the other dimensional parameters (e.g. ``{"eps": 2}`` for an area,
    #: ``{"scale": -2}`` for a free scale in 1/length^2); unlisted ones are dimensionless.
    units: ClassVar[Mapping[str, int]] = {}
    #: Name of the parameter at which the curve reaches 0 (a window's range), if any.
    range_param: ClassVar[str | None] = None
    #: `(offset(x), {param: basis(x)})` where `1/model = offset + sum_p p basis_p(x)` (linear
    #: in those parameters: a fit's linear start, `attenfit._fit._guess`); None: not linear.
    inverse_linear: ClassVar[tuple[Callable, Mapping[str, Callable]] | None] = None
    #: Where the parameters live: None, this model's own non-static fields; else the name of
    #: the field holding the model whose parameters these are (`PointLight`'s `family`), a
    #: model of class `params_class`.
    params_field: ClassVar[str | None] = None
    params_class: ClassVar[type | None] = None
    #: Class facts `describe` reports after the parameters, in this order.
    described: ClassVar[tuple[str, ...]] = ()

    def __check_init__(self):
        """Refuse concrete parameter values that break their constraint (tracers pass)."""
        cls = type(self)
        defaults = cls.defaults()
        for name, value in self.params().items():
            _check_param(cls.name, name, value, cls.constraint(name))
            _check_shape(cls.name, name, value, defaults[name])

    @abc.abstractmethod
    def evaluate(self, x: Float[ArrayLike, "*rows n"]) -> Float[Array, " n"]:
        """The model at its samples' inputs: a family's distances `d`, an area model's
        stacked `AreaInputs` (`inputs` rows). What a fit evaluates."""

    @abc.abstractmethod
    def shader_form(self) -> ShaderForm | None:
        """The model's expression in a shader (`attenfit._ir.ShaderForm`): the engine's code
        it cites, or the textbook formula, without the JAX form's guards (`_forms`). What
        `attenfit._shaders` prints, evaluates in float16/32, compiles and exports.

        None only for a class that says it has none, `shader_form = no_shader_form` (its
        export prints the guarded form traced from the JAX code instead)."""

    @classmethod
    def has_shader_form(cls) -> bool:
        """Whether instances have a shader form (the class does not say `no_shader_form`)."""
        return cls._params_home().shader_form is not no_shader_form

    # ------------------------------------------------------------------ class facts
    @classmethod
    def _params_home(cls) -> type:
        """The class whose non-static fields are the parameters."""
        return cls if cls.params_field is None else cls.params_class

    @classmethod
    def param_names(cls) -> tuple[str, ...]:
        """The parameter names, in field order (static fields are options, not parameters)."""
        return tuple(f.name for f in _param_fields(cls._params_home()))

    @classmethod
    def option_names(cls) -> tuple[str, ...]:
        """The static fields (options such as a spline's knots): part of the structure."""
        home = cls._params_home()
        return tuple(f.name for f in dataclasses.fields(home) if f.metadata.get("static", False))

    @classmethod
    def defaults(cls) -> dict[str, Any]:
        """The default parameter values."""
        return {
            f.name: f.default if f.default is not dataclasses.MISSING else f.default_factory()
            for f in _param_fields(cls._params_home())
        }

    @classmethod
    def constraint(cls, param: str) -> str:
        """The constraint of `param` ("positive" unless `constraints` says otherwise)."""
        if param not in cls.param_names():
            raise UnknownNameError(
                f"{cls.kind} {cls.name!r} has no parameter {param!r}; it has "
                f"{list(cls.param_names())}"
            )
        return cls.constraints.get(param, "positive")

    @classmethod
    def length_power(cls, param: str) -> int:
        """The power of length in the unit of `param` (1 for `length_params`, else `units`)."""
        cls.constraint(param)  # raises on an unknown name
        return 1 if param in cls.length_params else int(cls.units.get(param, 0))

    @classmethod
    def describe(cls) -> dict[str, Any]:
        """Name, formula, source, parameters with defaults and constraints, the class's
        other facts (`described`), and where the parameters live (`params_field`: the name
        of its model, e.g. ``{"family": "yuksel"}``)."""
        out = {
            "name": cls.name,
            "formula": cls.formula,
            "source": cls.source,
            "params": {
                p: {"default": _plain(v), "constraint": cls.constraint(p)}
                for p, v in cls.defaults().items()
            },
            "default_free": list(cls.default_free),
            **{k: _plain_fact(getattr(cls, k)) for k in cls.described},
        }
        if cls.params_field is not None:
            out[cls.params_field] = cls.params_class.name
        return out

    @classmethod
    def check_class(cls) -> None:
        """Raise unless the class's facts name its parameters (at registration)."""
        linear = {} if cls.inverse_linear is None else cls.inverse_linear[1]
        for param in (*cls.default_free, *cls.length_params, *cls.constraints, *linear):
            cls.constraint(param)  # raises on an unknown name
        for param, kind in cls.constraints.items():
            if kind not in CONSTRAINTS:
                raise BadValueError(
                    f"{cls.kind} {cls.name!r}: constraint {kind!r} of {param!r} is not one "
                    f"of {list(CONSTRAINTS)}"
                )

    # ------------------------------------------------------------------ values
    def _params_owner(self) -> "Model":
        """The model whose fields hold the parameters (`params_field`)."""
        field = type(self).params_field
        return self if field is None else getattr(self, field)

    def params(self) -> dict[str, Any]:
        """The parameter values, by name."""
        owner = self._params_owner()
        return {n: getattr(owner, n) for n in self.param_names()}

    def param_leaves(self) -> list[Any]:
        """The parameter values as the model's own leaves (what `eqx.tree_at` replaces)."""
        return list(self.params().values())

    def free_by_default(self) -> tuple[str, ...]:
        """`default_free` (kept for callers that ask an instance)."""
        return tuple(type(self).default_free)

    def replace(self, **values: Any) -> "Model":
        """A copy with some parameters replaced (their constraints checked)."""
        cls = type(self)
        names = cls.param_names()
        for key in values:
            if key not in names:
                raise UnknownNameError(
                    f"{cls.kind} {cls.name!r} has no parameter {key!r}; it has {list(names)}"
                )
        if cls.params_field is None:
            return dataclasses.replace(self, **values)
        owner = self._params_owner()
        return dataclasses.replace(self, **{cls.params_field: owner.replace(**values)})


def no_shader_form(self: Model) -> None:
    """The `shader_form` of a model without one: a class says ``shader_form = no_shader_form``
    (a spline with no published formula, a user's own family). `export` then prints the
    guarded form traced from the JAX code."""
    return None


def _check_param(family: str, name: str, value: Any, kind: str) -> None:
    """Raise BadValueError/BadTypeError if a concrete parameter value breaks `kind`."""
    if isinstance(value, jax.core.Tracer):
        return
    try:
        arr = np.asarray(value)
    except Exception:
        return  # an unusual leaf (e.g. an abstract placeholder): the maths will tell
    if arr.dtype == object or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise BadTypeError(
            f"family {family!r}: parameter {name!r} must be a real number or array, got {value!r}"
        )
    arr = arr.astype(np.float64)
    if np.any(np.isnan(arr)):
        raise BadValueError(f"family {family!r}: parameter {name!r} must be a number, got NaN")
    if np.any(np.isinf(arr)):
        # engines read "no range" as the curve without its window (three.js distance = 0,
        # Filament falloff(0)); the windowed forms give NaN or 0 at inf, so say it instead
        raise BadValueError(
            f"family {family!r}: parameter {name!r} must be finite, got {arr.max():g}; for a "
            "light without a range, use a family without a window (e.g. inverse_square)"
        )
    bad = None
    if kind == "positive" and np.any(arr <= 0):
        bad = "> 0"
    elif kind == "nonnegative" and np.any(arr < 0):
        bad = ">= 0"
    elif kind == "unit" and np.any((arr <= 0) | (arr >= 1)):
        bad = "strictly between 0 and 1"
    if bad is not None:
        shown = arr.item() if arr.ndim == 0 else arr.tolist()
        raise BadValueError(f"family {family!r}: parameter {name!r} must be {bad}, got {shown}")


def _check_shape(family: str, name: str, value: Any, default: Any) -> None:
    """A parameter with a vector default (a spline's knots) keeps that length (a batch may
    add leading axes)."""
    try:
        want, got = np.shape(default), np.shape(value)
    except Exception:
        return  # an unusual leaf (an abstract placeholder): the maths will tell
    if want and got[len(got) - len(want) :] != want:
        raise BadValueError(
            f"family {family!r}: parameter {name!r} must have shape {want} (or a batch of "
            f"them), got shape {got}"
        )


def _param_fields(cls: type) -> list[dataclasses.Field]:
    """The dataclass fields of `cls` that are parameters (not `eqx.field(static=True)`)."""
    return [f for f in dataclasses.fields(cls) if not f.metadata.get("static", False)]


def _plain(value: Any) -> Any:
    """A JSON-friendly copy of a parameter value."""
    arr = np.asarray(value)
    return arr.item() if arr.ndim == 0 else arr.tolist()


def _plain_fact(value: Any) -> Any:
    """A JSON-friendly copy of a class fact (tuples as lists)."""
    return list(value) if isinstance(value, tuple) else value
