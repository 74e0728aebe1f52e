"""The abstract `Family` base and the registry of named families."""

import abc
import dataclasses
import functools
import inspect
from collections.abc import Callable, Mapping
from typing import Any, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadTypeError, BadValueError, UnknownNameError

__all__ = [
    "Family",
    "Out",
    "Param",
    "family_from_function",
    "float32_family",
    "get_family",
    "jit_call",
    "list_families",
    "register_family",
]

#: The kinds of constraint a parameter can carry (see `Family.constraints`).
CONSTRAINTS = ("positive", "nonnegative", "unit", "real")


class Family(eqx.Module):
    """A differentiable, parameterised attenuation curve `f(d)`, in 1/length^2.

    `d` is the distance from the light's centre (docs/architecture.md, Conventions). A point light of
    intensity `I` gives irradiance `E = I * g * f(d) * max(0, n.l)`. A family's fields are
    its parameters (scalars, or arrays with a leading batch axis for `fit_many`); calling
    it broadcasts over `d` and returns the dtype of `d` when `d` is a float array (else the
    widest float dtype of the parameters, else JAX's default float). Every family is `jit`-, `vmap`- and `grad`-able and constructs with no
    arguments.

    Subclasses are final: they declare their parameters as fields with defaults, the class
    variables below, and `__call__`.
    """

    #: Registry name, e.g. ``"yuksel"``.
    name: eqx.AbstractClassVar[str]
    #: The formula as text, in the stable form the code evaluates.
    formula: eqx.AbstractClassVar[str]
    #: Citation: paper and equation, or engine file and function.
    source: eqx.AbstractClassVar[str]
    #: Parameters a fit frees when the caller does not say (`fit(..., free=None)`).
    default_free: eqx.AbstractClassVar[tuple[str, ...]]

    # Declared properties, checked for every family by the generic test suite.
    #: Parameter -> one of "positive" (the default), "nonnegative" (0 allowed and reachable
    #: by a fit), "unit" (strictly between 0 and 1), "real" (unconstrained).
    constraints: ClassVar[Mapping[str, str]] = {}
    #: True for the two honestly singular families (`inverse_square`, `gltf_range`).
    singular: ClassVar[bool] = False
    #: Name of the parameter at which the curve reaches 0 (a window's range), if any.
    range_param: ClassVar[str | None] = None
    #: "smooth": value and slope reach 0 at the range; "hard": the value does; "none".
    window: ClassVar[str] = "none"
    #: Non-increasing in `d` for every parameter value.
    monotone: ClassVar[bool] = True
    #: `f(d) * d^2 -> 1` as `d / (length scale) -> inf` (physically motivated families).
    tends_to_inverse_square: ClassVar[bool] = False
    #: Parameters with units of length: under d -> s d and p -> s p for each of them, the
    #: curve scales as f -> f / s^2 (or is unchanged for a family with a free `scale`).
    length_params: ClassVar[tuple[str, ...]] = ()
    #: Powers of length of the other dimensional parameters (e.g. ``{"eps": 2}`` for an area,
    #: ``{"scale": -2}`` for a free scale in 1/length^2); unlisted ones are dimensionless.
    units: ClassVar[Mapping[str, int]] = {}
    #: True when the curve obeys the scale law exactly: under d -> s d and every parameter
    #: p -> s^(its length power) p, f -> f / s^2. False for families with a hard-coded absolute
    #: length (Godot's 1e-4 m clamp, three.js's 0.01 floor) or fixed knots (`spline`).
    scale_covariant: ClassVar[bool] = False

    def __check_init__(self):
        """Refuse concrete parameter values that break their constraint (tracers pass)."""
        defaults = self.defaults()
        for name in self.param_names():
            value = getattr(self, name)
            _check_param(type(self).name, name, value, self.constraint(name))
            _check_shape(type(self).name, name, value, defaults[name])

    @abc.abstractmethod
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        """Evaluate `f(d)`."""

    def range_distance(self) -> Any:
        """The centre distance at which the curve reaches 0 for good, or None (no range).

        The value of `range_param` unless a family says otherwise (Madams' warped families
        measure their `d_max` from the light's surface, `madams_cutoff` derives its range).
        """
        return None if self.range_param is None else getattr(self, self.range_param)

    @classmethod
    def length_power(cls, param: str) -> int:
        """The power of length in the unit of `param` (1 for `length_params`, else `units`)."""
        cls.constraint(param)  # raises on an unknown name
        return 1 if param in cls.length_params else int(cls.units.get(param, 0))

    @classmethod
    def param_names(cls) -> tuple[str, ...]:
        """The parameter names, in field order (static fields are options, not parameters)."""
        return tuple(f.name for f in _param_fields(cls))

    @classmethod
    def defaults(cls) -> dict[str, Any]:
        """The default parameter values."""
        return {
            f.name: f.default if f.default is not dataclasses.MISSING else f.default_factory()
            for f in _param_fields(cls)
        }

    @classmethod
    def constraint(cls, param: str) -> str:
        """The constraint of `param` ("positive" unless `constraints` says otherwise)."""
        if param not in cls.param_names():
            raise UnknownNameError(
                f"family {cls.name!r} has no parameter {param!r}; it has {list(cls.param_names())}"
            )
        return cls.constraints.get(param, "positive")

    def params(self) -> dict[str, Any]:
        """The parameter values, by name."""
        return {name: getattr(self, name) for name in self.param_names()}

    def replace(self, **values: Any) -> "Family":
        """A copy with some parameters replaced."""
        names = self.param_names()
        for key in values:
            if key not in names:
                raise UnknownNameError(
                    f"family {self.name!r} has no parameter {key!r}; it has {list(names)}"
                )
        return dataclasses.replace(self, **values)

    @classmethod
    def describe(cls) -> dict[str, Any]:
        """Name, formula, source, parameters with defaults and constraints, and properties."""
        return {
            "name": cls.name,
            "formula": cls.formula,
            "source": cls.source,
            "params": {
                p: {"default": _plain(v), "constraint": cls.constraint(p)}
                for p, v in cls.defaults().items()
            },
            "default_free": list(cls.default_free),
            "singular": cls.singular,
            "range_param": cls.range_param,
            "window": cls.window,
            "monotone": cls.monotone,
            "tends_to_inverse_square": cls.tends_to_inverse_square,
            "length_params": list(cls.length_params),
        }


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


_REGISTRY: dict[str, type[Family]] = {}


def register_family(cls: type[Family] | None = None, *, overwrite: bool = False):
    """Add a `Family` subclass to the registry under its `name` (usable as a decorator).

    The class must be a concrete subclass of `Family` that constructs with no arguments;
    a name already taken is refused unless `overwrite=True`.
    """

    def add(klass: type[Family]) -> type[Family]:
        if not (inspect.isclass(klass) and issubclass(klass, Family)):
            raise BadTypeError(
                f"register_family takes a subclass of attenfit.Family, got {klass!r}"
            )
        if inspect.isabstract(klass):
            missing = sorted(getattr(klass, "__abstractmethods__", ()))
            raise BadTypeError(f"family class {klass.__name__} is abstract (missing {missing})")
        name = getattr(klass, "name", None)
        if not isinstance(name, str) or not name.isidentifier():
            raise BadValueError(
                f"family class {klass.__name__} needs a class attribute `name` that is an identifier, got {name!r}"
            )
        if name in _REGISTRY and _REGISTRY[name] is not klass and not overwrite:
            raise BadValueError(
                f"a family named {name!r} is registered already; pass overwrite=True to replace it"
            )
        for param in klass.default_free:
            klass.constraint(param)  # raises on an unknown name
        for param, kind in klass.constraints.items():
            if kind not in CONSTRAINTS:
                raise BadValueError(
                    f"family {name!r}: constraint {kind!r} of {param!r} is not one of {list(CONSTRAINTS)}"
                )
        try:
            klass()
        except Exception as exc:
            raise BadValueError(f"family {name!r} must construct with no arguments: {exc}") from exc
        _REGISTRY[name] = klass
        return klass

    return add if cls is None else add(cls)


def family_from_function(
    fn: Callable[..., Any],
    *,
    name: str,
    defaults: Mapping[str, Any],
    formula: str,
    source: str,
    default_free: tuple[str, ...] | None = None,
    register: bool = False,
    **properties: Any,
) -> type[Family]:
    """Make a `Family` class from a plain function ``fn(d, **params) -> f``.

    `defaults` gives the parameters (their order and default values); the remaining class
    variables (`constraints`, `singular`, `range_param`, `window`, `monotone`,
    `tends_to_inverse_square`, `length_params`, `units`, `scale_covariant`) may be passed as
    keywords. `default_free` defaults to every parameter. `fn` receives `d` and the parameters
    as given (call `attenfit.parts.promote` inside it to share one dtype). With
    ``register=True`` the class is also registered (see `register_family`).
    """
    if not callable(fn):
        raise BadTypeError(f"family_from_function takes a callable, got {fn!r}")
    allowed = {
        "constraints", "singular", "range_param", "window", "monotone",
        "tends_to_inverse_square", "length_params", "units", "scale_covariant",
    }  # fmt: skip
    unknown = sorted(set(properties) - allowed)
    if unknown:
        raise UnknownNameError(
            f"family_from_function: unknown properties {unknown}; allowed: {sorted(allowed)}"
        )
    params = dict(defaults)
    for p in params:
        if not (isinstance(p, str) and p.isidentifier()):
            raise BadValueError(f"family_from_function: parameter name {p!r} is not an identifier")

    def __call__(self, d):
        return fn(d, **{p: getattr(self, p) for p in params})

    namespace: dict[str, Any] = {
        "__annotations__": dict.fromkeys(params, Any),
        **params,
        "__call__": __call__,
        "__doc__": fn.__doc__ or f"{name}: {formula} ({source})",
        "__module__": getattr(fn, "__module__", __name__),
        "name": name,
        "formula": formula,
        "source": source,
        "default_free": tuple(params) if default_free is None else tuple(default_free),
        **properties,
    }
    klass = type(name.title().replace("_", ""), (Family,), namespace)
    return register_family(klass) if register else klass


def list_families() -> list[str]:
    """The registered family names, in registration order."""
    return list(_REGISTRY)


def get_family(name: str) -> type[Family]:
    """The family class registered as `name`."""
    if not isinstance(name, str):
        raise BadTypeError(f"family name must be a string, got {name!r}")
    try:
        return _REGISTRY[name]
    except KeyError:
        raise UnknownNameError(
            f"unknown family {name!r}; known families: {', '.join(_REGISTRY)}"
        ) from None


#: A parameter: a scalar, or an array with a leading batch axis (`fit_many`).
Param = Float[ArrayLike, "*batch"]
#: A family's output, shaped like `d`.
Out = Float[Array, "*shape"]


def jit_call(call):
    """Compile a family's `__call__` once per shape and dtype (not per parameter value).

    Parameters and `d` are turned into arrays first (Python numbers stay weakly typed), so
    `eqx.filter_jit` traces them instead of baking their values in; inside a caller's own
    `jit`/`vmap`/`grad` this is simply inlined. Eager calls then cost one dispatch instead of
    one per primitive.
    """
    jitted = eqx.filter_jit(call)

    @functools.wraps(call)
    def wrapper(self, d):
        self = jax.tree_util.tree_map(jnp.asarray, self)
        return jitted(self, jnp.asarray(d))

    return wrapper


Out = Float[Array, "*shape"]


def float32_family(family: Family) -> Family:
    """`family` with every floating parameter leaf as a float32 array."""

    def cast(x: Any) -> Any:
        if isinstance(x, float) or (
            hasattr(x, "dtype") and np.issubdtype(np.dtype(x.dtype), np.floating)
        ):
            return jnp.asarray(x, jnp.float32)
        return x

    return jax.tree.map(cast, family)
