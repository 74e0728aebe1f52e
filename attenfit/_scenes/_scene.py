"""`Scene`: a validated scene file (lights, receivers, tolerance, constraints) and its truth."""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Mapping
from typing import Any

from .. import _budget
from .._float64 import in_float64
from ._lighting import light_truth
from ._toml import parse_scene, read_toml
from ._types import (
    LightTruth,
    PlaneReceivers,
    PointReceivers,
    Receivers,
    SceneLight,
)


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
    precision: str = "float64"
    families: tuple[str, ...] | None = None
    name: str = ""
    description: str = ""
    seed: int = 0
    source: str = "<scene>"
    #: Parameters an engine fixes, per family (`{"frostbite_window": {"r_min": 0.01}}`): pinned,
    #: not fitted. Set by `--engine`; a TOML scene has none.
    fixed: Mapping[str, Mapping[str, float]] | None = None
    #: The spot falloffs ("frostbite", "threejs") an engine can express; None: both.
    spot_falloffs: tuple[str, ...] | None = None

    def __post_init__(self) -> None:
        if self.float32 and self.precision == "float64":  # `float32=True` says float32
            object.__setattr__(self, "precision", "float32")
        object.__setattr__(self, "float32", self.precision == "float32")

    # ------------------------------------------------------------------ construction
    @classmethod
    def load(cls, path: str | os.PathLike) -> Scene:
        """Read and validate a TOML scene file."""
        data, label = read_toml(path)
        return cls.from_dict(data, source=label)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], *, source: str = "<scene>") -> Scene:
        """Validate a scene given as a dict (the parsed TOML); `source` labels errors."""
        return cls(**parse_scene(d, source))

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
            "precision": self.precision,
        }
        if self.families is not None:
            cons["families"] = list(self.families)
        out["constraints"] = cons
        out["lights"] = [light.to_dict() for light in self.lights]
        out["receivers"] = [r.to_dict() for r in self.receivers]
        return out

    # ------------------------------------------------------------------ ground truth
    @in_float64
    def ground_truth(self) -> tuple[LightTruth, ...]:
        """Exact irradiance of each light at the scene's receivers, and nothing else.

        One `LightTruth` per light, in order. Plane and point receivers are the same for
        every light (world positions); a distribution is drawn around each light
        (deterministic in `seed` and the light's index).
        """
        check_memory(self)
        return tuple(light_truth(self, i) for i in range(len(self.lights)))


#: Peak memory of `attenfit scene` per (light, receiver) pair and its baseline, measured by
#: `python -m benchmarks memory` (0.8 kB a pair above about 1 GB) and rounded up.
BYTES_PER_PAIR = 2048
BYTES_BASE = 1 << 30


def receiver_count(receivers: tuple[Receivers, ...]) -> int:
    """How many receivers the scene's receiver tables hold (for each light)."""
    total = 0
    for r in receivers:
        if isinstance(r, PlaneReceivers):
            total += r.resolution**2
        elif isinstance(r, PointReceivers):
            total += len(r.points)
        else:
            total += int(r.n)
    return total


def check_memory(scene: Scene) -> None:
    """Refuse, before any work, a scene whose truth and fits would exceed the memory budget."""
    n = receiver_count(scene.receivers)
    pairs = n * len(scene.lights)
    _budget.check(
        BYTES_BASE + BYTES_PER_PAIR * pairs,
        f"{scene.source}: {len(scene.lights)} lights x {n:,} receivers",
        "fewer receivers (a plane's resolution, a distribution's n) or fewer lights",
    )
