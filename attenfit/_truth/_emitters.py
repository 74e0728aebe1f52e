"""Lambertian area emitters: sphere, one- or two-sided disk, and capsule.

Every emitter has uniform radiance `L` over its surface and a point-equivalent intensity
`I` (default 1), related by Yuksel's normalisation `L = I / (pi r^2)` (docs/architecture.md, Conventions;
Yuksel 2020, "Point Light Attenuation Without Singularity"): the sphere radiates `I` in
every direction, the disk `I` along its normal (`I cos(theta_e)` off it).

Each emitter also describes the point light that stands in for it: `point_light(points,
normals)` returns the distance `d` a family is evaluated at and the weight
`I * g * max(0, n.l)` such that the point-light model predicts `E = weight * f(d)`.

Emitters are small immutable `eqx.Module`s (pytrees), so they pass through `jit` and
`vmap`. Constructors validate concrete values eagerly (traced values are let through).
"""

from __future__ import annotations

import abc
import inspect
import math
from collections.abc import Mapping
from typing import Any, ClassVar

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadTypeError, BadValueError, UnknownNameError


# ----------------------------------------------------------------------------- validation
def _is_traced(x: Any) -> bool:
    return isinstance(x, jax.core.Tracer)


def _float_dtype(x: Any) -> Any:
    """The float dtype to store `x` in: its own if floating, else JAX's default float."""
    dt = getattr(x, "dtype", None)
    if dt is not None and jnp.issubdtype(dt, jnp.floating):
        return dt
    return jax.dtypes.canonicalize_dtype(jnp.float64)


def _check_real(name: str, x: Any, shape: tuple[int, ...]) -> Any:
    """Check a concrete real value of `shape`; return it as a JAX array."""
    if _is_traced(x):
        return x
    if isinstance(x, str | bytes) or x is None:
        raise BadTypeError(f"{name} must be a real number or array, got {type(x).__name__}")
    try:
        arr = np.asarray(x)
    except Exception as exc:  # ragged lists and the like
        raise BadTypeError(f"{name} must be a real number or array, got {x!r}") from exc
    if arr.dtype == bool or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise BadTypeError(f"{name} must be real (float or int), got dtype {arr.dtype}")
    if arr.shape != shape:
        want = "a scalar" if shape == () else f"shape {shape}"
        raise BadValueError(f"{name} must be {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise BadValueError(f"{name} must be finite, got {arr.tolist()}")
    dt = _float_dtype(x)
    with np.errstate(over="ignore"):  # an overflow is reported just below
        cast = arr.astype(dt)  # numpy, so this check also runs while jit is tracing
    if not np.all(np.isfinite(cast)):
        raise BadValueError(f"{name} = {arr.tolist()} overflows {np.dtype(dt)}")
    return jnp.asarray(x, dtype=dt)


def _check_positive(name: str, x: Any) -> Any:
    out = _check_real(name, x, ())
    if not _is_traced(x) and not float(np.asarray(x)) > 0:
        raise BadValueError(f"{name} must be > 0, got {float(np.asarray(x))!r}")
    return out


def _check_radius(name: str, x: Any) -> Any:
    """A positive radius whose square is a normal number of its dtype (else r^2, L overflow)."""
    out = _check_positive(name, x)
    if not _is_traced(x):
        dt = np.dtype(_float_dtype(x))
        fi = np.finfo(dt)
        lo, hi = math.sqrt(float(fi.tiny)), math.sqrt(float(fi.max))
        if not lo < float(np.asarray(x)) < hi:
            raise BadValueError(
                f"{name} must lie within ({lo:.3g}, {hi:.3g}) in {dt} (its square must be "
                f"a normal number), got {float(np.asarray(x)):g}"
            )
    return out


def _normalise(v: Array) -> Array:
    """`v / |v|` along the last axis, scaled to the order of 1 first: the squares of a normal
    like [0, 0, 1e-200] underflow (and of [1e300, 0, 0] overflow) before the square root."""
    m = jnp.max(jnp.abs(v), axis=-1, keepdims=True)
    v = v / jnp.where(m > 0, m, 1)
    return v / jnp.linalg.norm(v, axis=-1, keepdims=True)


def _unit(name: str, x: Any) -> Any:
    out = _check_real(name, x, (3,))
    if not _is_traced(x):
        if not float(np.max(np.abs(np.asarray(x, dtype=np.float64)))) > 0:
            raise BadValueError(f"{name} must be a non-zero 3-vector, got {np.asarray(x).tolist()}")
    return _normalise(out)


def _dot(a: Array, b: Array) -> Array:
    return jnp.sum(a * b, axis=-1)


def _safe_norm(v: Array) -> Array:
    """|v| over the last axis, with gradient 0 (not NaN) at v = 0."""
    n2 = _dot(v, v)
    pos = n2 > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, n2, 1)), 0)


def _real_input(name: str, x: Any) -> Any:
    """Refuse (eagerly) a concrete receiver array that is not real: complex, object, text, bool."""
    if _is_traced(x):
        return x
    dt = getattr(x, "dtype", None)
    if dt is None or np.dtype(dt).kind == "O":
        try:
            x = np.asarray(x)
        except Exception as exc:  # ragged lists and the like
            raise BadTypeError(f"{name} must be a real array [..., 3], got {x!r}") from exc
        dt = x.dtype
    if np.dtype(dt).kind == "b" or not (
        jnp.issubdtype(dt, jnp.floating) or jnp.issubdtype(dt, jnp.integer)
    ):
        raise BadTypeError(f"{name} must be real (float or int), got dtype {dt}")
    return x


def _receivers(points: ArrayLike, normals: ArrayLike) -> tuple[Array, Array]:
    """Points and unit normals as float arrays of one dtype, broadcast to one shape [..., 3]."""
    p = jnp.asarray(_real_input("points", points))
    n = jnp.asarray(_real_input("normals", normals))
    dt = _float_dtype(p) if jnp.issubdtype(p.dtype, jnp.floating) else _float_dtype(n)
    p = p.astype(dt)
    n = n.astype(dt)
    if p.shape[-1:] != (3,) or n.shape[-1:] != (3,):
        raise BadValueError(
            f"points and normals must have a last axis of 3, got shapes {p.shape} and {n.shape}"
        )
    try:
        shape = jnp.broadcast_shapes(p.shape, n.shape)
    except ValueError:
        raise BadValueError(
            f"points {p.shape} and normals {n.shape} must have the same (or broadcastable) shapes"
        ) from None
    p = jnp.broadcast_to(p, shape)
    n = jnp.broadcast_to(n, shape)
    return p, _normalise(n)


def _bcast(x: Array, like: Array) -> Array:
    """An emitter vector field (3,) cast to `like`'s dtype and rank (explicit, for strict rank promotion)."""
    x = jnp.asarray(x).astype(like.dtype)
    return jnp.broadcast_to(x, like.shape[:-1] + x.shape[-1:])


# ----------------------------------------------------------------------------- emitters
class AbstractEmitter(eqx.Module):
    """A Lambertian emitter of uniform radiance `L = I / (pi r^2)` (docs/architecture.md, Conventions)."""

    #: Name used in files and on the command line.
    kind: ClassVar[str]

    radius: eqx.AbstractVar[Array]
    intensity: eqx.AbstractVar[Array]

    @property
    def radiance(self) -> Array:
        """Uniform radiance `L = I / (pi r^2)` in W/(m^2 sr) per unit intensity (Yuksel 2020)."""
        return self.intensity / (math.pi * self.radius**2)

    @abc.abstractmethod
    def point_light(
        self, points: Float[ArrayLike, "*b 3"], normals: Float[ArrayLike, "*b 3"]
    ) -> tuple[Float[Array, "*b"], Float[Array, "*b"]]:
        """`(d, weight)` of the stand-in point light: `E_model = weight * f(d)`."""

    @abc.abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """A JSON-serialisable description; `emitter_from_dict` inverts it."""

    @abc.abstractmethod
    def reference_point(self) -> Array:
        """The light's centre (capsule: the midpoint of its segment)."""

    def exact_kernel(self, dtype: Any) -> Any:
        """`(p, n) -> E` at one receiver, for a shape whose exact irradiance lives with its
        class (the rectangle, `_rect`); None for those `_irradiance` holds."""
        return None


def flat_point_light(
    emitter: AbstractEmitter, points: ArrayLike, normals: ArrayLike, two_sided: bool = False
) -> tuple[Array, Array]:
    """A flat light's stand-in point light (a disk, a rectangle): the distance to its centre and
    `I * g * max(0, n.l)`, `g = max(0, m.(p - c)/d)` (`|.|` if two-sided); 0 at `d = 0`."""
    p, n = _receivers(points, normals)
    dv = _bcast(emitter.center, p) - p
    d = _safe_norm(dv)
    dsafe = jnp.where(d > 0, d, 1)
    cos_r = _dot(n, dv) / dsafe
    cos_e = -_dot(_bcast(emitter.normal, p), dv) / dsafe
    g = jnp.abs(cos_e) if two_sided else jnp.maximum(cos_e, 0)
    return d, emitter.intensity.astype(p.dtype) * g * jnp.maximum(cos_r, 0)


class SphereEmitter(AbstractEmitter):
    """A Lambertian sphere of centre `center` (m), radius `radius` (m), intensity `intensity`.

    Radiance `L = I / (pi r^2)`; isotropic intensity `I` (projected area `pi r^2` in every
    direction), total power `4 pi I`, like an isotropic point light (Yuksel 2020).
    Receivers on or inside the sphere are invalid (`irradiance` gives NaN there).
    """

    center: Float[Array, "3"]
    radius: Float[Array, ""]
    intensity: Float[Array, ""]
    kind: ClassVar[str] = "sphere"

    def __init__(self, center: ArrayLike, radius: ArrayLike, intensity: ArrayLike = 1.0):
        self.center = _check_real("center", center, (3,))
        self.radius = _check_radius("radius", radius)
        self.intensity = _check_positive("intensity", intensity)

    def reference_point(self) -> Array:
        return self.center

    def point_light(self, points, normals):
        """Distance to the centre and `I * max(0, n.l)`, `l` the unit vector to the centre."""
        p, n = _receivers(points, normals)
        dv = _bcast(self.center, p) - p
        d = _safe_norm(dv)
        cos = _dot(n, dv) / jnp.where(d > 0, d, 1)
        return d, self.intensity.astype(p.dtype) * jnp.maximum(cos, 0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "center": np.asarray(self.center, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
        }


class DiskEmitter(AbstractEmitter):
    """A flat Lambertian disk: centre `center` (m), unit `normal` (normalised here), `radius` (m).

    One-sided by default: it emits only into the half-space `(x - c).m > 0`; `two_sided=True`
    emits the same radiance from both faces. Radiance `L = I / (pi r^2)`, so the intensity is
    `I` along the normal and `I |cos(theta_e)|` (one-sided: `I max(0, cos(theta_e))`) off it.
    """

    center: Float[Array, "3"]
    normal: Float[Array, "3"]
    radius: Float[Array, ""]
    intensity: Float[Array, ""]
    two_sided: bool = eqx.field(static=True)
    kind: ClassVar[str] = "disk"

    def __init__(
        self,
        center: ArrayLike,
        normal: ArrayLike,
        radius: ArrayLike,
        intensity: ArrayLike = 1.0,
        two_sided: bool = False,
    ):
        self.center = _check_real("center", center, (3,))
        self.normal = _unit("normal", normal)
        self.radius = _check_radius("radius", radius)
        self.intensity = _check_positive("intensity", intensity)
        if not isinstance(two_sided, bool | np.bool_):
            raise BadTypeError(f"two_sided must be True or False, got {two_sided!r}")
        self.two_sided = bool(two_sided)

    def reference_point(self) -> Array:
        return self.center

    def point_light(self, points, normals):
        """Distance to the centre and `I * g * max(0, n.l)`, `g = max(0, m.(p - c)/d)`.

        Two-sided disks use `g = |m.(p - c)| / d`. The weight is 0 at `d = 0`.
        """
        return flat_point_light(self, points, normals, self.two_sided)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "center": np.asarray(self.center, dtype=np.float64).tolist(),
            "normal": np.asarray(self.normal, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
            "two_sided": self.two_sided,
        }


class CapsuleEmitter(AbstractEmitter):
    """A Lambertian capsule: the points within `radius` (m) of the segment from `a` to `b` (m).

    A cylinder of length `l = |b - a|` with hemispherical ends: the capsule light of Tomb
    Raider (2013), which shades with the direction to the closest point of the segment
    (Real-Time Rendering 4th ed., section 5.2.2). `a == b` is a sphere.

    **What `I` means.** The radiance is `L = I / (pi r^2)`, as for a sphere of the same
    radius: `I` is the intensity of the capsule seen end-on (projected area `pi r^2`), i.e.
    of one of its spherical ends alone. Seen at angle `psi` to its axis its projected area is
    `pi r^2 + 2 r l sin(psi)`, so its intensity there is `I g` with
    `g = 1 + 2 l sin(psi) / (pi r)`; `point_light` uses this `g` so that the point-light model
    tends to the truth far away.
    """

    a: Float[Array, "3"]
    b: Float[Array, "3"]
    radius: Float[Array, ""]
    intensity: Float[Array, ""]
    kind: ClassVar[str] = "capsule"

    def __init__(self, a: ArrayLike, b: ArrayLike, radius: ArrayLike, intensity: ArrayLike = 1.0):
        self.a = _check_real("a", a, (3,))
        self.b = _check_real("b", b, (3,))
        self.radius = _check_radius("radius", radius)
        self.intensity = _check_positive("intensity", intensity)

    @property
    def length(self) -> Array:
        """The segment's length `|b - a|` (m)."""
        return _safe_norm(self.b - self.a)

    def reference_point(self) -> Array:
        return 0.5 * (self.a + self.b)

    def closest_point(self, points: Float[ArrayLike, "*b 3"]) -> Float[Array, "*b 3"]:
        """The point of the segment closest to each of `points`."""
        p = jnp.asarray(points)
        a = _bcast(self.a, p)
        ab = _bcast(self.b, p) - a
        den = _dot(ab, ab)
        t = jnp.clip(_dot(p - a, ab) / jnp.where(den > 0, den, 1), 0, 1)
        return a + t[..., None] * ab

    def point_light(self, points, normals):
        """Distance to the closest point `q` of the segment and `I * g * max(0, n.l)`.

        `l` is the unit vector from the receiver to `q` (Tomb Raider's capsule light) and
        `g = 1 + 2 |b - a| sin(psi) / (pi r)` the capsule's projected area in direction `l`
        over `pi r^2` (`psi` the angle between `l` and the axis).
        """
        p, n = _receivers(points, normals)
        dv = self.closest_point(p) - p
        d = _safe_norm(dv)
        dsafe = jnp.where(d > 0, d, 1)
        l = dv / dsafe[..., None]
        ab = _bcast(self.b, p) - _bcast(self.a, p)
        sin_psi = _safe_norm(jnp.cross(l, ab))  # = |ab| sin(psi)
        r = self.radius.astype(p.dtype)
        g = 1 + 2 * sin_psi / (math.pi * r)
        cos_r = _dot(n, l)
        return d, self.intensity.astype(p.dtype) * g * jnp.maximum(cos_r, 0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "a": np.asarray(self.a, dtype=np.float64).tolist(),
            "b": np.asarray(self.b, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
        }


def _kinds() -> dict[str, tuple[type[AbstractEmitter], tuple[str, ...], tuple[str, ...]]]:
    """Every emitter class by its `kind`, with its constructor's required and optional keys."""
    out = {}
    stack = list(AbstractEmitter.__subclasses__())
    while stack:
        cls = stack.pop(0)
        stack.extend(cls.__subclasses__())
        params = list(inspect.signature(cls.__init__).parameters.values())[1:]
        required = tuple(p.name for p in params if p.default is inspect.Parameter.empty)
        optional = tuple(p.name for p in params if p.default is not inspect.Parameter.empty)
        out[cls.kind] = (cls, required, optional)
    return out


def emitter_from_dict(data: Mapping[str, Any]) -> AbstractEmitter:
    """Rebuild an emitter from `to_dict()`'s output (validated like the constructors).

    Raises `UnknownNameError` for an unknown `kind` and `BadValueError` for missing or
    unexpected keys.
    """
    if not isinstance(data, Mapping):
        raise BadTypeError(f"an emitter description must be a dict, got {type(data).__name__}")
    kind = data.get("kind")
    kinds = _kinds()
    if not isinstance(kind, str) or kind not in kinds:
        raise UnknownNameError(f"unknown emitter kind {kind!r}; allowed: {sorted(kinds)}")
    cls, required, optional = kinds[kind]
    missing = [k for k in required if k not in data]
    if missing:
        raise BadValueError(f"{kind} emitter description lacks {missing}")
    extra = sorted(set(data) - set(required) - set(optional) - {"kind"})
    if extra:
        raise BadValueError(f"{kind} emitter description has unknown keys {extra}")
    return cls(**{k: data[k] for k in (*required, *optional) if k in data})
