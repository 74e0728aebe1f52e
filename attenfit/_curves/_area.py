"""Area-light models: irradiance approximations that read the receiver's geometry, not only `d`.

A family predicts `E = I g f(d) max(0, n.l)`: its error on a tilted receiver, or where the
light straddles the receiver's horizon, lies in the angular factor, which no `f(d)` reaches.
An area model predicts `E / I` from the geometry the engines' area-light code reads
(docs/area.md), the `AreaInputs`:

* `d`: the distance from the receiver to the light's centre (capsule: to its segment);
* `cos_r = n.l`: the cosine at the receiver, `l` the unit vector to the centre;
* `cos_e = m.(p - c)/d`: the cosine at the emitter (a disk's normal `m`; 1 for a sphere);
* `r`: the light's radius;
* `cos_n = -n.m`: the receiver's normal against the disk's (1 when they face each other,
  as a floor under a downlight); a sphere is read as the disk that faces the receiver,
  `cos_n = cos_r`. Only the exact disk needs it: the vector irradiance of a disk is linear
  in `n`, with a component along `m` that `cos_r` alone does not give;
* `g`: the point-light model's emitter factor (1 for a sphere, `max(0, cos_e)` for a
  one-sided disk, a capsule's projected-area factor); sphere-shaped models multiply by it,
  so that a capsule is shaded as the sphere at its closest point, as the point light is.

The distance families are the special case `PointLight(family)`: `g f(d) max(0, cos_r)`.
Each model's `shader_form` is its expression in a shader, of `_forms.AREA_FORM_INPUTS` and
the light's radius (the parameter `radius`).
Every model is a final `eqx.Module` (a `Model`, `_model_base`) whose fields are its
parameters, registered by name, `jit`-, `vmap`- and `grad`-able, in the dtype of `d`.
"""

import abc
import functools
import math
from typing import Any, ClassVar, NamedTuple

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadTypeError, BadValueError, UnknownNameError
from .._ir import Ref, ShaderForm, fn
from . import _parts as parts
from ._family import Family
from ._forms import AREA_FORM_INPUTS
from ._model_base import Model
from ._softened import InverseSquare

__all__ = [
    "AREA_INPUTS",
    "RECT_INPUTS",
    "TUBE_INPUTS",
    "AreaInputs",
    "AreaModel",
    "PointLight",
    "cone_cosine",
    "get_area_model",
    "list_area_models",
    "point_light_class",
    "register_area_model",
]

#: The inputs of the sphere, disk and point-light models, in the order `AreaInputs` holds
#: them (the default `AreaModel.input_names`).
AREA_INPUTS = ("d", "cos_r", "cos_e", "r", "cos_n", "g")
#: The inputs of a rectangle's models: the receiver's point (x, y, z) and unit normal
#: (nx, ny, nz) in the light's frame (its centre the origin, x along its width, z its normal,
#: y = z cross x), and its half width `hw` and half height `hh`
#: (`attenfit._truth.model_inputs`).
RECT_INPUTS = ("x", "y", "z", "nx", "ny", "nz", "hw", "hh")
#: The inputs of a tube's models: the receiver's point and unit normal in the tube's frame
#: (its centre the origin, x along its axis), its half length `hl` and its radius `r`.
TUBE_INPUTS = ("x", "y", "z", "nx", "ny", "nz", "hl", "r")
#: The range check of each input (`attenfit._fit` refuses inputs outside it), by name.
INPUT_RANGES: dict[str, str] = {
    "d": "nonnegative", "cos_r": "cosine", "cos_e": "cosine", "r": "positive",
    "cos_n": "cosine", "g": "nonnegative", "nx": "cosine", "ny": "cosine", "nz": "cosine",
    "hw": "positive", "hh": "positive", "hl": "positive",
}  # fmt: skip

#: What each of `AREA_INPUTS` is, and its unit (`AreaModel.input_text`).
AREA_INPUT_TEXT: dict[str, str] = {
    "d": "distance from the receiver to the light's centre (a capsule: to its segment); length",
    "cos_r": "n.l, the cosine at the receiver (l: the unit vector to the light's centre); 1",
    "cos_e": "m.(p - c)/d, the cosine at the emitter (m: a disk's normal; 1 for a sphere); 1",
    "r": "the light's radius; length (the unit of d)",
    "cos_n": "-n.m, the receiver's normal against a disk's axis (a sphere: cos_r); 1",
    "g": "the emitter factor (1 for a sphere, max(0, cos_e) for a one-sided disk); 1",
}

Real = Float[Array, "*shape"]


class AreaInputs(NamedTuple):
    """The receiver geometry an area model reads (see the module docstring), arrays of one shape."""

    d: Float[ArrayLike, "*shape"]
    cos_r: Float[ArrayLike, "*shape"]
    cos_e: Float[ArrayLike, "*shape"]
    r: Float[ArrayLike, "*shape"]
    cos_n: Float[ArrayLike, "*shape"]
    g: Float[ArrayLike, "*shape"]

    def stack(self) -> Float[Array, " 6 *shape"]:
        """The six inputs as one array, inputs first (what the fit stage passes as `d`)."""
        return jnp.stack(jnp.broadcast_arrays(*(jnp.asarray(x) for x in self)))

    def take(self, index: Any) -> "AreaInputs":
        """The inputs of the receivers `index` selects."""
        return AreaInputs(*(jnp.asarray(x)[index] for x in self))


# ----------------------------------------------------------------------------- horizon parts
_SERIES_AT = 0.3
#: atan(x) - x = -x^3 (1/3 - x^2/5 + x^4/7 - ...): 16 terms are exact to rounding below 0.3
_ATAN_TAIL = tuple((-1.0) ** (k + 1) / (2 * k + 3) for k in range(16))


def _atan_minus_identity(x: Real) -> Real:
    """atan(x) - x for x >= 0, by its series below 0.3 (where the difference cancels)."""
    near = x < _SERIES_AT
    xs = jnp.where(near, x, jnp.zeros_like(x))
    x2 = xs * xs
    acc = jnp.zeros_like(x) + _ATAN_TAIL[-1]
    for coefficient in reversed(_ATAN_TAIL[:-1]):
        acc = coefficient + x2 * acc
    far = jnp.where(near, jnp.ones_like(x), x)
    return jnp.where(near, xs * x2 * acc, jnp.arctan(far) - far)


def safe_sqrt(x: Real) -> Real:
    """sqrt(max(x, 0)) with a gradient of 0 (not inf or NaN) at and below 0."""
    pos = x > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, x, jnp.ones_like(x))), jnp.zeros_like(x))


def cone_cosine(cos_t: Real, sin2: Real) -> Real:
    """The irradiance of a uniform cone over its unclipped facing value: `K / (pi sin^2 a)`.

    A uniform-radiance cone of half-angle `a` (`sin2 = sin^2 a`, in (0, 1]) seen at angle `t`
    from the receiver's normal gives `E = L K(cos t, sin a)` (Snyder 1996; Frostbite 2014
    section 4.7.2.4 `illuminanceSphereOrDisk`; Howell B-43), `K = pi sin^2 a cos t` while the
    cone is above the horizon, 0 once below it, and in between (docs/ground-truth.md §2)
    `K = sin^2 a cos t atan2(g, -cos a cos t) - g cos a + atan2(g, cos a)`,
    `g = sqrt(sin^2 a - cos^2 t)`. The result is `cos t` while unclipped: the factor a
    sphere's or a facing disk's irradiance carries in place of `max(0, n.l)`.

    Stable form: for `x = g / cos a < 0.3` the last two terms are `(atan x - x) + x sin^2 a`
    and, for `cos t < 0`, the first two `-sin^2 a |cos t| (atan u - u)`, `u = g/(cos a |cos t|)`,
    each by its series. Finite gradients everywhere (double `where`).
    """
    s2 = jnp.clip(sin2, 0, 1)
    s = safe_sqrt(s2)
    up = cos_t >= s
    down = cos_t <= -s
    clipped = ~(up | down)
    c = jnp.where(clipped, cos_t, jnp.zeros_like(cos_t))
    s2c = jnp.where(clipped, s2, jnp.full_like(s2, 0.5))
    sc = jnp.sqrt(s2c)
    ca = safe_sqrt(1 - s2c)
    g = safe_sqrt((sc - c) * (sc + c))
    phi = jnp.arctan2(g, -ca * c)
    contact = ca <= 0
    x = g / jnp.where(contact, jnp.ones_like(ca), ca)
    x_small = (x < _SERIES_AT) & ~contact
    # atan2(g, cos a) - g cos a, written without its cancellation where x is small
    tail = jnp.where(
        x_small,
        _atan_minus_identity(jnp.where(x_small, x, jnp.zeros_like(x))) + x * s2c,
        jnp.arctan2(g, ca) - g * ca,
    )
    k = s2c * c * phi + tail
    neg = c < 0
    u = g / jnp.where(neg & ~contact, ca * -c, jnp.ones_like(c))
    u_small = x_small & neg & (u < _SERIES_AT)
    uu = jnp.where(u_small, u, jnp.zeros_like(u))
    k_neg = _atan_minus_identity(jnp.where(x_small, x, jnp.zeros_like(x))) + s2c * c * (
        _atan_minus_identity(uu)
    )
    k = jnp.maximum(jnp.where(u_small, k_neg, k), 0)
    clip_value = k / (math.pi * s2c)
    return jnp.where(up, cos_t, jnp.where(down, jnp.zeros_like(cos_t), clip_value))


def contact_distance(d: Real, r: Real) -> Real:
    """`max(d, r)`: a receiver inside a sphere's radius is read as touching it (as Frostbite's
    `sinSigmaSqr <= 0.9999` clamp does)."""
    return jnp.where(d > r, d, r)


# ----------------------------------------------------------------------------- the base
class AreaModel(Model):
    """An area-light irradiance model: `E / I` from the receiver geometry (`AreaInputs`).

    Subclasses are final: parameters as fields with defaults, the class variables below (and
    `Model`'s), and `irradiance`. Calling a model, `model(d, cos_r, cos_e, r, cos_n=None,
    g=None)`, fills the defaults (`cos_n`: the receiver's normal turned toward the light's
    axis in the plane of `l` and the axis, `cos(theta_r - theta_e)`; `g`: `max(0, cos_e)`),
    broadcasts, and returns `E / I` in 1/length^2 in the dtype of `d`.
    """

    kind = "area model"
    #: The per-receiver inputs it reads, in order (`AREA_INPUTS`, `RECT_INPUTS`,
    #: `TUBE_INPUTS`): the rows of `evaluate`'s stacked inputs and `irradiance`'s arguments.
    input_names: ClassVar[tuple[str, ...]] = AREA_INPUTS
    inputs = len(AREA_INPUTS)
    #: The per-receiver inputs of its shader form (`_forms.area_form`), and the light's size
    #: as the form's parameters, each with the input it reads (`radius`: `r`).
    form_inputs: ClassVar[tuple[str, ...]] = AREA_FORM_INPUTS
    form_sizes: ClassVar[dict[str, str]] = {"radius": "r"}
    #: What each of its inputs is, and its unit, by name (the header `attenfit export` prints).
    input_text: ClassVar[dict[str, str]] = AREA_INPUT_TEXT
    #: What it returns, in words (the header's `output` line): `E / I` and the `I` it
    #: divides by, in its own light's size names.
    output_text: ClassVar[str] = (
        "E / I in 1/length^2 (I: the light's point-equivalent intensity, I = pi r^2 L; "
        "docs/architecture.md, Conventions)"
    )
    described = ("light", "exact")

    #: The lights it is written for: "sphere" (spheres, and capsules at their closest point
    #: times `g`), "disk", "rect", "tube", or "any".
    light: ClassVar[str] = "sphere"
    #: Where it is exact, in words ("" where nowhere).
    exact: ClassVar[str] = ""

    @abc.abstractmethod
    def irradiance(self, *x: Real) -> Real:
        """`E / I` from inputs of one dtype and shape, one per `input_names` (called by
        `__call__`; `AREA_INPUTS`: `d, cos_r, cos_e, r, cos_n, g`)."""

    def __call__(
        self,
        *x: Float[ArrayLike, "*shape"] | None,
        cos_n: Float[ArrayLike, "*shape"] | None = None,
        g: Float[ArrayLike, "*shape"] | None = None,
    ) -> Float[Array, "*shape"]:
        """`E / I` at receivers with this geometry (1/length^2): one array per `input_names`
        (`AREA_INPUTS`: `d, cos_r, cos_e, r, cos_n=None, g=None`, see the class docstring)."""
        names = type(self).input_names
        if names != AREA_INPUTS:
            if len(x) != len(names) or any(v is None for v in x):
                raise BadValueError(
                    f"area model {self.name!r} reads {len(names)} inputs ({', '.join(names)}), "
                    f"got {len(x)}"
                )
            return _evaluate(self, *parts.promote(*x))
        if not 4 <= len(x) <= 6:
            raise BadValueError(f"area model {self.name!r} reads d, cos_r, cos_e, r[, cos_n, g]")
        d, cos_r, cos_e, r = parts.promote(*x[:4])
        cos_n = x[4] if len(x) > 4 else cos_n
        g = x[5] if len(x) > 5 else g
        if cos_n is None:
            sin_r = safe_sqrt((1 - cos_r) * (1 + cos_r))
            sin_e = safe_sqrt((1 - cos_e) * (1 + cos_e))
            cos_n = cos_r * cos_e + sin_r * sin_e
        if g is None:
            g = jnp.maximum(cos_e, 0)
        return _evaluate(self, d, cos_r, cos_e, r, jnp.asarray(cos_n), jnp.asarray(g))

    def evaluate(self, x: Float[ArrayLike, " k *shape"]) -> Float[Array, "*shape"]:
        """`E / I` from the stacked inputs (`AreaInputs.stack()`), rows in `input_names` order."""
        x = np.asarray(x) if not isinstance(x, jax.core.Tracer) else x  # rows sliced on the host
        return self(*(x[k] for k in range(len(type(self).input_names))))


def _call(model: AreaModel, *x):
    if type(model).input_names != AREA_INPUTS:  # a frame's inputs: the model clamps them
        xs = jnp.broadcast_arrays(*parts.promote(*x))
        return parts.keep_nan(xs[0], model.irradiance(*xs).astype(xs[0].dtype))
    d, cos_r, cos_e, r, cos_n, g = parts.promote(*x)
    d, cos_r, cos_e, r, cos_n, g = jnp.broadcast_arrays(d, cos_r, cos_e, r, cos_n, g)
    out = model.irradiance(parts.distance(d), jnp.clip(cos_r, -1, 1), jnp.clip(cos_e, -1, 1), r,
                           jnp.clip(cos_n, -1, 1), g)  # fmt: skip
    return parts.keep_nan(d, out.astype(d.dtype))


_jitted = eqx.filter_jit(_call)


def _evaluate(model: AreaModel, *inputs: Array) -> Array:
    """The model at the inputs, compiled once per model structure, shapes and dtype."""
    return _jitted(jax.tree_util.tree_map(jnp.asarray, model), *inputs)


# ----------------------------------------------------------------------------- registry
_REGISTRY: dict[str, type[AreaModel]] = {}


def register_area_model(cls: type[AreaModel]) -> type[AreaModel]:
    """Add an `AreaModel` subclass to the registry under its `name` (a decorator)."""
    if not (isinstance(cls, type) and issubclass(cls, AreaModel)):
        raise BadTypeError(f"register_area_model takes a subclass of AreaModel, got {cls!r}")
    name = getattr(cls, "name", None)
    if not isinstance(name, str) or not name.isidentifier():
        raise BadValueError(f"area model {cls.__name__} needs a `name` that is an identifier")
    if name in _REGISTRY and _REGISTRY[name] is not cls:
        raise BadValueError(f"an area model named {name!r} is registered already")
    cls.check_class()
    if cls.light not in ("sphere", "disk", "rect", "tube", "any"):
        raise BadValueError(f"area model {name!r}: light must be sphere, disk, rect, tube or any")
    if cls.inputs != len(cls.input_names):
        raise BadValueError(f"area model {name!r}: inputs must be len(input_names)")
    untold = [x for x in cls.input_names if x not in cls.input_text]
    if untold:
        raise BadValueError(f"area model {name!r}: input_text does not say what {untold} are")
    cls()  # constructs with no arguments
    _REGISTRY[name] = cls
    return cls


def list_area_models() -> list[str]:
    """The registered area models, in registration order."""
    return list(_REGISTRY)


def get_area_model(name: str) -> type[AreaModel]:
    """The area model class registered as `name`."""
    if not isinstance(name, str):
        raise BadTypeError(f"area model name must be a string, got {name!r}")
    try:
        return _REGISTRY[name]
    except KeyError:
        raise UnknownNameError(
            f"unknown area model {name!r}; known: {', '.join(_REGISTRY)}"
        ) from None


# ----------------------------------------------------------------------------- point light
_ModuleMeta = type(eqx.Module)


class _PointLightMeta(_ModuleMeta):
    """`PointLight(family)` builds the point-light model of `type(family)`: one final class
    per family class, whose class facts are the family's (`point_light_class`)."""

    def __call__(cls, family: Family | None = None):
        target = cls
        if cls is PointLight:
            if family is None:
                family = InverseSquare()
            if not isinstance(family, Family):
                raise BadTypeError(
                    f"PointLight takes a Family instance, got {type(family).__name__}"
                )
            target = point_light_class(type(family))
        return _ModuleMeta.__call__(target, family)


class PointLight(AreaModel, metaclass=_PointLightMeta):
    """The point-light model as an area model: `E / I = g f(d) max(0, cos_r)`.

    Every distance family is this special case: its angular part is `max(0, n.l)` times the
    emitter factor `g`, whatever `f`. Its parameters are the family's (`family`, default
    `InverseSquare()`, the exact facing curve of a sphere); it is exact wherever the light
    is wholly above the horizon and `f` is the light's exact facing attenuation at that
    receiver's orientation (a sphere: any such receiver; a disk: coaxial facing ones).

    Abstract: `PointLight(family)` is an instance of `point_light_class(type(family))`, a
    final class whose facts (parameters, constraints, `default_free`, `length_params`) are
    the family class's, read through `params_field = "family"`.
    """

    family: Family

    name = "point_light"
    formula = "g f(d) max(0, cos_r)"
    source = "the point-light model (docs/architecture.md, Conventions; RTR4 eq. 5.11-5.14)"
    light = "any"
    exact = "a sphere wholly above the horizon, with f = 1/d^2"
    params_field = "family"

    def __init__(self, family: Family | None = None):
        want = type(self).params_class
        if family is None:
            family = want()
        if type(family) is not want:
            raise BadTypeError(
                f"{type(self).__name__} takes a {want.__name__} instance, got "
                f"{type(family).__name__}"
            )
        self.family = family

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        return g * self.family(d).astype(d.dtype) * jnp.maximum(cos_r, 0)

    def shader_form(self) -> ShaderForm | None:
        """The family's form times `g max(cos_r, 0)` (None where the family has none); it
        reads no radius."""
        inner = self.family.shader_form()
        if inner is None:
            return None
        result = Ref("g", "d") * inner.result * fn("max", Ref("cos_r", "d"), 0.0)
        return ShaderForm(
            "point_light",
            inner.params,
            inner.lets,
            result,
            f"the point-light model g f(d) max(0, n.l), f: {inner.source}",
            inner.engine,
            inner.note,
            AREA_FORM_INPUTS,
        )


@functools.cache
def point_light_class(family: type[Family]) -> type[PointLight]:
    """The final `PointLight` class of a family class: the family's facts, as class facts."""
    namespace = {
        "params_class": family,
        "default_free": tuple(family.default_free),
        "constraints": dict(family.constraints),
        "length_params": tuple(family.length_params),
        "units": dict(family.units),
        "__module__": family.__module__,
        "__doc__": f"`PointLight` of `{family.__name__}` ({family.name}).",
    }
    cls = _PointLightMeta(f"PointLight[{family.__name__}]", (PointLight,), namespace)
    cls.__qualname__ = f"PointLight[{family.__qualname__}]"
    return cls


register_area_model(point_light_class(InverseSquare))
