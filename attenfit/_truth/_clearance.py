"""How close to a light's surface a receiver may be: the receivers a float32 renderer can judge.

The exact irradiance is defined arbitrarily close to a light, but the independent witness
(Mitsuba 3, `data_gen`) works in float32, and so do real renderers. Two limits follow from its
source:

* **Mitsuba's ray offset.** A ray spawned at a surface point p starts
  `(1 + max_i |p_i|) * RayEpsilon` along the surface normal, `RayEpsilon = 1500 * 2^-24`
  (Dr.Jit's float32 `Epsilon` is 2^-24): `Interaction::offset_p` in
  `include/mitsuba/render/interaction.h` and `RayEpsilon` in `include/mitsuba/core/math.h`
  (shadow rays stop `ShadowEpsilon = 10 RayEpsilon` of their length short of their target,
  `Interaction::spawn_ray_to`). With p = 0.3 m that is 1.2e-4 m: a receiver nearer a light
  than that, spawning its rays the standard way, starts them behind the light (a disk: 0.0146
  for an exact 10.47) or beside it (a sphere: off by up to 89% within 2e-4 r). `data_gen`
  therefore spawns shadow rays from the light's surface, where the offset belongs, and
  cosine rays from the receiver itself (`data_gen.estimate`); `ray_offset` gives the limit.
* **float32 resolution.** What remains is how finely float32 places a receiver against a
  surface: coordinates round to 2^-24 of the scene's scale (`scene_scale`: the largest
  coordinate of the receiver, or of the light's extent around its centre), and the
  intersection routines (`src/shapes/{sphere,disk,cylinder,rectangle}.cpp`) subtract such
  coordinates (a sphere's `|o - c|^2 - r^2` cancels to 2^-24 of r^2). A receiver on a plane
  (which must leave it) starts its rays `SURFACE_OFFSET * scale` above it.

So every receiver must clear every light's surface by `CLEARANCE * scale` = 2^-16 of the
scale, twice the surface offset and 512 float32 steps: 7.6e-6 m for a light of radius 0.5 at
the origin and receivers within 0.5 m of its centre. `attenfit truth`'s builders never make
a receiver nearer (`too_close`), and `data_gen` refuses one, so `attenfit gen` and
`attenfit truth` make the same receivers and every one of them is judged.
"""

from __future__ import annotations

import numpy as np

from ._emitters import AbstractEmitter

__all__ = [
    "CLEARANCE",
    "RAY_EPSILON",
    "SHADOW_EPSILON",
    "SURFACE_OFFSET",
    "ray_offset",
    "scene_scale",
    "surface_distance",
    "too_close",
]

#: Mitsuba 3's relative ray epsilon (`include/mitsuba/core/math.h`): 1500 float32 epsilons.
RAY_EPSILON = 1500 * 2.0**-24
#: Mitsuba 3's shadow-ray shortening, relative to the ray's length: 10 RayEpsilon.
SHADOW_EPSILON = 10 * RAY_EPSILON
#: Where a receiver on a plane starts its rays, relative to the scene's scale: 2^-17.
SURFACE_OFFSET = 2.0**-17
#: The clearance every receiver keeps from every light's surface, relative to the scale.
CLEARANCE = 2.0 * SURFACE_OFFSET


def ray_offset(points: np.ndarray) -> np.ndarray:
    """Mitsuba's spawn offset at `points` (n, 3): `(1 + max_i |p_i|) RayEpsilon` (metres)."""
    p = np.asarray(points, dtype=np.float64)
    return (1.0 + np.abs(p).max(axis=-1)) * RAY_EPSILON


def scene_scale(emitter: AbstractEmitter, points: np.ndarray) -> np.ndarray:
    """The float32 scale at each receiver: the largest coordinate of it or of the light (n,)
    (the light's: `AbstractEmitter.extent`, its bounding box's)."""
    p = np.asarray(points, dtype=np.float64)
    return np.maximum(np.abs(p).max(axis=-1), emitter.extent())


def surface_distance(emitter: AbstractEmitter, points: np.ndarray) -> np.ndarray:
    """Distance (m) from each receiver (n, 3) to the light's surface (n,); 0 inside a solid
    light (`AbstractEmitter.surface_distance`: a sphere's `|p - c| - r`, a capsule's distance
    to its segment minus r; a disk's, a rectangle's and a tube's, as a solid cylinder, to the
    nearest point of the closed shape)."""
    return emitter.surface_distance(np.asarray(points, dtype=np.float64))


def too_close(emitter: AbstractEmitter, points: np.ndarray) -> np.ndarray:
    """Receivers (n, 3) nearer the light's surface than `CLEARANCE * scene_scale` (n,) bool.

    Inside a solid light counts as too close. The rule `attenfit truth`'s builders and
    `data_gen` share (see the module docstring for where it comes from).
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    return surface_distance(emitter, p) < CLEARANCE * scene_scale(emitter, p)
