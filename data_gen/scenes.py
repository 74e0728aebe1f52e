"""Mitsuba 3 scenes for attenfit's emitters, as plain data.

A light is described by a small frozen record (`SphereLight`, `DiskLight`, `CapsuleLight`,
`RectLight`, `TubeLight`) holding numbers only; `scene_components` turns a list of them, plus an optional opaque
`Plane`, into the plain dictionaries that `mitsuba.load_dict` accepts. Each light is made of
Mitsuba `sphere`, `disk`, `rectangle` or `cylinder` shapes carrying an `area` emitter of uniform radiance
L (Lambertian), with L the radiance that the point-equivalent intensity implies,
L = I / (pi r^2) (docs/architecture.md, Conventions).

The irradiance of a set of lights is the sum over *components* (`scene_components`): scenes
holding the same shapes but differing in which of them emit. Two reasons:

* Mitsuba's area emitter is one-sided (it emits along the shape's normal; `disk` has normal
  +z in object space, mapped to the light's normal `m` by `to_world`), so a two-sided disk's
  back face is a second disk facing `-m`, in a component of its own. One scene with both
  faces would be correct too, but Mitsuba then picks the wrong face for half the samples,
  which multiplies the variance (measured: 16x the standard error at 3 radii on the axis).
* A capsule is an open `cylinder` plus a `sphere` at each end; each end sphere emits in its
  own component with its inner half (inside the tube) clipped away.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from attenfit import BadTypeError, BadValueError

__all__ = [
    "LIGHT_TYPES",
    "CapsuleLight",
    "Component",
    "DiskLight",
    "Light",
    "Plane",
    "RectLight",
    "SphereLight",
    "TubeLight",
    "light_spheres",
    "lights_from_emitter",
    "plane_axes",
    "plane_dict",
    "scene_components",
]

Vec3 = tuple[float, float, float]


def _vec3(name: str, value) -> Vec3:
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (3,) or not np.all(np.isfinite(arr)):
        raise BadValueError(f"{name} must be 3 finite numbers, got {value!r}")
    return (float(arr[0]), float(arr[1]), float(arr[2]))


def _unit(name: str, value) -> Vec3:
    v = np.asarray(_vec3(name, value))
    norm = float(np.linalg.norm(v))
    if norm == 0.0:
        raise BadValueError(f"{name} must be a non-zero vector, got {value!r}")
    return (float(v[0] / norm), float(v[1] / norm), float(v[2] / norm))


def _positive(name: str, value) -> float:
    x = float(value)
    if not (np.isfinite(x) and x > 0):
        raise BadValueError(f"{name} must be a positive finite number, got {value!r}")
    return x


@dataclass(frozen=True)
class SphereLight:
    """A Lambertian sphere light: centre (3,), radius, radiance L (W sr^-1 m^-2 per unit I)."""

    center: Vec3
    radius: float
    radiance: float

    def __post_init__(self):
        object.__setattr__(self, "center", _vec3("center", self.center))
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        object.__setattr__(self, "radiance", _positive("radiance", self.radiance))


@dataclass(frozen=True)
class DiskLight:
    """A Lambertian disk light emitting along unit `normal` (both faces if `two_sided`)."""

    center: Vec3
    normal: Vec3
    radius: float
    radiance: float
    two_sided: bool = False

    def __post_init__(self):
        object.__setattr__(self, "center", _vec3("center", self.center))
        object.__setattr__(self, "normal", _unit("normal", self.normal))
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        object.__setattr__(self, "radiance", _positive("radiance", self.radiance))
        object.__setattr__(self, "two_sided", bool(self.two_sided))


@dataclass(frozen=True)
class Plane:
    """An opaque square: centre `point`, unit `normal`, half side `half_size` (an occluder)."""

    point: Vec3
    normal: Vec3
    half_size: float

    def __post_init__(self):
        object.__setattr__(self, "point", _vec3("point", self.point))
        object.__setattr__(self, "normal", _unit("normal", self.normal))
        object.__setattr__(self, "half_size", _positive("half_size", self.half_size))


@dataclass(frozen=True)
class CapsuleLight:
    """A Lambertian capsule light: the points within `radius` of the segment `a`-`b`.

    Rendered as an open Mitsuba `cylinder` from `a` to `b` plus a `sphere` at each end, all
    emitting `radiance`: each sphere's inner half lies inside the tube, where Mitsuba's
    shadow rays find it hidden by the cylinder wall, so the lit surface is the capsule's.
    """

    a: Vec3
    b: Vec3
    radius: float
    radiance: float

    def __post_init__(self):
        object.__setattr__(self, "a", _vec3("a", self.a))
        object.__setattr__(self, "b", _vec3("b", self.b))
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        object.__setattr__(self, "radiance", _positive("radiance", self.radiance))


@dataclass(frozen=True)
class RectLight:
    """A one-sided Lambertian rectangle light: centre, unit `normal` (it emits along it), unit
    `tangent` along its `width`, `height` along `normal x tangent` (Mitsuba's `rectangle`)."""

    center: Vec3
    normal: Vec3
    tangent: Vec3
    width: float
    height: float
    radiance: float

    def __post_init__(self):
        object.__setattr__(self, "center", _vec3("center", self.center))
        object.__setattr__(self, "normal", _unit("normal", self.normal))
        object.__setattr__(self, "tangent", _unit("tangent", self.tangent))
        for name in ("width", "height", "radiance"):
            object.__setattr__(self, name, _positive(name, getattr(self, name)))

    @property
    def radius(self) -> float:
        """The radius of the disk of the same area (as `attenfit.RectEmitter.radius`)."""
        return float(np.sqrt(self.width * self.height / np.pi))


@dataclass(frozen=True)
class TubeLight:
    """A Lambertian tube light: the side of the cylinder of `radius` around `a`-`b` (Mitsuba's
    `cylinder`, which has no end caps and emits outward), and its two end disks if `caps`."""

    a: Vec3
    b: Vec3
    radius: float
    radiance: float
    caps: bool = False

    def __post_init__(self):
        object.__setattr__(self, "a", _vec3("a", self.a))
        object.__setattr__(self, "b", _vec3("b", self.b))
        object.__setattr__(self, "radius", _positive("radius", self.radius))
        object.__setattr__(self, "radiance", _positive("radiance", self.radiance))
        object.__setattr__(self, "caps", bool(self.caps))


Light = SphereLight | DiskLight | CapsuleLight | RectLight | TubeLight
LIGHT_TYPES = (SphereLight, DiskLight, CapsuleLight, RectLight, TubeLight)


def light_spheres(light: Light) -> list[SphereLight]:
    """The sphere lights a light is rendered with (a capsule's two ends; a sphere itself)."""
    if isinstance(light, SphereLight):
        return [light]
    if isinstance(light, CapsuleLight):
        return [SphereLight(end, light.radius, light.radiance) for end in (light.a, light.b)]
    return []


def _frame(mi, center: Vec3, normal: Vec3, scale: float):
    """`to_world` mapping object-space +z to `normal`, the origin to `center`, xy scaled."""
    up = (0.0, 0.0, 1.0) if abs(normal[2]) < 0.9 else (1.0, 0.0, 0.0)
    target = (center[0] + normal[0], center[1] + normal[1], center[2] + normal[2])
    T = mi.ScalarTransform4f
    return T().look_at(origin=center, target=target, up=up) @ T().scale([scale, scale, 1.0])


def _emitter(radiance: float) -> dict:
    return {"type": "area", "radiance": {"type": "uniform", "value": radiance}}


@dataclass(frozen=True)
class _Shape:
    key: str
    shape: dict
    role: str  # the component in which this shape emits
    radiance: float
    clip: tuple[Vec3, Vec3] | None = None
    only_in: str | None = None  # present only in that component (a disk's back face)


def _rect_shape(mi, light: RectLight) -> dict:
    """A Mitsuba `rectangle` ([-1, 1]^2 at z = 0, normal +z) mapped onto the light."""
    m = np.asarray(light.normal)
    u = np.asarray(light.tangent) - (np.asarray(light.tangent) @ m) * m
    u /= np.linalg.norm(u)
    T = np.eye(4)
    T[:3, 0], T[:3, 1] = light.width / 2 * u, light.height / 2 * np.cross(m, u)
    T[:3, 2], T[:3, 3] = m, light.center
    return {"type": "rectangle", "to_world": mi.ScalarTransform4f(T.tolist())}


def _tube_shapes(mi, i: int, light: TubeLight) -> list[_Shape]:
    """An open `cylinder` (its normals point outward) and, with caps, a disk at each end."""
    L = light.radiance
    cyl = {"type": "cylinder", "p0": list(light.a), "p1": list(light.b), "radius": light.radius}
    out = [_Shape(f"light_{i}_tube", cyl, "main", L)]
    if light.caps:
        a, b = np.asarray(light.a), np.asarray(light.b)
        e = (b - a) / np.linalg.norm(b - a)
        for name, c, m in (("a", light.a, -e), ("b", light.b, e)):
            disk = {"type": "disk", "to_world": _frame(mi, c, tuple(m.tolist()), light.radius)}
            out.append(_Shape(f"light_{i}_cap_{name}", disk, "main", L))
    return out


def _shapes(mi, i: int, light: Light) -> list[_Shape]:
    """The Mitsuba shapes of light `i`, each tagged with the component it emits in."""
    L = light.radiance
    if isinstance(light, RectLight):
        return [_Shape(f"light_{i}", _rect_shape(mi, light), "main", L)]
    if isinstance(light, TubeLight):
        return _tube_shapes(mi, i, light)
    if isinstance(light, DiskLight):
        front = {"type": "disk", "to_world": _frame(mi, light.center, light.normal, light.radius)}
        out = [_Shape(f"light_{i}", front, "main", L)]
        if light.two_sided:
            m = tuple(-c for c in light.normal)
            back = {"type": "disk", "to_world": _frame(mi, light.center, m, light.radius)}
            out.append(_Shape(f"light_{i}_back", back, "back", L, only_in="back"))
        return out
    if isinstance(light, SphereLight) or light.a == light.b:
        sp = light_spheres(light)[0]
        return [_Shape(f"light_{i}", _sphere(sp), "spheres", L)]
    cylinder = {
        "type": "cylinder",
        "p0": list(light.a),
        "p1": list(light.b),
        "radius": light.radius,
    }
    a, b = np.asarray(light.a), np.asarray(light.b)
    out = [_Shape(f"light_{i}_tube", cylinder, "main", L)]
    end_a, end_b = light_spheres(light)
    for name, sp, axis in (("a", end_a, b - a), ("b", end_b, a - b)):
        clip = (sp.center, (float(axis[0]), float(axis[1]), float(axis[2])))
        out.append(_Shape(f"light_{i}_end_{name}", _sphere(sp), f"cap_{i}_{name}", L, clip))
    return out


def _sphere(sp: SphereLight) -> dict:
    return {"type": "sphere", "center": list(sp.center), "radius": sp.radius}


@dataclass(frozen=True)
class Component:
    """One Mitsuba scene (`scene`, a dict) whose emitters are one part of the lights.

    `cone` is True when every emitter in it is a sphere (Mitsuba samples the cone a sphere
    subtends, so light sampling alone has bounded values). Samples landing where
    `clip = (point, axis)` says `(x - point) . axis > 0` are discarded: the inner half of a
    capsule's end sphere, which is not part of the capsule's surface. `spheres` lists the
    (centre, radius) of the emitting spheres of a `cone` component (empty otherwise).
    """

    scene: dict
    clip: tuple[Vec3, Vec3] | None
    cone: bool
    spheres: tuple[tuple[Vec3, float], ...] = ()


def plane_axes(plane: Plane) -> tuple[np.ndarray, np.ndarray]:
    """Unit in-plane axes (u, v) with u x v = the plane's normal; u = +x, v = +y facing +z."""
    n = np.asarray(plane.normal)
    helper = np.array([1.0, 0.0, 0.0]) if abs(n[2]) >= 0.9 else np.array([0.0, 0.0, 1.0])
    u = helper - (helper @ n) * n
    u /= np.linalg.norm(u)
    return u, np.cross(n, u)


def plane_dict(mi, plane: Plane) -> dict:
    """A Mitsuba `rectangle` (object space [-1, 1]^2 at z = 0, normal +z) mapped onto `plane`.

    Object x, y, z go to h u, h v, n (`plane_axes`), so the square's sides follow u and v.
    """
    u, v = plane_axes(plane)
    h = plane.half_size
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = h * u, h * v, plane.normal, plane.point
    return {"type": "rectangle", "to_world": mi.ScalarTransform4f(m.tolist())}


def scene_components(mi, lights: Sequence[Light], plane: Plane | None = None) -> list[Component]:
    """The scene components whose irradiance sums to that of `lights` (over `plane`).

    Every component holds every shape, so shadows between lights are Mitsuba's; they differ
    in which shapes emit, in this order: disks (front faces) and capsule tubes; sphere
    lights; each capsule end's sphere alone, clipped to its outer half (rendering the ends
    with the tube would count a sliver of each inner half twice: shadow rays stop
    `ShadowEpsilon` short of their target, so the inner half is not hidden near the seam;
    measured +2% beside a capsule); last, if any disk is two-sided, the back faces. The
    plane, if any, is an occluder everywhere. `mi` is the `mitsuba` module with a variant set.
    """
    if not lights:
        raise BadValueError("lights must hold at least one light, got none")
    for i, light in enumerate(lights):
        if not isinstance(light, LIGHT_TYPES):
            raise BadTypeError(
                f"lights[{i}] must be a SphereLight, DiskLight, CapsuleLight, RectLight or "
                f"TubeLight, got {type(light).__name__}"
            )
    shapes = [sh for i, light in enumerate(lights) for sh in _shapes(mi, i, light)]
    roles = list(dict.fromkeys(sh.role for sh in shapes))
    roles.sort(key=lambda r: (r != "main", r != "spheres", r == "back"))
    has_back = {sh.key.removesuffix("_back") for sh in shapes if sh.only_in == "back"}
    components = []
    for role in roles:
        scene: dict = {"type": "scene"}
        clip = None
        cone = True
        spheres = []
        for sh in shapes:
            if sh.only_in is not None and sh.only_in != role:
                continue
            if role == "back" and sh.key in has_back:
                continue  # the front face is where the back face is
            d = dict(sh.shape)
            if sh.role == role:
                d["emitter"] = _emitter(sh.radiance)
                clip = sh.clip if sh.clip is not None else clip
                cone = cone and d["type"] == "sphere"
                if d["type"] == "sphere":
                    spheres.append((tuple(d["center"]), float(d["radius"])))
            scene[sh.key] = d
        if plane is not None:
            scene["plane"] = plane_dict(mi, plane)
        components.append(Component(scene, clip, cone, tuple(spheres) if cone else ()))
    return components


def lights_from_emitter(emitter) -> list[Light]:
    """The light records for an `attenfit` emitter (radiance from its `.radiance`).

    Accepts `attenfit.SphereEmitter`, `DiskEmitter`, `CapsuleEmitter`, `RectEmitter` and
    `TubeEmitter` (by class name and fields, so `data_gen` needs nothing else from
    `attenfit.emitters`).
    """
    kind = type(emitter).__name__
    radius = float(np.asarray(emitter.radius))
    radiance = float(np.asarray(emitter.radiance))
    if kind == "SphereEmitter":
        return [
            SphereLight(
                center=np.asarray(emitter.center, dtype=np.float64),
                radius=radius,
                radiance=radiance,
            )
        ]
    if kind == "DiskEmitter":
        return [
            DiskLight(
                center=np.asarray(emitter.center, dtype=np.float64),
                normal=np.asarray(emitter.normal, dtype=np.float64),
                radius=radius,
                radiance=radiance,
                two_sided=bool(getattr(emitter, "two_sided", False)),
            )
        ]
    if kind == "CapsuleEmitter":
        return [
            CapsuleLight(
                a=np.asarray(emitter.a, dtype=np.float64),
                b=np.asarray(emitter.b, dtype=np.float64),
                radius=radius,
                radiance=radiance,
            )
        ]
    if kind == "RectEmitter":
        return [
            RectLight(
                center=np.asarray(emitter.center, dtype=np.float64),
                normal=np.asarray(emitter.normal, dtype=np.float64),
                tangent=np.asarray(emitter.tangent, dtype=np.float64),
                width=float(emitter.width),
                height=float(emitter.height),
                radiance=radiance,
            )
        ]
    if kind == "TubeEmitter":
        return [
            TubeLight(
                a=np.asarray(emitter.a, dtype=np.float64),
                b=np.asarray(emitter.b, dtype=np.float64),
                radius=radius,
                radiance=radiance,
                caps=bool(emitter.caps),
            )
        ]
    raise BadTypeError(
        "Mitsuba ground truth supports SphereEmitter, DiskEmitter, CapsuleEmitter, RectEmitter "
        f"and TubeEmitter, got {kind}"
    )
