"""The abstract `Family` (a `Model` of the distance alone) and the registry of named families."""

import abc
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
from . import _parts as parts
from ._model_base import Model, no_shader_form

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

#: How a light's range R (the centre distance where the curve reaches 0 for good) sets the
#: parameter `Family.range_tie` names, where it is not R itself (`range_param`): the value
#: from (R, r) and R from (value, r), `r` the family's `r` parameter (the light's radius).
RANGE_TIES: dict[str, tuple[Callable[[Any, Any], Any], Callable[[Any, Any], Any]]] = {
    # measured from the light's surface: p = R - r (Madams 2011b's d_max)
    "surface": (lambda R, r: R - r, lambda p, r: r + p),
    # an irradiance cutoff relative to the value at the surface, a = r^2/d^2 reaching p at
    # d = R: p = (r/R)^2 (Madams 2011's scale and bias)
    "cutoff": (lambda R, r: (r / R) ** 2, lambda p, r: r / jnp.sqrt(p)),
}


class Family(Model):
    """A differentiable, parameterised attenuation curve `f(d)`, in 1/length^2.

    `d` is the distance from the light's centre (docs/architecture.md, Conventions). A point light of
    intensity `I` gives irradiance `E = I * g * f(d) * max(0, n.l)`. A family's fields are
    its parameters (scalars, or arrays with a leading batch axis for `fit_many`); calling
    it broadcasts over `d` and returns the dtype of `d` when `d` is a float array (else the
    widest float dtype of the parameters, else JAX's default float). Every family is `jit`-, `vmap`- and `grad`-able and constructs with no
    arguments.

    Subclasses are final: they declare their parameters as fields with defaults, the class
    variables below (and `Model`'s), `__call__` and `shader_form` (``shader_form =
    no_shader_form`` where there is none).
    """

    kind = "family"
    inputs = 0
    described = (
        "singular", "range_param", "window", "monotone", "tends_to_inverse_square",
        "length_params",
    )  # fmt: skip

    # Declared properties, checked for every family by the generic test suite.
    #: True for the two honestly singular families (`inverse_square`, `gltf_range`).
    singular: ClassVar[bool] = False
    #: "smooth": value and slope reach 0 at the range; "hard": the value does; "none".
    window: ClassVar[str] = "none"
    #: Non-increasing in `d` for every parameter value.
    monotone: ClassVar[bool] = True
    #: `f(d) * d^2 -> 1` as `d / (length scale) -> inf` (physically motivated families).
    tends_to_inverse_square: ClassVar[bool] = False
    #: True when the curve obeys the scale law exactly: under d -> s d and every parameter
    #: p -> s^(its length power) p, f -> f / s^2. False for families with a hard-coded absolute
    #: length (Godot's 1e-4 m clamp, three.js's 0.01 floor) or fixed knots (`spline`).
    scale_covariant: ClassVar[bool] = False
    #: `(parameter, rule)`: the parameter a light's range sets where it is not the range
    #: itself, and how (a rule of `RANGE_TIES`); None: `range_param` is the range.
    range_tie: ClassVar[tuple[str, str] | None] = None
    #: Parameter -> `(c, k)`: "as published" for a light of radius r the parameter is c r^k
    #: (a light's radius `r`: ``(1.0, 1)``); unlisted parameters keep their defaults.
    at_radius: ClassVar[Mapping[str, tuple[float, int]]] = {}
    #: The parameter holding `ln f` at the static `knots` of an authored curve (`spline`):
    #: no published values; a light's start is a facing disk's curve there.
    knots_param: ClassVar[str | None] = None
    #: The parameter p of a clamped distance, f(d) = g(d) / max(d, p)^2 with g free of p
    #: (RTR4 eq. 5.13's clamp): a fit that frees it alone starts at its exact optimum
    #: (`attenfit._fit._guess.clamp_candidate`); None: no such parameter.
    clamp_param: ClassVar[str | None] = None

    @abc.abstractmethod
    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        """Evaluate `f(d)`."""

    def evaluate(self, x: Float[ArrayLike, " n"]) -> Float[Array, " n"]:
        """`f(d)` at the samples' distances (what a fit evaluates)."""
        return self(x)

    @classmethod
    def range_setter(cls) -> str | None:
        """The parameter a light's range sets (`range_tie`'s, else `range_param`), or None."""
        return cls.range_param if cls.range_tie is None else cls.range_tie[0]

    @classmethod
    def range_value(cls, R: Any, r: Any) -> Any:
        """The value of `range_setter()` for a range R (centre distance) and radius r."""
        return R if cls.range_tie is None else RANGE_TIES[cls.range_tie[1]][0](R, r)

    def range_distance(self) -> Any:
        """The centre distance at which the curve reaches 0 for good, or None (no range).

        The value of `range_param`, or what `range_tie` derives it from (Madams' warped
        families measure their `d_max` from the light's surface, `madams_cutoff` has an
        irradiance cutoff).
        """
        cls = type(self)
        if cls.range_tie is None:
            return None if cls.range_param is None else getattr(self, cls.range_param)
        param, rule = cls.range_tie
        p, r = parts.promote(getattr(self, param), self.r)
        return RANGE_TIES[rule][1](p, r)


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
            hint = (
                "; a family without a shader form says `shader_form = attenfit.no_shader_form`"
                if "shader_form" in missing
                else ""
            )
            raise BadTypeError(
                f"family class {klass.__name__} is abstract (missing {missing}){hint}"
            )
        name = getattr(klass, "name", None)
        if not isinstance(name, str) or not name.isidentifier():
            raise BadValueError(
                f"family class {klass.__name__} needs a class attribute `name` that is an identifier, got {name!r}"
            )
        if name in _REGISTRY and _REGISTRY[name] is not klass and not overwrite:
            raise BadValueError(
                f"a family named {name!r} is registered already; pass overwrite=True to replace it"
            )
        klass.check_class()
        _check_family_facts(klass)
        try:
            klass()
        except Exception as exc:
            raise BadValueError(f"family {name!r} must construct with no arguments: {exc}") from exc
        _REGISTRY[name] = klass
        return klass

    return add if cls is None else add(cls)


def _check_family_facts(cls: type[Family]) -> None:
    """Raise unless the range and start facts of `cls` name its parameters."""
    names = cls.param_names()
    if cls.range_tie is not None:
        param, rule = cls.range_tie
        if param not in names or "r" not in names or rule not in RANGE_TIES:
            raise BadValueError(
                f"family {cls.name!r}: range_tie {cls.range_tie!r} needs the parameters "
                f"{param!r} and 'r', and a rule of {list(RANGE_TIES)}"
            )
    for param in cls.at_radius:
        cls.constraint(param)  # raises on an unknown name
    if cls.clamp_param is not None and cls.constraint(cls.clamp_param) != "positive":
        raise BadValueError(
            f"family {cls.name!r}: clamp_param {cls.clamp_param!r} must be a positive parameter"
        )


def family_from_function(
    fn: Callable[..., Any],
    *,
    name: str,
    defaults: Mapping[str, Any],
    formula: str,
    source: str,
    default_free: tuple[str, ...] | None = None,
    register: bool = False,
    shader_form: Callable[[Family], Any] | None = None,
    **properties: Any,
) -> type[Family]:
    """Make a `Family` class from a plain function ``fn(d, **params) -> f``.

    `defaults` gives the parameters (their order and default values); the remaining class
    variables (`constraints`, `singular`, `range_param`, `window`, `monotone`,
    `tends_to_inverse_square`, `length_params`, `units`, `scale_covariant`, `range_tie`,
    `at_radius`, `inverse_linear`, `knots_param`, `clamp_param`) may be passed as keywords. `default_free`
    defaults to every parameter. `fn` receives `d` and the parameters as given (call
    `attenfit.parts.promote` inside it to share one dtype). `shader_form(self) ->
    ShaderForm` is the class's shader form (default: none, `no_shader_form`). With
    ``register=True`` the class is also registered (see `register_family`).
    """
    if not callable(fn):
        raise BadTypeError(f"family_from_function takes a callable, got {fn!r}")
    allowed = {
        "constraints", "singular", "range_param", "window", "monotone",
        "tends_to_inverse_square", "length_params", "units", "scale_covariant", "range_tie",
        "at_radius", "inverse_linear", "knots_param", "clamp_param",
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
        "shader_form": no_shader_form if shader_form is None else shader_form,
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


def float32_family(family: Family) -> Family:
    """`family` with every floating parameter leaf as a float32 array."""

    def cast(x: Any) -> Any:
        if isinstance(x, float) or (
            hasattr(x, "dtype") and np.issubdtype(np.dtype(x.dtype), np.floating)
        ):
            return jnp.asarray(x, jnp.float32)
        return x

    return jax.tree.map(cast, family)
