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

import contextlib
import math
import os
import sys
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

from .. import _budget
from .._errors import AttenfitError, BadTypeError, BadValueError, DataFileError
from ._sample import Mesh, check_mesh, transform_normals
from ._types import SceneLight
from ._usd_layers import (
    MAX_PRIMS,
    USD_SUFFIXES,
    UsdLayers,
    pxr_error,
    usd_diagnostics,
    usd_layers,
)

__all__ = ["USD_SUFFIXES", "UsdLight", "read_usd"]

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


#: Memory per triangle and per point of a mesh while it is read and sampled (peak above the
#: baseline: 622 bytes per triangle for a 2,000,000-triangle grid with vertex normals,
#: `python -m attenfit` on 2 cores), rounded up; what the meshes need together is checked
#: against the memory budget before any is triangulated.
BYTES_PER_TRIANGLE = 1024
BYTES_PER_POINT = 128


def read_usd(
    path: str | os.PathLike,
    label: str,
    *,
    radius_for: Callable[[str], float | None],
    strict: bool,
    notice: Callable[[str], None],
) -> tuple[list[UsdLight], list[Mesh]]:
    """The lights and meshes of the USD file `path` (`label` names it in messages).

    Every layer the scene names is found and checked first (`_usd_layers.usd_layers`), so
    usd-core composes only files inside the scene's folder. `radius_for(name)` gives a
    radius from the options for a light that has none (`treatAsPoint`); `notice` receives
    one line per skipped prim, and one per warning of usd-core's (kept off standard error).
    """
    with usd_diagnostics() as warned:
        lights, meshes = _read(path, label, radius_for, strict, notice)
    for text in warned:
        notice(f"{label}: usd-core: {text}")
    return lights, meshes


def _read(path, label, radius_for, strict, notice) -> tuple[list[UsdLight], list[Mesh]]:
    Usd, UsdGeom, UsdLux = _pxr()
    layers = usd_layers(path, label)
    stage = _open_stage(layers, label, Usd)
    mpu = _meters_per_unit(stage, label, UsdGeom)
    cache = UsdGeom.XformCache(Usd.TimeCode.Default())
    found: list[tuple[Any, str]] = []
    for k, prim in enumerate(stage.Traverse(Usd.TraverseInstanceProxies())):
        if k >= MAX_PRIMS:
            raise BadValueError(
                f"{label}: more than {MAX_PRIMS:,} prims (instances counted); attenfit reads "
                f"at most {MAX_PRIMS:,}"
            )
        type_name = prim.GetTypeName()
        if type_name not in (*_UNSUPPORTED, "SphereLight", "DiskLight", "Mesh"):
            continue
        with _prim_errors(f"{label}: {type_name} {prim.GetPath()}"):
            img = UsdGeom.Imageable(prim)
            if img and (
                img.ComputeVisibility() == UsdGeom.Tokens.invisible
                or img.ComputePurpose() in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy)
            ):
                continue
        found.append((prim, type_name))
    _check_mesh_memory([p for p, t in found if t == "Mesh"], layers, label, UsdGeom)
    lights: list[UsdLight] = []
    meshes: list[Mesh] = []
    for prim, type_name in found:
        name = str(prim.GetPath())
        if type_name in _UNSUPPORTED:
            msg = f"{label}: {type_name} {name}: not modelled (attenfit takes sphere, disk and spot lights)"
            if strict:
                raise BadValueError(msg + "; --strict refuses it")
            notice(msg + "; skipped")
            continue
        with _prim_errors(f"{label}: {type_name} {name}"):
            if type_name in ("SphereLight", "DiskLight"):
                m = _matrix(cache.GetLocalToWorldTransform(prim))
                lights.append(_light(prim, type_name, m, mpu, label, radius_for, UsdLux))
            else:
                with np.errstate(over="ignore", invalid="ignore"):
                    meshes.append(_mesh(prim, cache, mpu, label, UsdGeom))
    return lights, meshes


@contextlib.contextmanager
def _prim_errors(where: str) -> Iterator[None]:
    """usd-core's errors while a prim is read (an xformOp whose value has the wrong type, an
    attribute of an unknown type...) as one line naming the prim: the file's content."""
    from pxr import Tf

    try:
        yield
    except Tf.ErrorException as exc:
        raise DataFileError(f"{where}: usd-core cannot read it ({pxr_error(exc)})") from None


def _length(attr, where: str) -> int:
    """The element count of an array attribute's value (0 when it has none)."""
    v = attr.Get()
    if v is None:
        return 0
    try:
        return len(v)
    except TypeError:
        raise BadTypeError(f"{where}: {attr.GetName()} must be an array, got {_show(v)}") from None


def _open_stage(layers: UsdLayers, label: str, Usd):
    """The stage composed from the checked layers, refusing one that used any other file."""
    try:
        stage = Usd.Stage.Open(layers.root, Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise DataFileError(
            f"{label}: not a USD scene usd-core can compose ({pxr_error(exc)})"
        ) from None
    if stage is None:
        raise DataFileError(f"{label}: not a USD file usd-core can open")
    checked = set(layers.files)
    for used in stage.GetUsedLayers():
        if not used.anonymous and os.path.realpath(used.realPath) not in checked:
            raise DataFileError(  # never seen: every composition arc is walked first
                f"{label}: usd-core composed {used.identifier!r}, which attenfit did not check"
            )
    return stage


def _meters_per_unit(stage, label: str, UsdGeom) -> float:
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    if isinstance(mpu, bool) or not isinstance(mpu, int | float):
        raise BadValueError(f"{label}: metersPerUnit must be a number, got {mpu!r}")
    if not (math.isfinite(mpu) and 1e-12 <= mpu <= 1e12):
        raise BadValueError(
            f"{label}: metersPerUnit {mpu:g}: must be a length from 1e-12 to 1e12 m "
            "(0.01 for centimetres, 1 for metres)"
        )
    return float(mpu)


def _check_mesh_memory(prims, layers: UsdLayers, label: str, UsdGeom) -> None:
    """Refuse meshes whose triangulation would exceed the memory budget, from their point
    and face-vertex counts (read before anything is triangulated)."""
    need, tris, biggest, big_tris = 0, 0, "", -1
    for prim in prims:
        mesh = UsdGeom.Mesh(prim)
        where = f"{label}: Mesh {prim.GetPath()}"
        with _prim_errors(where):
            n_pts = _length(mesh.GetPointsAttr(), where)
            n_idx = _length(mesh.GetFaceVertexIndicesAttr(), where)
            n_faces = _length(mesh.GetFaceVertexCountsAttr(), where)
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


def _show(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def _number(attr, default: float, where: str) -> float:
    """A finite number from `attr` (its default when unauthored), refused with one line
    naming the attribute otherwise."""
    v = _get(attr, default)
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise BadTypeError(f"{where}: {attr.GetName()} must be a number, got {_show(v)}")
    if not math.isfinite(v):
        raise BadValueError(f"{where}: {attr.GetName()} must be finite, got {v!r}")
    return float(v)


def _flag(attr, where: str) -> bool:
    v = _get(attr, False)
    if not isinstance(v, bool):
        raise BadTypeError(f"{where}: {attr.GetName()} must be true or false, got {_show(v)}")
    return v


def _normal_square(r: float) -> bool:
    """Whether `r` is a positive length whose square (areas, radiance) is a normal float."""
    return r > 0 and math.isfinite(r) and sys.float_info.min <= r * r < math.inf


def _light(prim, type_name, m, mpu, label, radius_for, UsdLux) -> UsdLight:
    name = str(prim.GetPath())
    where = f"{label}: {type_name} {name}"
    if not np.all(np.isfinite(m)) or not all(math.isfinite(float(x) * mpu) for x in m[3, :3]):
        raise BadValueError(
            f"{where}: its world transform is not finite (translation {_show(m[3, :3].tolist())} "
            f"x metersPerUnit {mpu:g})"
        )
    s = _scales(m)
    if not np.all(s > 0) or (s.max() - s.min()) > 1e-6 * s.max():
        raise BadValueError(
            f"{where}: non-uniform scale {tuple(round(float(x), 6) for x in s)} "
            "on a light (its radius would not be a radius); scale its radius instead"
        )
    scale = float(s[0]) * mpu
    api = UsdLux.SphereLight(prim) if type_name == "SphereLight" else UsdLux.DiskLight(prim)
    r_local = _number(api.GetRadiusAttr(), 0.5, where)
    radius = r_local * scale
    if type_name == "SphereLight" and _flag(api.GetTreatAsPointAttr(), where):
        given = radius_for(name)
        if given is None:
            raise BadValueError(
                f"{where}: treatAsPoint has no radius; give one with "
                f"--radius R (m) or a side file with [lights.'{name}'] radius = R"
            )
        radius = given
    elif not radius > 0:
        given = radius_for(name)
        if given is None:
            raise BadValueError(
                f"{where}: radius {radius:g} m is not positive; give one "
                f"with --radius R (m) or a side file with [lights.'{name}'] radius = R"
            )
        radius = given
    if not _normal_square(radius):
        raise BadValueError(
            f"{where}: radius {radius:g} m (inputs:radius {r_local:g} x scale {scale:g} m, or "
            "the one given) is out of range: its square must be a normal float"
        )
    lux = UsdLux.LightAPI(prim)
    intensity = _number(lux.GetIntensityAttr(), 1.0, where)
    exposure = _number(lux.GetExposureAttr(), 0.0, where)
    area = (4.0 if type_name == "SphereLight" else 1.0) * math.pi * radius**2
    normalize = _flag(lux.GetNormalizeAttr(), where)
    if not intensity > 0:
        raise BadValueError(f"{where}: intensity {intensity:g} is not positive (a dark light)")
    # radiance x pi r^2; in logarithms first: 2^exposure alone may overflow
    log2 = math.log2(intensity) + exposure + math.log2(math.pi * radius**2)
    log2 -= math.log2(area) if normalize else 0.0
    if not -1000 < log2 < 1000:
        raise BadValueError(
            f"{where}: inputs:intensity {intensity:g} x 2^inputs:exposure ({exposure:g}) gives "
            f"a point-equivalent intensity of 2^{log2:.5g}, outside the float range"
        )
    if abs(exposure) < 1000:
        intensity *= 2.0**exposure
        intensity = intensity / area if normalize else intensity
        intensity *= math.pi * radius**2
    else:
        intensity = 2.0**log2
    centre = tuple(float(x) * mpu for x in m[3, :3])
    axis = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
    axis = tuple(float(x) for x in axis / np.linalg.norm(axis))
    kw: dict[str, Any] = {"radius": radius, "position": centre, "intensity": intensity}
    angle = None
    if prim.HasAPI(UsdLux.ShapingAPI):
        shaping = UsdLux.ShapingAPI(prim)
        angle = _number(shaping.GetShapingConeAngleAttr(), 90.0, where)
        softness = _number(shaping.GetShapingConeSoftnessAttr(), 0.0, where)
        if angle >= 180:
            angle = None  # no cone
        elif not 0 < angle <= 90:
            raise BadValueError(
                f"{where}: inputs:shaping:cone:angle {angle:g} deg: attenfit "
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
    light = SceneLight(**kw)
    try:
        light.emitter()  # the emitter's own checks
    except AttenfitError as exc:
        raise type(exc)(f"{where}: {exc}") from None
    return UsdLight(name, light, kind, None)


def _array(attr, dtype, width: int, where: str) -> np.ndarray:
    """The values of an array attribute as a (n, width) or (n,) array, or one line naming
    the attribute when they are not numbers of that shape."""
    v = attr.Get()
    try:
        arr = np.asarray(v if v is not None else [], dtype=dtype)
        return arr.reshape(-1, width) if width > 1 else arr.reshape(-1)
    except (TypeError, ValueError, OverflowError):
        raise BadTypeError(
            f"{where}: {attr.GetName()} must be an array of "
            f"{'numbers' if width == 1 else f'{width}-vectors'}, got {_show(v)}"
        ) from None


def _mesh(prim, cache, mpu, label, UsdGeom) -> Mesh:
    name = str(prim.GetPath())
    where = f"{label}: Mesh {name}"
    mesh = UsdGeom.Mesh(prim)
    pts = _array(mesh.GetPointsAttr(), np.float64, 3, where)
    counts = _array(mesh.GetFaceVertexCountsAttr(), np.int64, 1, where)
    idx = _array(mesh.GetFaceVertexIndicesAttr(), np.int64, 1, where)
    if len(pts) == 0 or len(counts) == 0:
        raise BadValueError(f"{where}: degenerate (no points or no faces)")
    if counts.sum() != len(idx) or np.any(counts < 3):
        raise BadValueError(
            f"{where}: faceVertexCounts (sum {int(counts.sum())}) do not match "
            f"the {len(idx)} faceVertexIndices, or a face has fewer than 3 corners"
        )
    if idx.size and (idx.min() < 0 or idx.max() >= len(pts)):
        raise BadValueError(f"{where}: a faceVertexIndex is outside the {len(pts)} points")
    m = _matrix(cache.GetLocalToWorldTransform(prim))
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
    left = mesh.GetOrientationAttr().Get() == UsdGeom.Tokens.leftHanded
    normals = _normals(mesh, pts, idx, fv, face, counts, corners, left, UsdGeom, where)
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
    out = Mesh(name, corners, normals, bool(_get(mesh.GetDoubleSidedAttr(), False)))
    check_mesh(out, label)
    return out


def _normals(mesh, pts, idx, fv, face, counts, corners, left, UsdGeom, where) -> np.ndarray | None:
    """Authored shading normals per triangle corner (local space), or None.

    Their count is checked against the mesh's before they are read or flattened: an indexed
    primvar's indices (compressed 1,000 to 1 in a crate file) could stand for billions."""
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
        n = _length(pv.GetIndicesAttr() if pv.IsIndexed() else pv.GetAttr(), where)
        if n != expect.get(interp):
            return None  # a count that does not match: geometric normals
        flat = pv.ComputeFlattened()
        try:
            values = np.asarray(flat if flat is not None else [], np.float64).reshape(-1, 3)
        except (TypeError, ValueError, OverflowError):
            raise BadTypeError(
                f"{where}: primvars:normals must be an array of 3-vectors, got {_show(flat)}"
            ) from None
    else:
        interp = mesh.GetNormalsInterpolation()
        if _length(mesh.GetNormalsAttr(), where) != expect.get(interp):
            return None
        values = _array(mesh.GetNormalsAttr(), np.float64, 3, where)
    if len(values) != expect.get(interp) or len(values) == 0:
        return None
    if interp in ("vertex", "varying"):
        return values[idx[fv]]
    if interp == "faceVarying":
        return values[fv]
    if interp == "uniform":
        return np.repeat(values[face][:, None, :], 3, axis=1)
    return np.broadcast_to(values[0], (len(fv), 3, 3)).copy()
