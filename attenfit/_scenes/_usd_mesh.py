"""The meshes of a USD scene (for `_usd`): each `UsdGeom.Mesh` triangulated in world space,
lengths in metres, its attributes read at the scene's time (`_usd_attrs.UsdTime`).

A mesh is sampled as its control cage (Blender writes `subdivisionScheme = "none"`); faces
are fan-triangulated; authored shading normals (`primvars:normals`, or `normals`) are used
when their count matches their interpolation, else geometric normals (`orientation`
`leftHanded` flips them). The memory the meshes need together is checked against the budget
from their point and face-vertex counts before any is triangulated (`check_mesh_memory`).
"""

from __future__ import annotations

import math

import numpy as np

from .. import _budget
from .._errors import BadTypeError, BadValueError
from ._sample import Mesh, check_mesh, transform_normals
from ._usd_attrs import UsdTime, prim_errors, show, value_length, world_matrix
from ._usd_layers import UsdLayers

__all__ = ["BYTES_PER_POINT", "BYTES_PER_TRIANGLE", "check_mesh_memory", "read_mesh"]

#: Memory per triangle and per point of a mesh while it is read and sampled (peak above the
#: baseline: 622 bytes per triangle for a 2,000,000-triangle grid with vertex normals,
#: `python -m attenfit` on 2 cores), rounded up; what the meshes need together is checked
#: against the memory budget before any is triangulated.
BYTES_PER_TRIANGLE = 1024
BYTES_PER_POINT = 128


def _scales(m: np.ndarray) -> np.ndarray:
    """The lengths of the transformed unit axes (row-vector matrices: rows 0..2)."""
    return np.linalg.norm(m[:3, :3], axis=1)


def check_mesh_memory(prims, layers: UsdLayers, label: str, when: UsdTime) -> None:
    """Refuse meshes whose triangulation would exceed the memory budget, from their point
    and face-vertex counts (read before anything is triangulated)."""
    from pxr import UsdGeom

    need, tris, biggest, big_tris = 0, 0, "", -1
    for prim in prims:
        mesh = UsdGeom.Mesh(prim)
        where = f"{label}: Mesh {prim.GetPath()}"
        with prim_errors(where):
            n_pts = value_length(mesh.GetPointsAttr(), when, where)
            n_idx = value_length(mesh.GetFaceVertexIndicesAttr(), when, where)
            n_faces = value_length(mesh.GetFaceVertexCountsAttr(), when, where)
        t = max(n_idx - 2 * n_faces, 0)  # fan triangles: sum(count - 2) over the faces
        tris += t
        need += BYTES_PER_TRIANGLE * t + BYTES_PER_POINT * n_pts
        if t > big_tris:
            biggest, big_tris = str(prim.GetPath()), t
    _budget.check(
        layers.memory + need,
        f"{label}: {len(prims):,} meshes of {tris:,} triangles (the largest {biggest}, "
        f"{big_tris:,})",
        "a scene with fewer or coarser meshes",
    )


def _array(attr, dtype, width: int, where: str, when: UsdTime) -> np.ndarray:
    """The values of an array attribute as a (n, width) or (n,) array, or one line naming
    the attribute when they are not numbers of that shape."""
    v = when.get(attr)
    try:
        arr = np.asarray(v if v is not None else [], dtype=dtype)
        return arr.reshape(-1, width) if width > 1 else arr.reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise BadTypeError(
            f"{where}: {attr.GetName()} must be an array of "
            f"{'numbers' if width == 1 else f'{width}-vectors'}, got {show(v)}"
        ) from None


def read_mesh(prim, when: UsdTime, cache: dict, mpu: float, label: str) -> Mesh:
    """The mesh `prim` in world space, lengths in metres (`mpu`: the stage's metersPerUnit)."""
    from pxr import UsdGeom

    name = str(prim.GetPath())
    where = f"{label}: Mesh {name}"
    mesh = UsdGeom.Mesh(prim)
    pts = _array(mesh.GetPointsAttr(), np.float64, 3, where, when)
    counts = _array(mesh.GetFaceVertexCountsAttr(), np.int64, 1, where, when)
    idx = _array(mesh.GetFaceVertexIndicesAttr(), np.int64, 1, where, when)
    if len(pts) == 0 or len(counts) == 0:
        raise BadValueError(f"{where}: degenerate (no points or no faces)")
    if counts.sum() != len(idx) or np.any(counts < 3):
        raise BadValueError(
            f"{where}: faceVertexCounts (sum {int(counts.sum())}) do not match "
            f"the {len(idx)} faceVertexIndices, or a face has fewer than 3 corners"
        )
    if idx.size and (idx.min() < 0 or idx.max() >= len(pts)):
        raise BadValueError(f"{where}: a faceVertexIndex is outside the {len(pts)} points")
    m = world_matrix(prim, when, cache)
    if not np.all(np.isfinite(m)):
        raise BadValueError(f"{where}: its world transform is not finite")
    # fan triangulation: face f with corners c0..c(k-1) -> (c0, cj, cj+1), j = 1..k-2
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tri = counts - 2
    face = np.repeat(np.arange(len(counts)), n_tri)
    j = np.arange(int(n_tri.sum())) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri) + 1
    fv = np.stack(
        [starts[face], starts[face] + j, starts[face] + j + 1], axis=1
    )  # face-varying ids
    world = pts @ m[:3, :3] + m[3, :3]
    corners = world[idx[fv]] * mpu
    if not np.all(np.isfinite(corners)):
        raise BadValueError(
            f"{where}: points not finite in metres (points x world transform x "
            f"metersPerUnit {mpu:g})"
        )
    left = when.get(mesh.GetOrientationAttr()) == UsdGeom.Tokens.leftHanded
    normals = _normals(mesh, pts, idx, fv, face, counts, when, where)
    if normals is None:
        geo = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        geo = -geo if left else geo
        normals = np.repeat(geo[:, None, :], 3, axis=1)
        flat = normals.reshape(-1, 3)
        nn = np.linalg.norm(flat, axis=1, keepdims=True)
        normals = (flat / np.where(nn > 0, nn, 1)).reshape(-1, 3, 3)
    else:
        det = np.linalg.det(m[:3, :3])
        if not (math.isfinite(det) and abs(det) > 0):
            raise BadValueError(
                f"{where}: its world transform is singular (scales "
                f"{', '.join(f'{float(x):g}' for x in _scales(m))}): its normals cannot follow it"
            )
        normals = transform_normals(m, normals.reshape(-1, 3)).reshape(-1, 3, 3)
    out = Mesh(name, corners, normals, bool(when.get(mesh.GetDoubleSidedAttr()) or False))
    check_mesh(out, label)
    return out


def _normals(mesh, pts, idx, fv, face, counts, when: UsdTime, where: str) -> np.ndarray | None:
    """Authored shading normals per triangle corner (local space), or None.

    Their count is checked against the mesh's before they are read or flattened: an indexed
    primvar's indices (compressed 1,000 to 1 in a crate file) could stand for billions."""
    from pxr import UsdGeom

    pv = UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar("normals")
    expect = {
        "vertex": len(pts),
        "varying": len(pts),
        "faceVarying": len(idx),
        "uniform": len(counts),
        "constant": 1,
    }
    if pv and pv.HasAuthoredValue():
        interp = pv.GetInterpolation()
        n = value_length(pv.GetIndicesAttr() if pv.IsIndexed() else pv.GetAttr(), when, where)
        if n != expect.get(interp):
            return None  # a count that does not match: geometric normals
        flat = pv.ComputeFlattened(when.code(pv.GetAttr()))
        try:
            values = np.asarray(flat if flat is not None else [], np.float64).reshape(-1, 3)
        except (TypeError, ValueError, OverflowError):
            raise BadTypeError(
                f"{where}: primvars:normals must be an array of 3-vectors, got {show(flat)}"
            ) from None
    else:
        interp = mesh.GetNormalsInterpolation()
        if value_length(mesh.GetNormalsAttr(), when, where) != expect.get(interp):
            return None
        values = _array(mesh.GetNormalsAttr(), np.float64, 3, where, when)
    if len(values) != expect.get(interp) or len(values) == 0:
        return None
    if interp in ("vertex", "varying"):
        return values[idx[fv]]
    if interp == "faceVarying":
        return values[fv]
    if interp == "uniform":
        return np.repeat(values[face][:, None, :], 3, axis=1)
    return np.broadcast_to(values[0], (len(fv), 3, 3)).copy()
