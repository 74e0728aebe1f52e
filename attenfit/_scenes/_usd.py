"""USD scenes (`.usd`, `.usda`, `.usdc`) read with Pixar's `usd-core` (`pxr`): lights and meshes
in world space, lengths in metres.

Lights (UsdLux, https://openusd.org/release/api/usd_lux_page_front.html):

* `SphereLight`: a sphere of `inputs:radius` (attenfit kind "sphere"); `treatAsPoint` asks a
  renderer for a point: attenfit then needs a radius from `--radius` or the side file.
* `DiskLight`: a disk of `inputs:radius` in its local XY plane, emitting along -Z
  (UsdLux DiskLight: "The disk is centered in the XY plane and emits light along the -Z
  axis"); kind "disk".
* Either with `ShapingAPI` and `shaping:cone:angle` < 180 is a spot (kind "spot", shape
  sphere or disk): umbra = the cone angle (UsdLux: "angular limit off the primary axis"),
  and the penumbra from `shaping:cone:softness` as Blender writes and reads it
  (`io/usd/intern/usd_writer_light.cc` writes `spot_size / 2` as the angle and `spot_blend`
  as the softness; EEVEE `lamps_lib.glsl::spot_attenuation`, with `l_spot_size = cos(angle)`
  and `l_spot_blend = (1 - cos(angle)) blend` from `eevee_lights.c`, ramps smoothstep over
  `cos` from `cos(angle)` to `cos(angle) + (1 - cos(angle)) * blend`): penumbra =
  `acos(cos u + (1 - cos u) softness)`, profile "threejs" (smoothstep in cos).
* Rect, dome, cylinder, distant, geometry and portal lights are not modelled: skipped with a
  notice, or refused with `strict`.

Intensity: the radiance is `inputs:intensity * 2^inputs:exposure` (UsdLux LightAPI); with
`inputs:normalize` it is divided by the light's area (sphere 4 pi r^2, disk pi r^2). The
point-equivalent intensity attenfit takes is radiance x pi r^2 (a sphere's in every
direction, a disk's along its axis). Colour and colour temperature are left out: they scale
the truth and every curve alike (only `--threshold` compares absolute values, in the file's
intensity units per m^2).

Prims: the stage's default traversal with instance proxies (instanced meshes count), less
invisible prims and `guide` or `proxy` purposes; a mesh is sampled as its control cage
(Blender writes `subdivisionScheme = "none"`).

Transforms: the world transform of each prim (`UsdGeom.Xformable.
ComputeLocalToWorldTransform`) times the stage's `metersPerUnit`; a light whose transform
scales non-uniformly (its radius would not be a radius) is refused.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import BadValueError, DataFileError
from .._input import LIMITS, check_file
from ._sample import Mesh, check_mesh, transform_normals
from ._types import SceneLight

__all__ = ["UsdLight", "read_usd"]

USD_SUFFIXES = (".usd", ".usda", ".usdc")
_UNSUPPORTED = ("RectLight", "DomeLight", "CylinderLight", "DistantLight", "GeometryLight", "PortalLight")  # fmt: skip


def _pxr():
    from pxr import Usd, UsdGeom, UsdLux

    return Usd, UsdGeom, UsdLux


def _matrix(xf) -> np.ndarray:
    return np.array(xf, dtype=np.float64).reshape(4, 4)


def _scales(m: np.ndarray) -> np.ndarray:
    """The lengths of the transformed unit axes (row-vector matrices: rows 0..2)."""
    return np.linalg.norm(m[:3, :3], axis=1)


def _get(attr, default: Any) -> Any:
    if attr is None or not attr.IsValid() or not attr.HasAuthoredValue():
        v = attr.Get() if attr is not None and attr.IsValid() else None
        return default if v is None else v
    v = attr.Get()
    return default if v is None else v


class UsdLight:
    """A light read from a file: the `SceneLight` and where it came from."""

    def __init__(
        self,
        name: str,
        light: SceneLight,
        kind: str,
        published_range: float | None,
        ref: str | int | None = None,
    ):
        self.name = name
        self.light = light
        self.kind = kind  # the file's type: SphereLight, DiskLight, point, spot
        self.published_range = published_range
        self.ref = name if ref is None else ref  # USD prim path; glTF light index


def read_usd(
    path: str | os.PathLike,
    label: str,
    *,
    radius_for: Callable[[str], float | None],
    strict: bool,
    notice: Callable[[str], None],
) -> tuple[list[UsdLight], list[Mesh]]:
    """The lights and meshes of the USD file `path` (`label` names it in messages).

    `radius_for(name)` gives a radius from the options for a light that has none
    (`treatAsPoint`); `notice` receives one line per skipped prim.
    """
    Usd, UsdGeom, UsdLux = _pxr()
    path = Path(path)
    check_file(path, f"scene file {label!r}", LIMITS["mesh_scene"])
    try:
        stage = Usd.Stage.Open(str(path), Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException with several lines
        lines = str(exc).strip().splitlines()
        why = (lines[-1] if lines else str(exc)).strip().rsplit(" : ", 1)[-1].strip("'")
        raise DataFileError(f"{label}: not a USD file usd-core can open ({why})") from None
    if stage is None:
        raise DataFileError(f"{label}: not a USD file usd-core can open")
    mpu = float(UsdGeom.GetStageMetersPerUnit(stage))
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    lights: list[UsdLight] = []
    meshes: list[Mesh] = []
    for prim in stage.Traverse(Usd.TraverseInstanceProxies()):
        name = str(prim.GetPath())
        type_name = prim.GetTypeName()
        img = UsdGeom.Imageable(prim)
        if img and (
            img.ComputeVisibility() == UsdGeom.Tokens.invisible
            or img.ComputePurpose() in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)
        ):
            continue
        if type_name in _UNSUPPORTED:
            msg = f"{label}: {type_name} {name}: not modelled (attenfit takes sphere, disk and spot lights)"
            if strict:
                raise BadValueError(msg + "; --strict refuses it")
            notice(msg + "; skipped")
            continue
        if type_name in ("SphereLight", "DiskLight"):
            m = _matrix(cache.GetLocalToWorldTransform(prim))
            lights.append(_light(prim, type_name, m, mpu, label, radius_for, UsdLux))
        elif type_name == "Mesh":
            mesh = _mesh(prim, cache, mpu, label, UsdGeom)
            if mesh is not None:
                meshes.append(mesh)
    return lights, meshes


def _light(prim, type_name, m, mpu, label, radius_for, UsdLux) -> UsdLight:
    name = str(prim.GetPath())
    s = _scales(m)
    if not np.all(s > 0) or (s.max() - s.min()) > 1e-6 * s.max():
        raise BadValueError(
            f"{label}: {type_name} {name}: non-uniform scale {tuple(round(float(x), 6) for x in s)} "
            "on a light (its radius would not be a radius); scale its radius instead"
        )
    scale = float(s[0]) * mpu
    api = UsdLux.SphereLight(prim) if type_name == "SphereLight" else UsdLux.DiskLight(prim)
    r_local = float(_get(api.GetRadiusAttr(), 0.5))
    radius = r_local * scale
    if type_name == "SphereLight" and bool(_get(api.GetTreatAsPointAttr(), False)):
        given = radius_for(name)
        if given is None:
            raise BadValueError(
                f"{label}: SphereLight {name}: treatAsPoint has no radius; give one with "
                f"--radius R (m) or a side file with [lights.'{name}'] radius = R"
            )
        radius = given
    elif not radius > 0 or not math.isfinite(radius):
        given = radius_for(name)
        if given is None:
            raise BadValueError(
                f"{label}: {type_name} {name}: radius {radius:g} m is not positive; give one "
                f"with --radius R (m) or a side file with [lights.'{name}'] radius = R"
            )
        radius = given
    lux = UsdLux.LightAPI(prim)
    intensity = float(_get(lux.GetIntensityAttr(), 1.0)) * 2.0 ** float(
        _get(lux.GetExposureAttr(), 0.0)
    )
    area = (4.0 if type_name == "SphereLight" else 1.0) * math.pi * radius**2
    if bool(_get(lux.GetNormalizeAttr(), False)):
        intensity /= area
    intensity *= math.pi * radius**2
    if not intensity > 0:
        raise BadValueError(
            f"{label}: {type_name} {name}: intensity {intensity:g} is not positive (a dark light)"
        )
    centre = tuple(float(x) * mpu for x in m[3, :3])
    axis = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
    axis = tuple(float(x) for x in axis / np.linalg.norm(axis))
    kw: dict[str, Any] = {"radius": radius, "position": centre, "intensity": intensity}
    angle = None
    if prim.HasAPI(UsdLux.ShapingAPI):
        shaping = UsdLux.ShapingAPI(prim)
        angle = float(_get(shaping.GetShapingConeAngleAttr(), 90.0))
        softness = float(_get(shaping.GetShapingConeSoftnessAttr(), 0.0))
        if angle >= 180:
            angle = None  # no cone
        elif not 0 < angle <= 90:
            raise BadValueError(
                f"{label}: {type_name} {name}: shaping:cone:angle {angle:g} deg: attenfit "
                "models cones of 0 to 90 degrees (or 180, no cone)"
            )
    if angle is not None:
        softness = min(max(softness, 0.0), 1.0)
        cu = math.cos(math.radians(angle))
        penumbra = math.degrees(math.acos(min(1.0, cu + (1 - cu) * softness)))
        kw.update(
            kind="spot",
            umbra=angle,
            penumbra=min(penumbra, angle),
            direction=axis,
            shape="sphere" if type_name == "SphereLight" else "disk",
            profile="threejs",
        )
        kind = f"{type_name} + ShapingAPI"
    elif type_name == "SphereLight":
        kw["kind"] = "sphere"
        kind = type_name
    else:
        kw.update(kind="disk", normal=axis)
        kind = type_name
    return UsdLight(name, SceneLight(**kw), kind, None)


def _mesh(prim, cache, mpu, label, UsdGeom) -> Mesh | None:
    name = str(prim.GetPath())
    mesh = UsdGeom.Mesh(prim)
    pts = np.asarray(mesh.GetPointsAttr().Get() or [], dtype=np.float64).reshape(-1, 3)
    counts = np.asarray(mesh.GetFaceVertexCountsAttr().Get() or [], dtype=np.int64)
    idx = np.asarray(mesh.GetFaceVertexIndicesAttr().Get() or [], dtype=np.int64)
    if len(pts) == 0 or len(counts) == 0:
        raise BadValueError(f"{label}: Mesh {name}: degenerate (no points or no faces)")
    if counts.sum() != len(idx) or np.any(counts < 3):
        raise BadValueError(
            f"{label}: Mesh {name}: faceVertexCounts (sum {int(counts.sum())}) do not match "
            f"the {len(idx)} faceVertexIndices, or a face has fewer than 3 corners"
        )
    if idx.size and (idx.min() < 0 or idx.max() >= len(pts)):
        raise BadValueError(
            f"{label}: Mesh {name}: a faceVertexIndex is outside the {len(pts)} points"
        )
    # fan triangulation: face f with corners c0..c(k-1) -> (c0, cj, cj+1), j = 1..k-2
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])
    n_tri = counts - 2
    face = np.repeat(np.arange(len(counts)), n_tri)
    j = np.arange(int(n_tri.sum())) - np.repeat(np.cumsum(n_tri) - n_tri, n_tri) + 1
    fv = np.stack(
        [starts[face], starts[face] + j, starts[face] + j + 1], axis=1
    )  # face-varying ids
    m = _matrix(cache.GetLocalToWorldTransform(prim))
    world = pts @ m[:3, :3] + m[3, :3]
    corners = world[idx[fv]] * mpu
    left = mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded
    normals = _normals(mesh, pts, idx, fv, face, counts, corners, left, UsdGeom)
    if normals is None:
        geo = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
        geo = -geo if left else geo
        normals = np.repeat(geo[:, None, :], 3, axis=1)
        flat = normals.reshape(-1, 3)
        nn = np.linalg.norm(flat, axis=1, keepdims=True)
        normals = (flat / np.where(nn > 0, nn, 1)).reshape(-1, 3, 3)
    else:
        normals = transform_normals(m, normals.reshape(-1, 3)).reshape(-1, 3, 3)
    out = Mesh(name, corners, normals, bool(mesh.GetDoubleSidedAttr().Get()))
    check_mesh(out, label)
    return out


def _normals(mesh, pts, idx, fv, face, counts, corners, left, UsdGeom) -> np.ndarray | None:
    """Authored shading normals per triangle corner (local space), or None."""
    pv = UsdGeom.PrimvarsAPI(mesh.GetPrim()).GetPrimvar("normals")
    if pv and pv.HasAuthoredValue():
        values = np.asarray(pv.ComputeFlattened() or [], dtype=np.float64).reshape(-1, 3)
        interp = pv.GetInterpolation()
    else:
        values = np.asarray(mesh.GetNormalsAttr().Get() or [], dtype=np.float64).reshape(-1, 3)
        interp = mesh.GetNormalsInterpolation()
    if len(values) == 0:
        return None
    if interp in ("vertex", "varying") and len(values) == len(pts):
        return values[idx[fv]]
    if interp == "faceVarying" and len(values) == len(idx):
        return values[fv]
    if interp == "uniform" and len(values) == len(counts):
        return np.repeat(values[face][:, None, :], 3, axis=1)
    if interp == "constant" and len(values) == 1:
        return np.broadcast_to(values[0], (len(fv), 3, 3)).copy()
    return None  # a count that does not match: geometric normals
