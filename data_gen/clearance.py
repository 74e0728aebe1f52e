"""Where rays start, and which receivers are too close to a light to judge.

Mitsuba spawns a ray from a surface point `(1 + max|p|) * RayEpsilon` (1500 float32 epsilons)
along the normal (`Interaction::offset_p`, `include/mitsuba/render/interaction.h`). Our
receivers are not on a surface (except those on an occluding plane), so that offset only
moves them: with p = 0.3 m it is 1.2e-4 m, and a receiver nearer a light than that starts its
rays behind or beside it. So `data_gen.estimate` spawns each shadow ray from the light's
surface towards the receiver (Mitsuba's `spawn_ray_to` from the sampled point, where its
offset belongs), and each cosine-sampled ray from the receiver itself (`ray_origins`): free
receivers from their own point, receivers on the occluding plane `SURFACE_OFFSET` of the
scene's scale above it. What float32 cannot resolve is refused with the rule `attenfit
truth`'s builders use (`attenfit._truth._clearance`): a receiver must clear every light's
surface by 2^-16 of the scene's scale.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from attenfit import (
    BadValueError,
    CapsuleEmitter,
    DiskEmitter,
    RectEmitter,
    SphereEmitter,
    TubeEmitter,
)
from attenfit._truth._clearance import (
    CLEARANCE,
    SURFACE_OFFSET,
    scene_scale,
    surface_distance,
)

from .scenes import CapsuleLight, DiskLight, Light, Plane, RectLight, SphereLight, TubeLight

__all__ = ["check_clearance", "emitter_of", "ray_origins"]


def emitter_of(light: Light):
    """The `attenfit` emitter with `light`'s geometry (intensity 1: only the shape matters)."""
    if isinstance(light, SphereLight):
        return SphereEmitter(light.center, light.radius, 1.0)
    if isinstance(light, DiskLight):
        return DiskEmitter(light.center, light.normal, light.radius, 1.0, light.two_sided)
    if isinstance(light, CapsuleLight):
        return CapsuleEmitter(light.a, light.b, light.radius, 1.0)
    if isinstance(light, RectLight):
        return RectEmitter(light.center, light.normal, light.tangent, light.width, light.height)
    if isinstance(light, TubeLight):
        return TubeEmitter(light.a, light.b, light.radius, 1.0, light.caps)
    raise BadValueError(f"not a light: {light!r}")


def _scale(emitters: Sequence, points: np.ndarray) -> np.ndarray:
    return np.max([scene_scale(e, points) for e in emitters], axis=0)


def check_clearance(lights: Sequence[Light], points: np.ndarray) -> None:
    """Refuse a receiver nearer a light's surface than 2^-16 of the scene's scale (or inside)."""
    emitters = [emitter_of(light) for light in lights]
    scale = _scale(emitters, points)
    for light, em in zip(lights, emitters, strict=True):
        gap = surface_distance(em, points)
        bad = np.flatnonzero(gap < CLEARANCE * scale)
        if bad.size:
            i = int(bad[0])
            kind = type(light).__name__.removesuffix("Light").lower()
            where = "inside or on" if gap[i] == 0 else f"{gap[i]:.3g} m from the surface of"
            raise BadValueError(
                f"points[{i}] is {where} a {kind} light (radius {light.radius:g}); receivers "
                f"must clear every light by {CLEARANCE * scale[i]:.3g} m (2^-16 of the scene's "
                "scale: float32 cannot place them nearer; attenfit's builders never do)"
            )


def ray_origins(
    lights: Sequence[Light], points: np.ndarray, normals: np.ndarray, plane: Plane | None
) -> np.ndarray:
    """Where each receiver's cosine-sampled rays start (n, 3): the receiver itself, or for a
    receiver on `plane` (within 2^-17 of the scale), `SURFACE_OFFSET * scale` along its normal."""
    p = np.asarray(points, dtype=np.float64)
    if plane is None:
        return p.copy()
    scale = _scale([emitter_of(light) for light in lights], p)
    height = np.abs((p - np.asarray(plane.point)) @ np.asarray(plane.normal))
    on = height <= SURFACE_OFFSET * scale
    lift = np.where(on, SURFACE_OFFSET * scale, 0.0)
    return p + lift[:, None] * np.asarray(normals, dtype=np.float64)
