"""Lambertian area emitters: the abstract bases, and the sphere, one- or two-sided disk and capsule.

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
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadTypeError, BadValueError, UnknownNameError
from ._emitter_checks import (
    _bcast,
    _check_positive,
    _check_radius,
    _check_real,
    _dot,
    _receivers,
    _safe_norm,
    _unit,
    array_module,
)


# ----------------------------------------------------------------------------- emitters
class AbstractEmitter(eqx.Module):
    """A Lambertian emitter of uniform radiance `L = I / (pi r^2)` (docs/architecture.md, Conventions).

    Besides its irradiance, each shape states the geometry the rest of attenfit reads from
    it, so that a new shape is written in its own class: its **core** (the point or segment
    distances are measured from: `closest_point`, `core_distance`, `core_samples`,
    `core_length`), where receivers may not be (`solid_radius`, `inside`,
    `surface_distance`, `extent`), how the builders place receivers (`facing_direction`,
    `apparent_sine`), and what an area model reads (`area_factors`; a shape with its own
    models, `frame_input_names` and `light_frame`).
    """

    #: Name used in files and on the command line.
    kind: ClassVar[str]
    #: The inputs of the area models written for this shape alone (`attenfit._curves`
    #: `RECT_INPUTS`, `TUBE_INPUTS`), read by `light_frame`; () where its models read
    #: `AreaInputs` only.
    frame_input_names: eqx.AbstractClassVar[tuple[str, ...]]

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

    # ------------------------------------------------------------------ the core
    @abc.abstractmethod
    def closest_point(self, points: Float[ArrayLike, "*b 3"]) -> Float[Array, "*b 3"]:
        """The point of the light's core nearest each of `points` (JAX): its centre, or the
        nearest point of its segment (where `area_inputs` measures `d` from)."""

    @abc.abstractmethod
    def core_distance(self, pts: np.ndarray) -> np.ndarray:
        """Distance (m) of each receiver `(n, 3)` from the light's core (numpy, float64)."""

    @abc.abstractmethod
    def core_samples(self, rng: np.random.Generator, k: int) -> np.ndarray:
        """`k` uniform points of the core `(k, 3)` (a centre: itself, drawing nothing)."""

    @property
    @abc.abstractmethod
    def core_length(self) -> float:
        """The core's length (m): 0 for a centre, the segment's length."""

    # ------------------------------------------------------------------ where receivers may be
    @property
    @abc.abstractmethod
    def solid_radius(self) -> float:
        """How far from its core (m) a receiver may be inside the light (0: a flat light)."""

    @abc.abstractmethod
    def inside(self, pts: np.ndarray, margin: float = 1e-9) -> np.ndarray:
        """Receivers `(n, 3)` on or inside the light, with a relative `margin` (n,) bool."""

    @abc.abstractmethod
    def surface_distance(self, pts: np.ndarray) -> np.ndarray:
        """Distance (m) from each receiver `(n, 3)` to the light's surface; 0 inside it."""

    @abc.abstractmethod
    def extent(self) -> float:
        """The largest coordinate of any point of the light (its bounding box's), m."""

    # ------------------------------------------------------------------ receivers of the builders
    @abc.abstractmethod
    def facing_direction(self) -> np.ndarray:
        """The unit direction from the centre along which `facing_sweep` places receivers."""

    @abc.abstractmethod
    def apparent_sine(self, dist: np.ndarray) -> np.ndarray:
        """The sine of the light's apparent angular radius at distances `dist` from its core."""

    # ------------------------------------------------------------------ what area models read
    @abc.abstractmethod
    def area_factors(
        self, p: Array, n: Array, dv: Array, dsafe: Array, cos_r: Array, r: Array
    ) -> tuple[Array, Array, Array]:
        """`(cos_e, cos_n, g)` of `AreaInputs` at receivers `p`, unit normals `n`, with `dv`
        the vector to `closest_point`, `dsafe` its length (1 where 0) and `r` the radius."""

    @abc.abstractmethod
    def light_frame(self, dtype: Any) -> tuple[Array, Array, Array, tuple[Array, ...]]:
        """`(centre, x axis, z axis, sizes)` of the frame its own models read
        (`attenfit.frame_inputs`); a shape without such models raises `BadTypeError`."""


def _no_frame(self: AbstractEmitter, dtype: Any) -> Any:
    raise BadTypeError(
        f"frame inputs are for a RectEmitter or a TubeEmitter, got {type(self).__name__}"
    )


def _perpendicular(e: np.ndarray) -> np.ndarray:
    helper = np.array([1.0, 0, 0]) if abs(e[0]) < 0.9 else np.array([0, 1.0, 0])
    w = np.cross(e, helper)
    return w / np.linalg.norm(w)


def _f64(x: Any) -> np.ndarray:
    return np.asarray(x, dtype=np.float64)


class AbstractCentredEmitter(AbstractEmitter):
    """A light whose core is its centre (a sphere, a disk, a rectangle)."""

    center: eqx.AbstractVar[Array]

    def reference_point(self) -> Array:
        return self.center

    def closest_point(self, points):
        return _bcast(self.reference_point(), array_module(points).asarray(points))

    def core_distance(self, pts):
        return np.linalg.norm(pts - _f64(self.center), axis=1)

    def core_samples(self, rng, k):
        return np.broadcast_to(_f64(self.reference_point()), (k, 3))

    @property
    def core_length(self) -> float:
        return 0.0


class AbstractFlatEmitter(AbstractCentredEmitter):
    """A flat one- or two-sided light of unit `normal` (a disk, a rectangle): no inside;
    receivers along its normal; read by area models as a disk (`g = max(0, cos_e)`)."""

    normal: eqx.AbstractVar[Array]
    two_sided: eqx.AbstractVar[bool]

    def point_light(self, points, normals):
        """Distance to the centre and `I * g * max(0, n.l)`, `g = max(0, m.(p - c)/d)`
        (`|.|` if two-sided); the weight is 0 at `d = 0`."""
        p, n = _receivers(points, normals)
        xp = array_module(p, self.center, self.normal, self.intensity)
        dv = _bcast(self.center, p) - p
        d = _safe_norm(dv)
        dsafe = xp.where(d > 0, d, 1)
        cos_r = _dot(n, dv) / dsafe
        cos_e = -_dot(_bcast(self.normal, p), dv) / dsafe
        g = xp.abs(cos_e) if self.two_sided else xp.maximum(cos_e, 0)
        return d, xp.asarray(self.intensity).astype(p.dtype) * g * xp.maximum(cos_r, 0)

    @property
    def solid_radius(self) -> float:
        return 0.0

    def inside(self, pts, margin=1e-9):
        return np.zeros(len(pts), dtype=bool)

    def facing_direction(self):
        return _f64(self.normal)

    def apparent_sine(self, dist):
        return np.sin(np.arctan(float(self.radius) / dist))

    def area_factors(self, p, n, dv, dsafe, cos_r, r):
        """`cos_e = m.(p - c)/d` (negative behind a one-sided light), `cos_n = -n.m`,
        `g = max(0, cos_e)`; two-sided: read from the face the receiver sees."""
        xp = array_module(p, n, dv, self.normal)
        m = _bcast(self.normal, p)
        cos_e = -_dot(m, dv) / dsafe
        cos_n = -_dot(n, m)
        if self.two_sided:
            one = xp.ones_like(dsafe)
            flip = xp.where(cos_e < 0, -one, one)
            cos_e, cos_n = cos_e * flip, cos_n * flip
        return cos_e, cos_n, xp.maximum(cos_e, 0)


class AbstractSegmentEmitter(AbstractEmitter):
    """A light around the segment `a -> b` (a capsule, a tube): distances from the segment,
    receivers beside it, shaded as a sphere at the closest point times its factor `g`."""

    a: eqx.AbstractVar[Array]
    b: eqx.AbstractVar[Array]

    @property
    def length(self) -> Array:
        """The segment's length `|b - a|` (m)."""
        return _safe_norm(self.b - self.a)

    def closest_point(self, points: Float[ArrayLike, "*b 3"]) -> Float[Array, "*b 3"]:
        """The point of the segment closest to each of `points`."""
        xp = array_module(points, self.a, self.b)
        p = xp.asarray(points)
        a = _bcast(self.a, p)
        ab = _bcast(self.b, p) - a
        den = _dot(ab, ab)
        t = xp.clip(_dot(p - a, ab) / xp.where(den > 0, den, 1), 0, 1)
        return a + t[..., None] * ab

    def core_distance(self, pts):
        a = _f64(self.a)
        ab = _f64(self.b) - a
        den = float(ab @ ab)
        t = np.clip((pts - a) @ ab / den, 0, 1) if den > 0 else np.zeros(len(pts))
        return np.linalg.norm(pts - (a + t[:, None] * ab), axis=1)

    def core_samples(self, rng, k):
        a, b = _f64(self.a), _f64(self.b)
        return a + rng.uniform(0, 1, size=(k, 1)) * (b - a)

    @property
    def core_length(self) -> float:
        return float(self.length)

    @property
    def solid_radius(self) -> float:
        return float(self.radius)

    def extent(self):
        ends = np.abs(np.stack([np.asarray(self.a), np.asarray(self.b)], dtype=np.float64))
        return float(ends.max()) + float(np.asarray(self.radius))

    def facing_direction(self):
        ab = _f64(self.b) - _f64(self.a)
        e = ab / np.linalg.norm(ab) if np.linalg.norm(ab) > 0 else np.array([0.0, 0.0, 1.0])
        return _perpendicular(e)

    def apparent_sine(self, dist):
        return np.clip(float(self.radius) / dist, 0, 1)

    def area_factors(self, p, n, dv, dsafe, cos_r, r):
        """`cos_e = 1`, `cos_n = cos_r` (a sphere at the closest point) and `g` the
        projected-area factor (`projected_factor`) towards the closest point."""
        xp = array_module(p, dv, self.a, self.b)
        ab = _bcast(self.b, p) - _bcast(self.a, p)
        l = dv / dsafe[..., None]
        sin_psi = _safe_norm(xp.cross(l, ab))  # |b - a| sin(psi)
        return xp.ones_like(dsafe), cos_r, self.projected_factor(l, ab, sin_psi, r)

    @abc.abstractmethod
    def projected_factor(self, l: Array, ab: Array, sin_psi: Array, r: Array) -> Array:
        """The light's projected area seen along `l` over `pi r^2` (`ab = b - a`,
        `sin_psi = |ab| sin(psi)`, `psi` the angle between `l` and the axis)."""


class SphereEmitter(AbstractCentredEmitter):
    """A Lambertian sphere of centre `center` (m), radius `radius` (m), intensity `intensity`.

    Radiance `L = I / (pi r^2)`; isotropic intensity `I` (projected area `pi r^2` in every
    direction), total power `4 pi I`, like an isotropic point light (Yuksel 2020).
    Receivers on or inside the sphere are invalid (`irradiance` gives NaN there).
    """

    center: Float[Array, "3"]
    radius: Float[Array, ""]
    intensity: Float[Array, ""]
    kind: ClassVar[str] = "sphere"
    frame_input_names: ClassVar[tuple[str, ...]] = ()

    def __init__(self, center: ArrayLike, radius: ArrayLike, intensity: ArrayLike = 1.0):
        self.center = _check_real("center", center, (3,))
        self.radius = _check_radius("radius", radius)
        self.intensity = _check_positive("intensity", intensity)

    def point_light(self, points, normals):
        """Distance to the centre and `I * max(0, n.l)`, `l` the unit vector to the centre."""
        p, n = _receivers(points, normals)
        xp = array_module(p, self.center, self.intensity)
        dv = _bcast(self.center, p) - p
        d = _safe_norm(dv)
        cos = _dot(n, dv) / xp.where(d > 0, d, 1)
        return d, xp.asarray(self.intensity).astype(p.dtype) * xp.maximum(cos, 0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "center": np.asarray(self.center, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
        }

    @property
    def solid_radius(self) -> float:
        return float(self.radius)

    def inside(self, pts, margin=1e-9):
        return self.core_distance(pts) <= float(self.radius) * (1 + margin)

    def surface_distance(self, pts):
        """`|p - c| - r`, 0 inside."""
        return np.maximum(self.core_distance(_f64(pts)) - float(np.asarray(self.radius)), 0.0)

    def extent(self):
        return float(np.abs(_f64(self.center)).max()) + float(np.asarray(self.radius))

    def facing_direction(self):
        return np.array([0.0, 0.0, -1.0])

    def apparent_sine(self, dist):
        return np.clip(float(self.radius) / dist, 0, 1)

    def area_factors(self, p, n, dv, dsafe, cos_r, r):
        """The disk that faces the receiver: `cos_e = 1`, `cos_n = cos_r`, `g = 1`."""
        one = array_module(dsafe).ones_like(dsafe)
        return one, cos_r, one

    light_frame = _no_frame


class DiskEmitter(AbstractFlatEmitter):
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
    frame_input_names: ClassVar[tuple[str, ...]] = ()

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

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "center": np.asarray(self.center, dtype=np.float64).tolist(),
            "normal": np.asarray(self.normal, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
            "two_sided": self.two_sided,
        }

    def surface_distance(self, pts):
        """Distance to the nearest point of the (closed) disk."""
        p = _f64(pts)
        m = _f64(self.normal)
        m = m / np.linalg.norm(m)
        rel = p - _f64(self.center)
        z = rel @ m
        s = np.linalg.norm(rel - z[:, None] * m, axis=1)
        return np.hypot(z, np.maximum(s - float(np.asarray(self.radius)), 0.0))

    def extent(self):
        return float(np.abs(_f64(self.center)).max()) + float(np.asarray(self.radius))

    light_frame = _no_frame


class CapsuleEmitter(AbstractSegmentEmitter):
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
    frame_input_names: ClassVar[tuple[str, ...]] = ()

    def __init__(self, a: ArrayLike, b: ArrayLike, radius: ArrayLike, intensity: ArrayLike = 1.0):
        self.a = _check_real("a", a, (3,))
        self.b = _check_real("b", b, (3,))
        self.radius = _check_radius("radius", radius)
        self.intensity = _check_positive("intensity", intensity)

    def reference_point(self) -> Array:
        return 0.5 * (self.a + self.b)

    def point_light(self, points, normals):
        """Distance to the closest point `q` of the segment and `I * g * max(0, n.l)`.

        `l` is the unit vector from the receiver to `q` (Tomb Raider's capsule light) and
        `g = 1 + 2 |b - a| sin(psi) / (pi r)` the capsule's projected area in direction `l`
        over `pi r^2` (`psi` the angle between `l` and the axis).
        """
        p, n = _receivers(points, normals)
        xp = array_module(p, self.a, self.b, self.radius, self.intensity)
        dv = self.closest_point(p) - p
        d = _safe_norm(dv)
        dsafe = xp.where(d > 0, d, 1)
        l = dv / dsafe[..., None]
        ab = _bcast(self.b, p) - _bcast(self.a, p)
        sin_psi = _safe_norm(xp.cross(l, ab))  # = |ab| sin(psi)
        r = xp.asarray(self.radius).astype(p.dtype)
        g = 1 + 2 * sin_psi / (math.pi * r)
        cos_r = _dot(n, l)
        return d, xp.asarray(self.intensity).astype(p.dtype) * g * xp.maximum(cos_r, 0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "a": np.asarray(self.a, dtype=np.float64).tolist(),
            "b": np.asarray(self.b, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
        }

    def inside(self, pts, margin=1e-9):
        return self.core_distance(pts) <= float(self.radius) * (1 + margin)

    def surface_distance(self, pts):
        """Distance to the segment minus r, 0 inside."""
        return np.maximum(self.core_distance(_f64(pts)) - float(np.asarray(self.radius)), 0.0)

    def projected_factor(self, l, ab, sin_psi, r):
        """`1 + 2 |b - a| sin(psi) / (pi r)`, as `point_light`'s."""
        return 1 + 2 * sin_psi / (math.pi * r)

    light_frame = _no_frame


def _kinds() -> dict[str, tuple[type[AbstractEmitter], tuple[str, ...], tuple[str, ...]]]:
    """Every emitter class by its `kind`, with its constructor's required and optional keys."""
    out = {}
    stack = list(AbstractEmitter.__subclasses__())
    while stack:
        cls = stack.pop(0)
        stack.extend(cls.__subclasses__())
        if inspect.isabstract(cls):  # the abstract bases of the shapes
            continue
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
