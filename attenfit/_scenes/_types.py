"""The parts of a scene: its lights, its receiver sets, and the ground truth of one light."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .._truth import (
    AbstractEmitter,
    CapsuleEmitter,
    Dataset,
    DiskEmitter,
    RectEmitter,
    SphereEmitter,
    TubeEmitter,
)

#: Light kinds of a scene file.
LIGHT_KINDS = ("sphere", "disk", "capsule", "spot", "rect", "tube")
#: Receiver kinds of a scene file.
RECEIVER_KINDS = ("plane", "points", "distribution")
#: True angular profiles of a spot (see the module docstring).
SPOT_PROFILES = ("aperture", "linear", "frostbite", "threejs")
#: Shapes a spot's emitter can take.
SPOT_SHAPES = ("sphere", "disk")

LIGHT_EXTRA = {
    "sphere": (),
    "disk": ("normal", "two_sided"),
    "capsule": ("length", "axis"),
    "spot": ("umbra", "penumbra", "direction", "shape", "profile"),
    "rect": ("normal", "tangent", "size"),
    "tube": ("length", "axis", "caps"),
}


# ----------------------------------------------------------------------------- the objects
@dataclasses.dataclass(frozen=True)
class SceneLight:
    """One light of a scene (validated; lengths in m, angles in degrees as in the file).

    A rectangle (`kind` "rect") is `size` = (width along `tangent`, height along `normal x
    tangent`), emitting along `normal`; its `radius` is the equal-area disk's,
    `sqrt(w h / pi)` (as `RectEmitter.radius`). A tube is `length` along `axis` around
    `position`, of `radius`, with its end disks if `caps`.
    """

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
    tangent: tuple[float, float, float] = (1.0, 0.0, 0.0)
    size: tuple[float, float] | None = None
    caps: bool = False

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
        if self.kind == "rect":
            w, h = self.size or (2 * self.radius, 2 * self.radius)
            return RectEmitter(c, list(self.normal), list(self.tangent), w, h, self.intensity)
        axis = np.asarray(self.axis, dtype=np.float64)
        half = 0.5 * float(self.length) * axis / np.linalg.norm(axis)
        a, b = (np.asarray(c) - half).tolist(), (np.asarray(c) + half).tolist()
        if self.kind == "tube":
            return TubeEmitter(a, b, self.radius, self.intensity, self.caps)
        return CapsuleEmitter(a, b, self.radius, self.intensity)

    def to_dict(self) -> dict[str, Any]:
        """The keys as a scene file would write them (defaults of other kinds left out)."""
        out: dict[str, Any] = {
            "kind": self.kind,
            "radius": self.radius,
            "position": list(self.position),
            "intensity": self.intensity,
        }
        if self.kind == "rect":  # its radius is the equal-area disk's, from its size
            del out["radius"]
        if self.range is not None:
            out["range"] = self.range
        for key in LIGHT_EXTRA[self.kind]:
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
    """Explicit receivers; `normals` None means each receiver faces the light it is lit by.

    `light` set to a light's index makes them that light's receivers only (a USD or glTF
    scene samples each light's receivers where it reaches); None, every light's. Points
    and normals may be tuples or (n, 3) float64 arrays (a sampled scene's thousands).
    """

    points: Any
    normals: Any = None
    light: int | None = None
    kind: str = dataclasses.field(default="points", init=False)

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "kind": self.kind,
            "points": [[float(x) for x in p] for p in self.points],
        }
        if self.normals is not None:
            out["normals"] = [[float(x) for x in n] for n in self.normals]
        if self.light is not None:
            out["light"] = self.light
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
