"""A scene's ground truth: the exact irradiance of each light at the scene's receivers, and
nowhere else.

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

import math
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import jax
import jax.numpy as jnp
import numpy as np

from .. import _cache
from .._curves import spot_frostbite, spot_threejs
from .._errors import BadValueError
from .._truth import (
    AbstractEmitter,
    CapsuleEmitter,
    Dataset,
    DiskEmitter,
    RectEmitter,
    TubeEmitter,
    irradiance,
)
from ._types import (
    DistanceDistribution,
    LightTruth,
    PlaneReceivers,
    PointReceivers,
    SceneLight,
)

if TYPE_CHECKING:
    from ._scene import Scene


# ----------------------------------------------------------------------------- ground truth
#: Lights around a segment `a -> b` (distances from the segment, receivers beside it).
_SEGMENT = (CapsuleEmitter, TubeEmitter)


def inside_light(em: AbstractEmitter, pts: np.ndarray, margin: float) -> np.ndarray:
    if isinstance(em, DiskEmitter | RectEmitter):
        return np.zeros(len(pts), dtype=bool)
    if isinstance(em, TubeEmitter):  # the solid cylinder, no end hemispheres
        a = np.asarray(em.a, dtype=np.float64)
        ab = np.asarray(em.b, dtype=np.float64) - a
        with np.errstate(over="ignore", invalid="ignore"):
            t = np.nan_to_num((pts - a) @ ab / float(ab @ ab))
        rho = _length(pts - (a + t[:, None] * ab))
        grow = margin * float(em.radius) / float(np.linalg.norm(ab))
        return (rho <= float(em.radius) * (1 + margin)) & (t >= -grow) & (t <= 1 + grow)
    return _distance_to(em, pts) <= float(em.radius) * (1 + margin)


def _length(v: np.ndarray) -> np.ndarray:
    """|v| per row, by hypot: no overflow for coordinates up to the largest float."""
    return np.hypot(np.hypot(v[:, 0], v[:, 1]), v[:, 2])


def _distance_to(em: AbstractEmitter, pts: np.ndarray) -> np.ndarray:
    """Distance of each point from the light's centre (capsule, tube: from its segment)."""
    if isinstance(em, _SEGMENT):
        a = np.asarray(em.a, dtype=np.float64)
        ab = np.asarray(em.b, dtype=np.float64) - a
        with np.errstate(over="ignore", invalid="ignore"):
            t = np.nan_to_num(np.clip((pts - a) @ ab / float(ab @ ab), 0, 1))
        return _length(pts - (a + t[:, None] * ab))
    return _length(pts - np.asarray(em.reference_point(), dtype=np.float64))


def _unit(v: Sequence[float]) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    v = v / np.max(np.abs(v))  # first to the order of 1: |v|^2 of [0, 0, 1e-200] underflows to 0
    return v / np.linalg.norm(v)


def _basis(e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    helper = np.array([1.0, 0, 0]) if abs(e[0]) < 0.9 else np.array([0, 1.0, 0])
    u = np.cross(e, helper)
    u /= np.linalg.norm(u)
    return u, np.cross(e, u)


def _light_axis(light: SceneLight) -> np.ndarray:
    if light.kind in ("disk", "rect"):
        return _unit(light.normal)
    if light.kind == "spot":
        return _unit(light.direction)
    if light.kind in ("capsule", "tube"):
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
    if isinstance(em, _SEGMENT):
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
    if isinstance(em, _SEGMENT):
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
        fn = spot_frostbite if light.profile == "frostbite" else spot_threejs
        return _cache.cached_array(
            "values",
            ("spot-profile", light.profile, theta, tu, tp),
            lambda: np.asarray(fn(jnp.asarray(np.cos(theta)), tu, tp), dtype=np.float64),
            shape=np.shape(theta),
        )
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


#: Receivers farther than this many light radii are refused: the curves are vouched for up to
#: 1e12 r (tests/test_families_stability.py), and the irradiance there underflows anyway.
_MAX_D_OVER_R = 1e12


def _facing_normals(em: AbstractEmitter, p: np.ndarray) -> np.ndarray:
    """Unit normals from each point to the light's closest point (its centre, or its segment's)."""
    n = _closest(em, p) - p
    norm = np.linalg.norm(n, axis=1, keepdims=True)
    n /= np.where(norm > 0, norm, 1)
    n[~np.any(n != 0, axis=1)] = (0.0, 0.0, 1.0)
    return n


def _receivers_of(
    scene: Scene, i: int, em: AbstractEmitter
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """The receivers of light `i` outside it: points, unit normals, and their tables."""
    light = scene.lights[i]
    pts_list, nrm_list, src = [], [], []
    for j, rec in enumerate(scene.receivers):
        if isinstance(rec, PointReceivers) and rec.light not in (None, i):
            continue
        if isinstance(rec, PlaneReceivers):
            p, n = _plane_points(rec)
        elif isinstance(rec, PointReceivers):
            p = np.asarray(rec.points, dtype=np.float64)
            if rec.normals is None:
                n = _facing_normals(em, p)
            else:
                n = np.asarray(rec.normals, dtype=np.float64).reshape(-1, 3)
                n = n / np.linalg.norm(n, axis=1, keepdims=True)
        else:
            rng = np.random.default_rng([scene.seed, i, j])
            p, n = _distribution_points(light, em, rec, rng)
        keep = ~inside_light(em, p, 1e-6)
        pts_list.append(p[keep])
        nrm_list.append(n[keep])
        src.extend([f"[[receivers]][{j}]"] * int(keep.sum()))
    pts = np.concatenate(pts_list) if pts_list else np.zeros((0, 3))
    nrm = np.concatenate(nrm_list) if nrm_list else np.zeros((0, 3))
    if len(pts) == 0:
        raise BadValueError(
            f"{scene.source}: [[lights]][{i}]: every receiver lies inside this light"
        )
    return pts, nrm, src


def bucket(n: int, lo: int = 64) -> int:
    """The next power of two >= max(n, lo)."""
    return max(lo, 1 << max(0, (n - 1).bit_length()))


def bucketed(fn: Callable[..., Any], *arrays: np.ndarray, axis: int = -1) -> np.ndarray:
    """`fn(*arrays)` on the arrays padded along `axis` to a power of two (`bucket`) with
    copies of their last entry, and cut back: a program is compiled per shape, so the lights
    of every scene (and of a scene edited) with a similar number of receivers share one."""
    n = arrays[0].shape[axis]
    pad = bucket(n) - n
    if pad == 0 or n == 0:
        return np.asarray(fn(*arrays))

    def padded(a: np.ndarray) -> np.ndarray:
        last = np.take(a, [n - 1], axis=axis)
        return np.concatenate([a, np.repeat(last, pad, axis=axis)], axis=axis)

    out = np.asarray(fn(*map(padded, arrays)))
    return np.take(out, np.arange(n), axis=axis)


def _exact(scene: Scene, i: int, em: AbstractEmitter, pts: np.ndarray, nrm: np.ndarray) -> Dataset:
    """The light's exact irradiance at the receivers, as a dataset in JAX's default float."""
    E = _cache.cached_array(
        "values",
        ("scene-irradiance", em, pts, nrm, jax.config.jax_enable_x64),
        lambda: bucketed(lambda p, n: irradiance(em, p, n), pts, nrm, axis=0).astype(np.float64),
        shape=(len(pts),),
    )
    if not np.all(np.isfinite(E)):  # a bug, not a user error: receivers inside were removed
        raise RuntimeError(f"irradiance is not finite at a receiver of light {i}")
    dtype = np.asarray(jnp.zeros(())).dtype
    return Dataset(
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


def light_truth(scene: Scene, i: int) -> LightTruth:
    """The exact irradiance of light `i` (sphere, disk, capsule, spot, rectangle or tube: its
    `SceneLight.emitter()`) at the scene's receivers, and which of them are judged."""
    light = scene.lights[i]
    em = light.emitter()
    pts, nrm, src = _receivers_of(scene, i, em)
    d = _distance_to(em, pts)
    far = float(np.max(d)) / float(light.radius)
    if not far <= _MAX_D_OVER_R:
        where = src[int(np.argmax(d))]
        raise BadValueError(
            f"{scene.source}: {where}: a receiver lies {far:.3g} radii from [[lights]][{i}] "
            f"({float(np.max(d)):.3g} m), "
            f"beyond the {_MAX_D_OVER_R:.0e} radii within which attenfit judges a curve"
        )
    ds = _exact(scene, i, em, pts, nrm)
    if light.is_spot:
        c = np.asarray(light.position, dtype=np.float64)
        dirs = pts - c
        cos_s = dirs @ _unit(light.direction) / np.linalg.norm(dirs, axis=1)
        theta = np.arccos(np.clip(cos_s, -1, 1))
    else:
        theta = np.zeros(len(pts))
    profile = spot_profile(light, theta)
    weight = np.asarray(ds.weight(), dtype=np.float64)
    within = np.ones(len(pts), bool) if light.range is None else d <= light.range
    judged = within & (weight > 0)
    if not np.any(judged & (profile > 0)):
        why = (
            "inside its range, in front of it and inside its cone"
            if light.is_spot
            else "inside its range and in front of it"
        )
        raise BadValueError(
            f"{scene.source}: [[lights]][{i}]: no receiver lies {why}: there is nothing to judge "
            "a curve on (aim the light at a receiver, or add receivers it reaches)"
        )
    E = np.asarray(ds.E, dtype=np.float64)
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
