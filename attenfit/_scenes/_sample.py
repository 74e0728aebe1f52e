"""Receivers of a USD or glTF scene: points sampled on its meshes, area-weighted, with their
shading normals, kept only where a light can reach them.

A mesh arrives here as world-space triangles (`Mesh`: corner positions and corner shading
normals, already through the prim's or node's world transform). For each light, points are
drawn uniformly by area over the triangles that can be within its range (barycentric
coordinates `(1 - sqrt(u), sqrt(u) (1 - v), sqrt(u) v)`: Osada et al. 2002, "Shape
distributions", eq. 1), their normals interpolated from the corners and normalised, and a
point is kept when the light can reach it:

* within the light's range, when it has one;
* in front of the light: on the emitting side of a disk's plane, inside a spot's cone;
* above the horizon of the receiving face: the light's centre on the side its shading normal
  points to. A double-sided face (glTF `material.doubleSided`, USD `doubleSided`) is lit on
  whichever side faces the light: its normal is turned toward it, as a renderer flips a
  back face's normal;
* outside a solid light.

Occlusion is not traced: attenfit compares attenuation curves, and a shadow multiplies the
truth and every curve alike.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from jaxtyping import Float

from .._errors import BadValueError
from ._lighting import inside_light
from ._types import SceneLight

__all__ = ["Mesh", "sample_receivers", "transform_normals", "triangle_areas"]


@dataclasses.dataclass(frozen=True)
class Mesh:
    """World-space triangles of one mesh: `corners[t, k]` is corner k of triangle t and
    `normals[t, k]` its shading normal (unit); `name` is the prim path or node name."""

    name: str
    corners: Float[np.ndarray, "t 3 3"]
    normals: Float[np.ndarray, "t 3 3"]
    double_sided: bool = False


def triangle_areas(corners: Float[np.ndarray, "t 3 3"]) -> Float[np.ndarray, " t"]:
    """Area of each triangle, |(b - a) x (c - a)| / 2."""
    return 0.5 * np.linalg.norm(
        np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1
    )


def transform_normals(
    m: Float[np.ndarray, "4 4"], n: Float[np.ndarray, "k 3"]
) -> Float[np.ndarray, "k 3"]:
    """Normals through the row-vector transform `m` (points map as `p @ m[:3, :3] + m[3, :3]`):
    by the inverse transpose of its linear part, then normalised (zero normals stay zero)."""
    lin = np.linalg.inv(m[:3, :3]).T
    out = n @ lin
    norm = np.linalg.norm(out, axis=1, keepdims=True)
    return np.where(norm > 0, out / np.where(norm > 0, norm, 1), 0.0)


def check_mesh(mesh: Mesh, source: str) -> None:
    """Refuse a mesh with non-finite coordinates or no area at all (one line, naming it)."""
    if not (np.all(np.isfinite(mesh.corners)) and np.all(np.isfinite(mesh.normals))):
        raise BadValueError(f"{source}: mesh {mesh.name!r}: non-finite points or normals")
    if mesh.corners.size == 0 or not float(triangle_areas(mesh.corners).sum()) > 0:
        raise BadValueError(
            f"{source}: mesh {mesh.name!r}: degenerate (no triangle with a non-zero area)"
        )


def _reach_radius(light: SceneLight) -> float:
    return np.inf if light.range is None else float(light.range)


def _reaches(
    light: SceneLight, pts: np.ndarray, nrm: np.ndarray, double: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Which points the light reaches (see the module docstring), and their normals (double-
    sided faces turned toward the light)."""
    c = np.asarray(light.position, dtype=np.float64)
    to_light = c - pts
    dist = np.linalg.norm(to_light, axis=1)
    facing = np.einsum("ij,ij->i", nrm, to_light)
    flip = double & (facing < 0)
    nrm = np.where(flip[:, None], -nrm, nrm)
    keep = np.abs(facing) > 1e-12 * dist  # not edge-on
    keep &= (facing > 0) | flip
    if light.range is not None:
        keep &= dist <= light.range
    if light.kind in ("disk", "rect"):  # one-sided: its lit half-space
        axis = np.asarray(light.normal, dtype=np.float64)
        keep &= (pts - c) @ axis > 0
    elif light.kind == "spot":
        axis = np.asarray(light.direction, dtype=np.float64)
        axis = axis / np.linalg.norm(axis)
        cos_t = ((pts - c) @ axis) / np.where(dist > 0, dist, 1)
        keep &= cos_t > np.cos(np.radians(light.umbra))  # type: ignore[arg-type]
        if light.shape == "disk":
            keep &= (pts - c) @ axis > 0
    keep &= ~inside_light(light.emitter(), pts, 1e-6)
    return keep, nrm


def sample_receivers(
    light: SceneLight, meshes: list[Mesh], n: int, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, int]:
    """Up to `n` receivers on `meshes` that `light` reaches: (points, normals, tried).

    Draws rounds of points by area over the triangles that can lie within the light's range
    until `n` are kept or 8 rounds have drawn `64 n` points (a light that reaches little of
    the scene gets the receivers there are); `tried` counts the points drawn.
    """
    c = np.asarray(light.position, dtype=np.float64)
    reach = _reach_radius(light)
    tris, tnrm, dbl = [], [], []
    for m in meshes:
        sel = np.ones(len(m.corners), bool)
        if np.isfinite(reach):  # triangles whose bounding sphere meets the range
            centre = m.corners.mean(axis=1)
            rad = np.linalg.norm(m.corners - centre[:, None], axis=2).max(axis=1)
            sel = np.linalg.norm(centre - c, axis=1) - rad <= reach
        tris.append(m.corners[sel])
        tnrm.append(m.normals[sel])
        dbl.append(np.full(int(sel.sum()), m.double_sided))
    corners = np.concatenate(tris) if tris else np.zeros((0, 3, 3))
    normals = np.concatenate(tnrm) if tnrm else np.zeros((0, 3, 3))
    double = np.concatenate(dbl) if dbl else np.zeros(0, bool)
    area = triangle_areas(corners)
    if corners.size == 0 or not area.sum() > 0:
        return np.zeros((0, 3)), np.zeros((0, 3)), 0
    cdf = np.cumsum(area)
    cdf /= cdf[-1]
    kept_p, kept_n, have, tried = [], [], 0, 0
    batch = n
    for _ in range(8):
        t = np.minimum(np.searchsorted(cdf, rng.uniform(size=batch), side="right"), len(cdf) - 1)
        su = np.sqrt(rng.uniform(size=batch))
        v = rng.uniform(size=batch)
        w = np.stack([1 - su, su * (1 - v), su * v], axis=1)
        pts = np.einsum("ik,ikj->ij", w, corners[t])
        nrm = np.einsum("ik,ikj->ij", w, normals[t])
        norm = np.linalg.norm(nrm, axis=1, keepdims=True)
        ok = norm[:, 0] > 1e-12
        nrm = nrm / np.where(norm > 0, norm, 1)
        keep, nrm = _reaches(light, pts, nrm, double[t])
        keep &= ok
        kept_p.append(pts[keep])
        kept_n.append(nrm[keep])
        have += int(keep.sum())
        tried += batch
        if have >= n or tried >= 64 * n:
            break
        frac = max(have / tried, 1 / 64)
        batch = min(int(1.2 * (n - have) / frac) + 16, 64 * n - tried)
    pts = np.concatenate(kept_p)[:n]
    nrm = np.concatenate(kept_n)[:n]
    return pts, nrm, tried
