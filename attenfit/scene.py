"""Scene files: the lights, receivers and tolerance of one real scene, and its ground truth.

A scene says what a shader has to get right, and nothing more: which lights (their kind,
radius, position, intensity, range and spot angles), which receivers (planes, point sets or
distributions of distances and angles) and how much error is acceptable. `Scene.load`
reads a TOML file (stdlib `tomllib`) and validates every key, with errors that name the
file, the table and the key:

    scene.toml: [[lights]][1].radius: must be a positive number, got -1

(tables of an array are numbered from 0). `Scene.ground_truth()` computes the exact
irradiance (`attenfit.irradiance`) at exactly the scene's receivers from exactly the scene's
lights; `attenfit.recommend(scene)` fits and judges every family there. The file format is
documented key by key in the README ("Scene files") and in `SCENE_KEYS` below.

Conventions (DESIGN.md section 1): lengths in metres, angles in degrees in the file
(radians in the API objects' `umbra_rad`/`penumbra_rad`), `height = h` places a light at
`(0, 0, h)`, above the floor `z = 0` where planes lie by default.

Spotlights
----------
A spot is a small sphere (or a disk facing along the spot direction) whose emission is
masked by an angular profile `g(theta)` of the angle `theta` from the spot's axis: zero
beyond the umbra angle, one inside the penumbra angle. The truth is the emitter's exact
irradiance times `g`. The profile is the scene's `profile`:

* ``"aperture"`` (default): a circular source seen through a circular opening, in the
  small-angle (flat) approximation: the visible fraction of a disk of angular radius
  `b = (umbra - penumbra)/2` whose centre is `theta` from the centre of an opening of
  angular radius `a = (umbra + penumbra)/2` (the area of the lens of two circles over
  `pi b^2`), 1 for `theta <= penumbra`, 0 for `theta >= umbra`. The soft edge of a real
  projector, not any engine's formula.
* ``"linear"``: linear in the angle from penumbra to umbra.
* ``"frostbite"`` / ``"threejs"``: the engines' own curves (`attenfit.directional`), for a
  scene authored in one engine and shaded in another.
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import jax.numpy as jnp
import numpy as np

from . import directional
from ._dataset import Dataset
from ._errors import BadTypeError, BadValueError, DataFileError, UnknownNameError
from ._irradiance import irradiance
from .emitters import AbstractEmitter, CapsuleEmitter, DiskEmitter, SphereEmitter

__all__ = [
    "LIGHT_KINDS",
    "RECEIVER_KINDS",
    "SCENE_KEYS",
    "SPOT_PROFILES",
    "DistanceDistribution",
    "LightTruth",
    "PlaneReceivers",
    "PointReceivers",
    "Scene",
    "SceneLight",
    "spot_profile",
]

#: Light kinds of a scene file.
LIGHT_KINDS = ("sphere", "disk", "capsule", "spot")
#: Receiver kinds of a scene file.
RECEIVER_KINDS = ("plane", "points", "distribution")
#: True angular profiles of a spot (see the module docstring).
SPOT_PROFILES = ("aperture", "linear", "frostbite", "threejs")
#: Shapes a spot's emitter can take.
SPOT_SHAPES = ("sphere", "disk")

#: Every key of a scene file: table -> key -> one-line description (README is made from it).
SCENE_KEYS: dict[str, dict[str, str]] = {
    "top level": {
        "tolerance": "required; the largest acceptable error of the irradiance, relative (0.05 = 5%)",
        "error_floor": "optional, default 0; below `error_floor` x the light's brightest receiver, errors are measured relative to that floor instead (dim receivers do not need 5% accuracy)",
        "name": "optional; a title for the report",
        "description": "optional; free text",
        "seed": "optional integer, default 0; the seed of random receiver distributions",
    },
    "[constraints]": {
        "reach_zero_at_range": "optional, default false; the curve must reach 0 at each light's `range` (so culling there leaves no seam): only windowed families qualify, their range pinned to the light's",
        "float32": "optional, default false; shading is float32: every candidate is evaluated in float32 (fits run in float64; their parameters are rounded to float32)",
        "families": "optional list of family names; only these are candidates (default: every registered family)",
    },
    "[[lights]]": {
        "kind": "required; sphere | disk | capsule | spot",
        "radius": "required; the emitter's radius (m), > 0",
        "position": "[x, y, z] of the centre (m); give this or `height`",
        "height": "the centre's height above the floor z = 0 (m): the light sits at (0, 0, height)",
        "intensity": "optional, default 1; the point-equivalent intensity I (W/sr)",
        "range": "optional; the distance (m) beyond which the engine culls the light; receivers beyond it are not judged; windows reach 0 there",
        "normal": "disk only, default [0, 0, -1]: the emitting side",
        "two_sided": "disk only, default false",
        "length": "capsule only, required; the segment's length (m)",
        "axis": "capsule only, default [1, 0, 0]: the segment's direction",
        "umbra": "spot only, required; the cone's half-angle in degrees, 0 < umbra <= 90",
        "penumbra": "spot only, required; the half-angle of full intensity in degrees, 0 <= penumbra <= umbra",
        "direction": "spot only, default [0, 0, -1]",
        "shape": "spot only, default sphere; sphere | disk (a disk faces along `direction`)",
        "profile": "spot only, default aperture; the true angular falloff: aperture | linear | frostbite | threejs",
    },
    "[[receivers]] kind = plane": {
        "extent": "required; half-width (m) of the square grid",
        "resolution": "optional, default 16; grid points per side (2..256)",
        "center": "optional, default [0, 0, 0]",
        "normal": "optional, default [0, 0, 1]; the receivers' normal (the plane is perpendicular to it)",
    },
    "[[receivers]] kind = points": {
        "points": "required; a list of [x, y, z] (at most 4096)",
        "normals": "optional; a list of [x, y, z], one per point (default: each receiver faces the light)",
    },
    "[[receivers]] kind = distribution": {
        "distance": "required; [min, max] distance (m) from each light's centre (capsule: from its segment)",
        "angle": "optional, default [0, 0]; [min, max] degrees between a receiver's normal and the direction to the light (0 = facing it), within [0, 90]",
        "off_axis": "optional, default [0, 90]; [min, max] degrees between the light's axis (disk normal, spot direction) and the receiver's direction, within [0, 180]; ignored for spheres; capsules put receivers perpendicular to the segment",
        "n": "optional, default 64; receivers per light (1..4096)",
        "spacing": "optional, default log; log | linear spacing of distances",
    },
}

_TOP = (
    "tolerance",
    "error_floor",
    "name",
    "description",
    "seed",
    "lights",
    "receivers",
    "constraints",
)
_CONSTRAINTS = ("reach_zero_at_range", "float32", "families")
_LIGHT_COMMON = ("kind", "radius", "position", "height", "intensity", "range")
_LIGHT_EXTRA = {
    "sphere": (),
    "disk": ("normal", "two_sided"),
    "capsule": ("length", "axis"),
    "spot": ("umbra", "penumbra", "direction", "shape", "profile"),
}
_RECEIVER_KEYS = {
    "plane": ("kind", "extent", "resolution", "center", "normal"),
    "points": ("kind", "points", "normals"),
    "distribution": ("kind", "distance", "angle", "off_axis", "n", "spacing"),
}
_MAX_RECEIVERS = 4096


# ----------------------------------------------------------------------------- the objects
@dataclasses.dataclass(frozen=True)
class SceneLight:
    """One light of a scene (validated; lengths in m, angles in degrees as in the file)."""

    kind: str
    radius: float
    position: tuple[float, float, float]
    intensity: float = 1.0
    range: float | None = None
    normal: tuple[float, float, float] = (0.0, 0.0, -1.0)
    two_sided: bool = False
    length: float | None = None
    axis: tuple[float, float, float] = (1.0, 0.0, 0.0)
    umbra: float | None = None
    penumbra: float | None = None
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    shape: str = "sphere"
    profile: str = "aperture"

    @property
    def umbra_rad(self) -> float | None:
        """The umbra half-angle in radians (spots only)."""
        return None if self.umbra is None else math.radians(self.umbra)

    @property
    def penumbra_rad(self) -> float | None:
        """The penumbra half-angle in radians (spots only)."""
        return None if self.penumbra is None else math.radians(self.penumbra)

    @property
    def is_spot(self) -> bool:
        return self.kind == "spot"

    def emitter(self) -> AbstractEmitter:
        """The attenfit emitter whose exact irradiance is this light's truth (before a spot's profile)."""
        c = list(self.position)  # Python floats: the emitter takes JAX's default float dtype
        if self.kind == "sphere" or (self.kind == "spot" and self.shape == "sphere"):
            return SphereEmitter(c, self.radius, self.intensity)
        if self.kind == "disk":
            return DiskEmitter(c, list(self.normal), self.radius, self.intensity, self.two_sided)
        if self.kind == "spot":
            return DiskEmitter(c, list(self.direction), self.radius, self.intensity)
        axis = np.asarray(self.axis, dtype=np.float64)
        half = 0.5 * float(self.length) * axis / np.linalg.norm(axis)
        centre = np.asarray(c)
        return CapsuleEmitter(
            (centre - half).tolist(), (centre + half).tolist(), self.radius, self.intensity
        )

    def to_dict(self) -> dict[str, Any]:
        """The keys as a scene file would write them (defaults of other kinds left out)."""
        out: dict[str, Any] = {
            "kind": self.kind,
            "radius": self.radius,
            "position": list(self.position),
            "intensity": self.intensity,
        }
        if self.range is not None:
            out["range"] = self.range
        for key in _LIGHT_EXTRA[self.kind]:
            value = getattr(self, key)
            out[key] = list(value) if isinstance(value, tuple) else value
        return out


@dataclasses.dataclass(frozen=True)
class PlaneReceivers:
    """A square grid of receivers: `resolution`^2 points within `extent` of `center`, normals `normal`."""

    extent: float
    resolution: int = 16
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)
    kind: str = dataclasses.field(default="plane", init=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "extent": self.extent,
            "resolution": self.resolution,
            "center": list(self.center),
            "normal": list(self.normal),
        }


@dataclasses.dataclass(frozen=True)
class PointReceivers:
    """Explicit receivers; `normals` None means each receiver faces the light it is lit by."""

    points: tuple[tuple[float, float, float], ...]
    normals: tuple[tuple[float, float, float], ...] | None = None
    kind: str = dataclasses.field(default="points", init=False)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {"kind": self.kind, "points": [list(p) for p in self.points]}
        if self.normals is not None:
            out["normals"] = [list(n) for n in self.normals]
        return out


@dataclasses.dataclass(frozen=True)
class DistanceDistribution:
    """`n` receivers per light at distances and normal angles drawn from the given ranges.

    Distances `distance = (min, max)` from the light's centre (capsule: its segment), spaced
    log-uniformly (or uniformly) at random; the angle between each receiver's normal and the
    direction to the light is uniform in `angle` (degrees), and the direction from the light
    makes an angle uniform in cos within `off_axis` (degrees) with the light's axis.
    """

    distance: tuple[float, float]
    angle: tuple[float, float] = (0.0, 0.0)
    off_axis: tuple[float, float] = (0.0, 90.0)
    n: int = 64
    spacing: str = "log"
    kind: str = dataclasses.field(default="distribution", init=False)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "distance": list(self.distance),
            "angle": list(self.angle),
            "off_axis": list(self.off_axis),
            "n": self.n,
            "spacing": self.spacing,
        }


Receivers = PlaneReceivers | PointReceivers | DistanceDistribution


@dataclasses.dataclass(frozen=True)
class LightTruth:
    """The ground truth of one light at the scene's receivers.

    `dataset` holds the emitter's exact irradiance `E` (before a spot's profile) at every
    receiver the light can light (receivers inside a solid light are left out); `profile`
    is the spot's true angular factor (ones for other lights), so the true irradiance is
    `E_true = dataset.E * profile`. `theta` is the angle (radians) from the spot's axis (0 for
    other lights). `judged` marks the receivers the error is judged on: within the light's
    range and with a non-zero point-light weight (a receiver whose normal faces away from
    the light's centre gets 0 from every point-light model, whatever the family; `unlit`
    counts those where the truth is still positive, horizon-clipped light that no family
    can represent). `source` names the receiver table each receiver came from.
    """

    light: int
    dataset: Dataset
    profile: np.ndarray
    theta: np.ndarray
    judged: np.ndarray
    source: tuple[str, ...]
    beyond_range: int
    unlit: int

    @property
    def E_true(self) -> np.ndarray:
        return np.asarray(self.dataset.E, dtype=np.float64) * self.profile


@dataclasses.dataclass(frozen=True)
class Scene:
    """A validated scene: lights, receivers, tolerance and constraints (immutable).

    Build it with `Scene.load(path)` or `Scene.from_dict(d, source=...)`; every user
    error raises an `AttenfitError` naming the file, the table and the key.
    """

    lights: tuple[SceneLight, ...]
    receivers: tuple[Receivers, ...]
    tolerance: float
    error_floor: float = 0.0
    reach_zero_at_range: bool = False
    float32: bool = False
    families: tuple[str, ...] | None = None
    name: str = ""
    description: str = ""
    seed: int = 0
    source: str = "<scene>"

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(cls, path: str | os.PathLike) -> Scene:
        """Read and validate a TOML scene file."""
        path = Path(path)
        label = path.name
        try:
            raw = path.read_bytes()
        except FileNotFoundError:
            raise DataFileError(f"{label}: no such scene file ({str(path)!r})") from None
        except IsADirectoryError:
            raise DataFileError(f"{label}: is a folder, not a scene file") from None
        except OSError as exc:
            raise DataFileError(f"{label}: cannot read the scene file: {exc.strerror}") from None
        try:
            text = raw.decode("utf-8")
        except UnicodeDecodeError:
            raise DataFileError(f"{label}: not a UTF-8 text file") from None
        try:
            data = tomllib.loads(text)
        except tomllib.TOMLDecodeError as exc:
            raise DataFileError(f"{label}: TOML syntax error: {exc}") from None
        return cls.from_dict(data, source=label)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], *, source: str = "<scene>") -> Scene:
        """Validate a scene given as a dict (the parsed TOML); `source` labels errors."""
        return _parse(d, source)

    def to_dict(self) -> dict[str, Any]:
        """The scene as a dict `from_dict` accepts (and TOML can hold)."""
        out: dict[str, Any] = {"tolerance": self.tolerance, "error_floor": self.error_floor}
        if self.name:
            out["name"] = self.name
        if self.description:
            out["description"] = self.description
        out["seed"] = self.seed
        cons: dict[str, Any] = {
            "reach_zero_at_range": self.reach_zero_at_range,
            "float32": self.float32,
        }
        if self.families is not None:
            cons["families"] = list(self.families)
        out["constraints"] = cons
        out["lights"] = [light.to_dict() for light in self.lights]
        out["receivers"] = [r.to_dict() for r in self.receivers]
        return out

    # ------------------------------------------------------------------ ground truth
    def ground_truth(self) -> tuple[LightTruth, ...]:
        """Exact irradiance of each light at the scene's receivers, and nothing else.

        One `LightTruth` per light, in order. Plane and point receivers are the same for
        every light (world positions); a distribution is drawn around each light
        (deterministic in `seed` and the light's index).
        """
        return tuple(_light_truth(self, i) for i in range(len(self.lights)))

    def recommend(self, **options: Any):
        """`attenfit.recommend(self, **options)`."""
        from ._recommend import recommend

        return recommend(self, **options)


# ----------------------------------------------------------------------------- validation
class _Where:
    """Builds messages `file: table.key: what`."""

    def __init__(self, source: str, table: str = ""):
        self.source = source
        self.table = table

    def at(self, table: str) -> _Where:
        return _Where(self.source, table)

    def path(self, key: str) -> str:
        return f"{self.table}.{key}" if self.table else key

    def bad(self, key: str, what: str) -> BadValueError:
        return BadValueError(f"{self.source}: {self.path(key)}: {what}")

    def type(self, key: str, what: str) -> BadTypeError:
        return BadTypeError(f"{self.source}: {self.path(key)}: {what}")

    def table_msg(self, what: str) -> str:
        return f"{self.source}: {self.table or 'top level'}: {what}"


def _show(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], w: _Where) -> None:
    for key in table:
        if key not in allowed:
            raise UnknownNameError(
                w.table_msg(f"unknown key {key!r}; allowed: {', '.join(allowed)}")
            )


def _require(table: Mapping[str, Any], key: str, w: _Where, what: str) -> Any:
    if key not in table:
        raise BadValueError(w.table_msg(f"missing key {key!r} ({what})"))
    return table[key]


def _number(value: Any, key: str, w: _Where, *, what: str = "a number") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise w.type(key, f"must be {what}, got {_show(value)}")
    x = float(value)
    if not math.isfinite(x):
        raise w.bad(key, f"must be {what} (finite), got {_show(value)}")
    return x


def _positive(value: Any, key: str, w: _Where) -> float:
    x = _number(value, key, w, what="a positive number")
    if not x > 0:
        raise w.bad(key, f"must be a positive number, got {_show(value)}")
    return x


def _integer(value: Any, key: str, w: _Where, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise w.type(key, f"must be an integer from {lo} to {hi}, got {_show(value)}")
    if not lo <= value <= hi:
        raise w.bad(key, f"must be an integer from {lo} to {hi}, got {value}")
    return int(value)


def _boolean(value: Any, key: str, w: _Where) -> bool:
    if not isinstance(value, bool):
        raise w.type(key, f"must be true or false, got {_show(value)}")
    return value


def _string(value: Any, key: str, w: _Where) -> str:
    if not isinstance(value, str):
        raise w.type(key, f"must be a string, got {_show(value)}")
    return value


def _choice(value: Any, key: str, w: _Where, allowed: Sequence[str]) -> str:
    if not isinstance(value, str):
        raise w.type(key, f"must be one of {', '.join(allowed)}, got {_show(value)}")
    if value not in allowed:
        raise UnknownNameError(
            f"{w.source}: {w.path(key)}: unknown {key} {value!r}; allowed: {', '.join(allowed)}"
        )
    return value


def _vec3(value: Any, key: str, w: _Where, *, nonzero: bool = False) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise w.type(key, f"must be a list of 3 numbers [x, y, z], got {_show(value)}")
    v = tuple(_number(x, key, w, what="a list of 3 finite numbers") for x in value)
    if nonzero and not any(v):
        raise w.bad(key, f"must be a non-zero vector, got {_show(value)}")
    return v  # type: ignore[return-value]


def _interval(
    value: Any, key: str, w: _Where, *, lo: float, hi: float, positive: bool = False
) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise w.type(key, f"must be a list [min, max] of 2 numbers, got {_show(value)}")
    a, b = (_number(x, key, w, what="a list [min, max] of finite numbers") for x in value)
    if positive and not a > 0:
        raise w.bad(key, f"min must be > 0, got {_show(value)}")
    if not (lo <= a and b <= hi):
        raise w.bad(key, f"must lie within [{lo:g}, {hi:g}], got {_show(value)}")
    if b < a:
        raise w.bad(key, f"range is backwards (min > max): {_show(value)}")
    return (a, b)


def _table(value: Any, what: str, w: _Where) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise BadTypeError(f"{w.source}: {what}: must be a table, got {_show(value)}")
    return value


def _array_of_tables(d: Mapping[str, Any], key: str, w: _Where) -> list[Mapping[str, Any]]:
    if key not in d:
        raise BadValueError(
            f"{w.source}: missing [[{key}]]: a scene needs at least one [[{key}]] table"
        )
    value = d[key]
    if not isinstance(value, list) or not all(isinstance(t, Mapping) for t in value):
        raise BadTypeError(
            f"{w.source}: {key}: must be an array of tables ([[{key}]]), got {_show(value)}"
        )
    if not value:
        raise BadValueError(f"{w.source}: [[{key}]]: a scene needs at least one table")
    return value


def _parse(d: Mapping[str, Any], source: str) -> Scene:
    w = _Where(source)
    if not isinstance(d, Mapping):
        raise BadTypeError(f"{source}: a scene must be a table (dict), got {type(d).__name__}")
    _check_keys(d, _TOP, w)
    tolerance = _number(
        _require(d, "tolerance", w, "the largest acceptable relative error, e.g. 0.05"),
        "tolerance",
        w,
        what="a relative error in (0, 1]",
    )
    if not 0 < tolerance <= 1:
        raise w.bad("tolerance", f"must be a relative error in (0, 1], got {_show(d['tolerance'])}")
    error_floor = 0.0
    if "error_floor" in d:
        error_floor = _number(d["error_floor"], "error_floor", w, what="a number in [0, 1)")
        if not 0 <= error_floor < 1:
            raise w.bad("error_floor", f"must be a number in [0, 1), got {_show(d['error_floor'])}")
    name = _string(d["name"], "name", w) if "name" in d else ""
    description = _string(d["description"], "description", w) if "description" in d else ""
    seed = _integer(d["seed"], "seed", w, 0, 2**63 - 1) if "seed" in d else 0

    reach_zero, float32, families = False, False, None
    if "constraints" in d:
        cons = _table(d["constraints"], "constraints", w)
        wc = w.at("[constraints]")
        _check_keys(cons, _CONSTRAINTS, wc)
        if "reach_zero_at_range" in cons:
            reach_zero = _boolean(cons["reach_zero_at_range"], "reach_zero_at_range", wc)
        if "float32" in cons:
            float32 = _boolean(cons["float32"], "float32", wc)
        if "families" in cons:
            families = _family_names(cons["families"], wc)

    lights = tuple(
        _parse_light(t, w.at(f"[[lights]][{i}]"))
        for i, t in enumerate(_array_of_tables(d, "lights", w))
    )
    receivers = tuple(
        _parse_receivers(t, w.at(f"[[receivers]][{i}]"))
        for i, t in enumerate(_array_of_tables(d, "receivers", w))
    )
    if reach_zero:
        for i, light in enumerate(lights):
            if light.range is None:
                raise BadValueError(
                    f"{source}: [constraints].reach_zero_at_range: needs every light to have a "
                    f"range; [[lights]][{i}] has none"
                )
    _check_geometry(lights, receivers, w)
    return Scene(
        lights=lights,
        receivers=receivers,
        tolerance=tolerance,
        error_floor=error_floor,
        reach_zero_at_range=reach_zero,
        float32=float32,
        families=families,
        name=name,
        description=description,
        seed=seed,
        source=source,
    )


def _family_names(value: Any, w: _Where) -> tuple[str, ...]:
    from ._family import list_families

    known = list_families()
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise w.type("families", f"must be a non-empty list of family names, got {_show(value)}")
    for v in value:
        if v not in known:
            raise UnknownNameError(
                f"{w.source}: {w.path('families')}: unknown family {v!r}; allowed: {', '.join(known)}"
            )
    return tuple(dict.fromkeys(value))


def _parse_light(t: Mapping[str, Any], w: _Where) -> SceneLight:
    kind = _choice(_require(t, "kind", w, " | ".join(LIGHT_KINDS)), "kind", w, LIGHT_KINDS)
    _check_keys(t, (*_LIGHT_COMMON, *_LIGHT_EXTRA[kind]), w)
    radius = _positive(_require(t, "radius", w, "the emitter's radius in m"), "radius", w)
    if "position" in t and "height" in t:
        raise BadValueError(w.table_msg("give either 'position' or 'height', not both"))
    if "position" in t:
        position = _vec3(t["position"], "position", w)
    elif "height" in t:
        position = (0.0, 0.0, _number(t["height"], "height", w))
    else:
        raise BadValueError(
            w.table_msg("missing key 'position' ([x, y, z] in m) or 'height' (above z = 0, in m)")
        )
    kw: dict[str, Any] = {"kind": kind, "radius": radius, "position": position}
    if "intensity" in t:
        kw["intensity"] = _positive(t["intensity"], "intensity", w)
    if "range" in t:
        rng = _positive(t["range"], "range", w)
        if not rng > radius:
            raise w.bad("range", f"must exceed the radius ({radius:g}), got {_show(t['range'])}")
        kw["range"] = rng
    if kind == "disk":
        if "normal" in t:
            kw["normal"] = _vec3(t["normal"], "normal", w, nonzero=True)
        if "two_sided" in t:
            kw["two_sided"] = _boolean(t["two_sided"], "two_sided", w)
    elif kind == "capsule":
        kw["length"] = _positive(
            _require(t, "length", w, "the capsule's segment length in m"), "length", w
        )
        if "axis" in t:
            kw["axis"] = _vec3(t["axis"], "axis", w, nonzero=True)
    elif kind == "spot":
        umbra = _number(
            _require(t, "umbra", w, "the cone's half-angle in degrees"), "umbra", w,
            what="an angle in degrees",
        )  # fmt: skip
        if not 0 < umbra <= 90:
            raise w.bad("umbra", f"must be an angle in (0, 90] degrees, got {_show(t['umbra'])}")
        penumbra = _number(
            _require(t, "penumbra", w, "the half-angle of full intensity in degrees"),
            "penumbra", w, what="an angle in degrees",
        )  # fmt: skip
        if not 0 <= penumbra <= umbra:
            raise w.bad(
                "penumbra",
                f"must be an angle in [0, umbra = {umbra:g}] degrees, got {_show(t['penumbra'])}",
            )
        kw["umbra"], kw["penumbra"] = umbra, penumbra
        if "direction" in t:
            kw["direction"] = _vec3(t["direction"], "direction", w, nonzero=True)
        if "shape" in t:
            kw["shape"] = _choice(t["shape"], "shape", w, SPOT_SHAPES)
        if "profile" in t:
            kw["profile"] = _choice(t["profile"], "profile", w, SPOT_PROFILES)
    return SceneLight(**kw)


def _parse_receivers(t: Mapping[str, Any], w: _Where) -> Receivers:
    kind = _choice(_require(t, "kind", w, " | ".join(RECEIVER_KINDS)), "kind", w, RECEIVER_KINDS)
    _check_keys(t, _RECEIVER_KEYS[kind], w)
    if kind == "plane":
        kw: dict[str, Any] = {
            "extent": _positive(_require(t, "extent", w, "half-width in m"), "extent", w)
        }
        if "resolution" in t:
            kw["resolution"] = _integer(t["resolution"], "resolution", w, 2, 256)
        if "center" in t:
            kw["center"] = _vec3(t["center"], "center", w)
        if "normal" in t:
            kw["normal"] = _vec3(t["normal"], "normal", w, nonzero=True)
        return PlaneReceivers(**kw)
    if kind == "points":
        pts = _require(t, "points", w, "a list of [x, y, z]")
        if not isinstance(pts, list) or not pts:
            raise w.type("points", f"must be a non-empty list of [x, y, z], got {_show(pts)}")
        if len(pts) > _MAX_RECEIVERS:
            raise w.bad("points", f"at most {_MAX_RECEIVERS} points, got {len(pts)}")
        points = tuple(_vec3(p, f"points[{j}]", w) for j, p in enumerate(pts))
        normals = None
        if "normals" in t:
            nrm = t["normals"]
            if not isinstance(nrm, list) or len(nrm) != len(points):
                raise w.type(
                    "normals",
                    f"must be a list of {len(points)} [x, y, z] (one per point), got {_show(nrm)}",
                )
            normals = tuple(_vec3(n, f"normals[{j}]", w, nonzero=True) for j, n in enumerate(nrm))
        return PointReceivers(points=points, normals=normals)
    kw = {
        "distance": _interval(
            _require(t, "distance", w, "[min, max] in m"),
            "distance",
            w,
            lo=0.0,
            hi=math.inf,
            positive=True,
        )
    }
    if "angle" in t:
        kw["angle"] = _interval(t["angle"], "angle", w, lo=0.0, hi=90.0)
    if "off_axis" in t:
        kw["off_axis"] = _interval(t["off_axis"], "off_axis", w, lo=0.0, hi=180.0)
    if "n" in t:
        kw["n"] = _integer(t["n"], "n", w, 1, _MAX_RECEIVERS)
    if "spacing" in t:
        kw["spacing"] = _choice(t["spacing"], "spacing", w, ("log", "linear"))
    return DistanceDistribution(**kw)


def _check_geometry(
    lights: Sequence[SceneLight], receivers: Sequence[Receivers], w: _Where
) -> None:
    """Refuse receivers inside a solid light (points, distributions) before any work."""
    for i, light in enumerate(lights):
        em = light.emitter()
        solid = not isinstance(em, DiskEmitter)
        for j, rec in enumerate(receivers):
            where = f"[[receivers]][{j}]"
            if isinstance(rec, DistanceDistribution) and solid and rec.distance[0] <= light.radius:
                raise BadValueError(
                    f"{w.source}: {where}.distance: min {rec.distance[0]:g} is inside "
                    f"[[lights]][{i}] (radius {light.radius:g}); distances start at the centre"
                )
            if isinstance(rec, PointReceivers) and solid:
                inside = _inside(em, np.asarray(rec.points, dtype=np.float64), 1e-6)
                if inside.any():
                    k = int(np.argmax(inside))
                    raise BadValueError(
                        f"{w.source}: {where}.points[{k}]: lies inside [[lights]][{i}] "
                        f"(radius {light.radius:g})"
                    )


# ----------------------------------------------------------------------------- ground truth
def _inside(em: AbstractEmitter, pts: np.ndarray, margin: float) -> np.ndarray:
    if isinstance(em, DiskEmitter):
        return np.zeros(len(pts), dtype=bool)
    return _distance_to(em, pts) <= float(em.radius) * (1 + margin)


def _distance_to(em: AbstractEmitter, pts: np.ndarray) -> np.ndarray:
    """Distance of each point from the light's centre (capsule: from its segment)."""
    if isinstance(em, CapsuleEmitter):
        a = np.asarray(em.a, dtype=np.float64)
        ab = np.asarray(em.b, dtype=np.float64) - a
        t = np.clip((pts - a) @ ab / float(ab @ ab), 0, 1)
        return np.linalg.norm(pts - (a + t[:, None] * ab), axis=1)
    return np.linalg.norm(pts - np.asarray(em.reference_point(), dtype=np.float64), axis=1)


def _unit(v: Sequence[float]) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return v / np.linalg.norm(v)


def _basis(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([1.0, 0, 0]) if abs(e[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(e, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(e, u)


def _light_axis(light: SceneLight) -> np.ndarray:
    if light.kind == "disk":
        return _unit(light.normal)
    if light.kind == "spot":
        return _unit(light.direction)
    if light.kind == "capsule":
        return _unit(light.axis)
    return np.array([0.0, 0.0, -1.0])


def _plane_points(rec: PlaneReceivers) -> tuple[np.ndarray, np.ndarray]:
    up = _unit(rec.normal)
    ex, ey = _basis(up)
    xs = np.linspace(-rec.extent, rec.extent, rec.resolution)
    X, Y = np.meshgrid(xs, xs)
    c = np.asarray(rec.center, dtype=np.float64)
    pts = c + X.reshape(-1, 1) * ex + Y.reshape(-1, 1) * ey
    return pts, np.broadcast_to(up, pts.shape).copy()


def _closest(em: AbstractEmitter, pts: np.ndarray) -> np.ndarray:
    if isinstance(em, CapsuleEmitter):
        return np.asarray(em.closest_point(pts), dtype=np.float64)
    return np.broadcast_to(np.asarray(em.reference_point(), dtype=np.float64), pts.shape)


def _tilted_normals(l: np.ndarray, angle: tuple[float, float], rng) -> np.ndarray:
    """Unit normals at an angle uniform in `angle` (degrees) from the unit vectors `l`."""
    n = len(l)
    a = np.radians(rng.uniform(angle[0], angle[1], size=n))
    helper = np.where(np.abs(l[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t1 = np.cross(l, helper)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(l, t1)
    phi = rng.uniform(0, 2 * np.pi, size=n)
    t = np.cos(phi)[:, None] * t1 + np.sin(phi)[:, None] * t2
    return np.cos(a)[:, None] * l + np.sin(a)[:, None] * t


def _distribution_points(
    light: SceneLight, em: AbstractEmitter, rec: DistanceDistribution, rng
) -> tuple[np.ndarray, np.ndarray]:
    n = rec.n
    lo, hi = rec.distance
    if rec.spacing == "log":
        d = np.exp(rng.uniform(math.log(lo), math.log(hi), size=n))
    else:
        d = rng.uniform(lo, hi, size=n)
    axis = _light_axis(light)
    u, v = _basis(axis)
    phi = rng.uniform(0, 2 * np.pi, size=n)
    ring = np.cos(phi)[:, None] * u + np.sin(phi)[:, None] * v
    if isinstance(em, CapsuleEmitter):
        a = np.asarray(em.a, dtype=np.float64)
        b = np.asarray(em.b, dtype=np.float64)
        base = a + rng.uniform(0, 1, size=(n, 1)) * (b - a)
        direction = ring  # perpendicular to the segment: d is the distance to it
    else:
        base = np.broadcast_to(np.asarray(em.reference_point(), dtype=np.float64), (n, 3))
        if light.kind == "sphere":
            w = rng.normal(size=(n, 3))
            direction = w / np.linalg.norm(w, axis=1, keepdims=True)
        else:
            c0, c1 = np.cos(np.radians(rec.off_axis[0])), np.cos(np.radians(rec.off_axis[1]))
            cos_t = rng.uniform(c1, c0, size=n)
            sin_t = np.sqrt(np.clip(1 - cos_t**2, 0, 1))
            direction = cos_t[:, None] * axis + sin_t[:, None] * ring
    pts = base + d[:, None] * direction
    l = (_closest(em, pts) - pts) / d[:, None]
    return pts, _tilted_normals(l, rec.angle, rng)


def spot_profile(light: SceneLight, theta: np.ndarray) -> np.ndarray:
    """The true angular factor `g(theta)` of a spot (`theta` in radians from its axis).

    See the module docstring for the profiles; ones for a light that is not a spot.
    """
    theta = np.asarray(theta, dtype=np.float64)
    if not light.is_spot:
        return np.ones_like(theta)
    tu, tp = light.umbra_rad, light.penumbra_rad
    assert tu is not None and tp is not None
    if light.profile in ("frostbite", "threejs"):
        fn = (
            directional.spot_frostbite if light.profile == "frostbite" else directional.spot_threejs
        )
        return np.asarray(fn(jnp.asarray(np.cos(theta)), tu, tp), dtype=np.float64)
    if tu - tp < 1e-9:
        return (theta < tu).astype(np.float64)
    if light.profile == "linear":
        return np.clip((tu - theta) / (tu - tp), 0.0, 1.0)
    # aperture: visible fraction of a disk of radius b at offset theta from a disk of radius a
    a, b = 0.5 * (tu + tp), 0.5 * (tu - tp)
    x = np.clip(theta, a - b, a + b)
    xs = np.where(x > 0, x, 1.0)
    c1 = np.clip((xs * xs + b * b - a * a) / (2 * xs * b), -1, 1)
    c2 = np.clip((xs * xs + a * a - b * b) / (2 * xs * a), -1, 1)
    k = (-xs + b + a) * (xs + b - a) * (xs - b + a) * (xs + b + a)
    lens = b * b * np.arccos(c1) + a * a * np.arccos(c2) - 0.5 * np.sqrt(np.clip(k, 0, None))
    frac = np.clip(lens / (math.pi * b * b), 0.0, 1.0)
    return np.where(theta <= a - b, 1.0, np.where(theta >= a + b, 0.0, frac))


def _light_truth(scene: Scene, i: int) -> LightTruth:
    light = scene.lights[i]
    em = light.emitter()
    pts_list, nrm_list, src = [], [], []
    for j, rec in enumerate(scene.receivers):
        if isinstance(rec, PlaneReceivers):
            p, n = _plane_points(rec)
        elif isinstance(rec, PointReceivers):
            p = np.asarray(rec.points, dtype=np.float64)
            if rec.normals is None:
                q = _closest(em, p)
                n = q - p
                n /= np.where(
                    np.linalg.norm(n, axis=1, keepdims=True) > 0,
                    np.linalg.norm(n, axis=1, keepdims=True),
                    1,
                )
                n[~np.any(n != 0, axis=1)] = (0.0, 0.0, 1.0)
            else:
                n = np.asarray([_unit(v) for v in rec.normals])
        else:
            rng = np.random.default_rng([scene.seed, i, j])
            p, n = _distribution_points(light, em, rec, rng)
        keep = ~_inside(em, p, 1e-6)
        pts_list.append(p[keep])
        nrm_list.append(n[keep])
        src.extend([f"[[receivers]][{j}]"] * int(keep.sum()))
    pts = np.concatenate(pts_list)
    nrm = np.concatenate(nrm_list)
    if len(pts) == 0:
        raise BadValueError(
            f"{scene.source}: [[lights]][{i}]: every receiver lies inside this light"
        )
    E = np.asarray(irradiance(em, jnp.asarray(pts), jnp.asarray(nrm)), dtype=np.float64)
    if not np.all(np.isfinite(E)):  # a bug, not a user error: receivers inside were removed
        raise RuntimeError(f"irradiance is not finite at a receiver of light {i}")
    dtype = np.asarray(jnp.zeros(())).dtype
    ds = Dataset(
        em,
        pts.astype(dtype),
        nrm.astype(dtype),
        E.astype(dtype),
        np.zeros(len(E), dtype),
        {
            "generator": "attenfit.irradiance",
            "stderr": "exact",
            "builder": "attenfit.scene",
            "scene": scene.source,
            "light": i,
        },
    )
    if light.is_spot:
        c = np.asarray(light.position, dtype=np.float64)
        dirs = pts - c
        cos_s = dirs @ _unit(light.direction) / np.linalg.norm(dirs, axis=1)
        theta = np.arccos(np.clip(cos_s, -1, 1))
    else:
        theta = np.zeros(len(pts))
    profile = spot_profile(light, theta)
    d = _distance_to(em, pts)
    weight = np.asarray(ds.weight(), dtype=np.float64)
    within = np.ones(len(pts), bool) if light.range is None else d <= light.range
    judged = within & (weight > 0)
    unlit = int(np.sum(within & ~(weight > 0) & (E * profile > 0)))
    return LightTruth(
        light=i,
        dataset=ds,
        profile=profile,
        theta=theta,
        judged=judged,
        source=tuple(src),
        beyond_range=int(np.sum(~within)),
        unlit=unlit,
    )
