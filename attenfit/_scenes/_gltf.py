"""glTF 2.0 scenes (`.gltf`, `.glb`) read with `pygltflib`: `KHR_lights_punctual` lights and
triangle meshes in world space (glTF is in metres).

`pygltflib` parses the JSON and the GLB container and keeps every extension and `extras`
as written (what a write-back needs); accessors are decoded here with numpy (glTF 2.0
specification, section 3.6 "Binary Data Storage": component types, `byteStride`,
`byteOffset`). Buffers come from the GLB's BIN chunk, a `data:` URI or a file beside the
scene (read through `attenfit._input.read_bytes`, within its size limit). Normalized integer
accessors (KHR_mesh_quantization) are scaled to [-1, 1]; Draco- or meshopt-compressed meshes
are refused.

Lights (KHR_lights_punctual README): `point` and `spot` (`spot.outerConeAngle` default
pi/4, `innerConeAngle` default 0, radians), intensity in candela (the point-equivalent
intensity attenfit takes), optional `range`; a spot shines along the node's local -Z. The
extension has no radius: it comes from `radius_for(name)` (`--radius` or the side file);
a light without one is refused with how to give one. The true angular falloff of a spot is
the extension's own reference, `sat(cos * scale + offset)^2` (profile "frostbite"). The
extension says a light's properties "are unaffected" by the node's scale; a non-uniform
scale (which would bend a spot's cone) is refused. Directional lights are skipped (no
distance falloff) with a notice, or refused with `strict`.
"""

from __future__ import annotations

import base64
import math
import os
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .._errors import BadValueError, DataFileError
from .._input import LIMITS, read_bytes
from ._sample import Mesh, check_mesh, transform_normals
from ._types import SceneLight
from ._usd import UsdLight

__all__ = ["GLTF_SUFFIXES", "load_gltf", "read_gltf"]

GLTF_SUFFIXES = (".gltf", ".glb")
_EXT = "KHR_lights_punctual"
_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}  # fmt: skip
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


def load_gltf(path: str | os.PathLike, label: str):
    """The parsed `pygltflib.GLTF2` of `path` and the bytes of each of its buffers."""
    from pygltflib import GLTF2

    path = Path(path)
    data = read_bytes(path, f"scene file {label!r}", LIMITS["mesh_scene"])
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            if data[:4] == b"glTF":
                gltf = GLTF2.load_from_bytes(data)
            else:
                gltf = GLTF2.from_json(data.decode("utf-8"), infer_missing=True)
    except Exception as exc:
        raise DataFileError(f"{label}: not a glTF 2.0 file pygltflib can read ({exc})") from None
    if gltf is None:
        raise DataFileError(f"{label}: not a glTF 2.0 file pygltflib can read")
    buffers = []
    for k, buf in enumerate(gltf.buffers or []):
        uri = buf.uri
        if uri is None:
            blob = gltf.binary_blob()
            if blob is None:
                raise DataFileError(f"{label}: buffers[{k}] has no uri and there is no GLB chunk")
            buffers.append(bytes(blob))
        elif uri.startswith("data:"):
            try:
                buffers.append(base64.b64decode(uri.split(",", 1)[1]))
            except (ValueError, IndexError):
                raise DataFileError(f"{label}: buffers[{k}]: a malformed data: URI") from None
        else:
            from urllib.parse import unquote

            buffers.append(
                read_bytes(
                    path.parent / unquote(uri),
                    f"buffer {uri!r} of {label!r}",
                    LIMITS["mesh_scene"],
                )
            )
    return gltf, buffers


def _accessor(gltf, buffers, k: int, label: str, where: str) -> np.ndarray:
    acc = gltf.accessors[k]
    if acc.sparse is not None:
        raise BadValueError(f"{label}: {where}: sparse accessors are not read")
    dtype = np.dtype(_DTYPES[acc.componentType]).newbyteorder("<")
    width = _WIDTH[acc.type]
    if acc.bufferView is None:
        return np.zeros((acc.count, width))
    view = gltf.bufferViews[acc.bufferView]
    buf = buffers[view.buffer]
    start = (view.byteOffset or 0) + (acc.byteOffset or 0)
    item = dtype.itemsize * width
    stride = view.byteStride or item
    end = start + stride * (acc.count - 1) + item if acc.count else start
    if end > (view.byteOffset or 0) + view.byteLength or end > len(buf):
        raise BadValueError(f"{label}: {where}: accessor {k} reads past its buffer")
    raw = np.frombuffer(buf, dtype=np.uint8, count=end - start, offset=start)
    if stride == item:
        out = raw.view(dtype).reshape(acc.count, width)
    else:
        rows = np.lib.stride_tricks.as_strided(raw, (acc.count, item), (stride, 1))
        out = np.ascontiguousarray(rows).view(dtype).reshape(acc.count, width)
    if dtype.kind == "f":
        return out.astype(np.float64)
    if acc.normalized:  # glTF 2.0 section 3.11 (KHR_mesh_quantization): c / (2^(bits-1) - 1) etc.
        return np.maximum(out.astype(np.float64) / np.iinfo(dtype).max, -1.0)
    return out.astype(np.int64)


def _local(node) -> np.ndarray:
    """The node's local transform as a row-vector matrix (p' = p @ M)."""
    if node.matrix is not None and len(node.matrix) == 16:
        return np.asarray(node.matrix, dtype=np.float64).reshape(4, 4)  # column-major = M^T
    t = np.asarray(node.translation or (0, 0, 0), dtype=np.float64)
    x, y, z, w = (float(v) for v in (node.rotation or (0, 0, 0, 1)))
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    s = np.asarray(node.scale or (1, 1, 1), dtype=np.float64)
    m = np.eye(4)
    m[:3, :3] = (r * s[None, :]).T  # column vectors R S, transposed for rows
    m[3, :3] = t
    return m


def _world(gltf, label: str) -> dict[int, np.ndarray]:
    """World transforms of the nodes of the default scene (every root when none is set)."""
    nodes = gltf.nodes or []
    if gltf.scenes:
        s = gltf.scenes[gltf.scene or 0]
        roots = list(s.nodes or [])
    else:
        children = {c for n in nodes for c in (n.children or [])}
        roots = [k for k in range(len(nodes)) if k not in children]
    out: dict[int, np.ndarray] = {}
    stack = [(k, np.eye(4)) for k in roots]
    while stack:
        k, parent = stack.pop()
        if k in out or not 0 <= k < len(nodes):
            raise BadValueError(f"{label}: nodes[{k}]: a node is reached twice or does not exist")
        out[k] = _local(nodes[k]) @ parent
        stack.extend((c, out[k]) for c in nodes[k].children or [])
    return out


def _node_name(gltf, k: int) -> str:
    return gltf.nodes[k].name or f"nodes[{k}]"


def read_gltf(
    path: str | os.PathLike,
    label: str,
    *,
    radius_for: Callable[[str], float | None],
    strict: bool,
    notice: Callable[[str], None],
) -> tuple[list[UsdLight], list[Mesh]]:
    """The lights and meshes of the glTF file `path` (see the module docstring)."""
    gltf, buffers = load_gltf(path, label)
    compressed = {"KHR_draco_mesh_compression", "EXT_meshopt_compression"}
    needed = sorted(compressed & set(gltf.extensionsRequired or []))
    if needed:
        raise BadValueError(
            f"{label}: meshes compressed with {needed[0]} are not read; export without it"
        )
    ext = (gltf.extensions or {}).get(_EXT, {})
    defs = ext.get("lights", []) if isinstance(ext, dict) else []
    world = _world(gltf, label)
    lights: list[UsdLight] = []
    meshes: list[Mesh] = []
    for k, m in sorted(world.items()):
        node = gltf.nodes[k]
        name = _node_name(gltf, k)
        ne = (node.extensions or {}).get(_EXT)
        if isinstance(ne, dict) and "light" in ne:
            j = ne["light"]
            if not isinstance(j, int) or not 0 <= j < len(defs):
                raise BadValueError(f"{label}: node {name!r}: {_EXT}.light {j!r} does not exist")
            light = _light(defs[j], j, name, m, label, radius_for, strict, notice)
            if light is not None:
                lights.append(light)
        if node.mesh is not None:
            meshes.extend(_meshes(gltf, buffers, node.mesh, name, m, label, notice))
    return lights, meshes


def _light(d: dict[str, Any], j, node, m, label, radius_for, strict, notice) -> UsdLight | None:
    lname = d.get("name") or f"lights[{j}]"
    where = f"{label}: light {lname!r} (node {node!r})"
    kind = d.get("type")
    if kind not in ("point", "spot"):
        msg = f"{where}: type {kind!r} has no distance falloff to fit"
        if strict:
            raise BadValueError(msg + "; --strict refuses it")
        notice(msg + "; skipped")
        return None
    s = np.linalg.norm(m[:3, :3], axis=1)
    if not np.all(s > 0) or (s.max() - s.min()) > 1e-6 * s.max():
        raise BadValueError(
            f"{where}: non-uniform scale {tuple(round(float(x), 6) for x in s)} on a light's node"
        )
    radius = radius_for(lname) or radius_for(node)
    if radius is None:
        raise BadValueError(
            f"{where}: glTF lights have no radius; give one with --radius R (m) or a side "
            f"file (--side) with [lights.'{lname}'] radius = R"
        )
    intensity = float(d.get("intensity", 1.0))
    if not intensity > 0 or not math.isfinite(intensity):
        raise BadValueError(f"{where}: intensity {intensity:g} cd is not positive")
    rng = d.get("range")
    if rng is not None and not (isinstance(rng, int | float) and rng > radius):
        raise BadValueError(f"{where}: range {rng!r} must be a number above the radius {radius:g}")
    kw: dict[str, Any] = {
        "radius": float(radius),
        "position": tuple(float(x) for x in m[3, :3]),
        "intensity": intensity,
        "range": None if rng is None else float(rng),
        "kind": "sphere",
    }
    if kind == "spot":
        spot = d.get("spot") or {}
        outer = float(spot.get("outerConeAngle", math.pi / 4))
        inner = float(spot.get("innerConeAngle", 0.0))
        if not (0 <= inner < outer <= math.pi / 2):
            raise BadValueError(
                f"{where}: spot cone angles inner {inner:g}, outer {outer:g} rad: need "
                "0 <= inner < outer <= pi/2"
            )
        axis = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
        kw.update(
            kind="spot",
            umbra=math.degrees(outer),
            penumbra=math.degrees(inner),
            direction=tuple(float(x) for x in axis / np.linalg.norm(axis)),
            profile="frostbite",
        )
    return UsdLight(lname, SceneLight(**kw), kind, kw["range"], ref=j)


def _meshes(gltf, buffers, mi: int, node: str, m, label, notice) -> list[Mesh]:
    out = []
    mesh = gltf.meshes[mi]
    for p, prim in enumerate(mesh.primitives or []):
        name = f"{node}/{mesh.name or f'meshes[{mi}]'}/primitives[{p}]"
        mode = 4 if prim.mode is None else prim.mode
        if mode != 4:
            notice(f"{label}: mesh {name!r}: mode {mode} is not triangles; skipped")
            continue
        attrs = prim.attributes
        if attrs.POSITION is None:
            raise BadValueError(f"{label}: mesh {name!r}: no POSITION attribute")
        pts = _accessor(gltf, buffers, attrs.POSITION, label, name)
        if prim.indices is not None:
            idx = _accessor(gltf, buffers, prim.indices, label, name).reshape(-1)
        else:
            idx = np.arange(len(pts))
        if len(idx) % 3 or (idx.size and (idx.min() < 0 or idx.max() >= len(pts))):
            raise BadValueError(
                f"{label}: mesh {name!r}: indices are not triangles of its {len(pts)} points"
            )
        tri = idx.reshape(-1, 3)
        corners = (pts @ m[:3, :3] + m[3, :3])[tri]
        if attrs.NORMAL is not None:
            nrm = _accessor(gltf, buffers, attrs.NORMAL, label, name)
            normals = transform_normals(m, nrm)[tri]
        else:  # glTF 2.0 section 3.7.2.1: flat normals when NORMAL is absent
            geo = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            nn = np.linalg.norm(geo, axis=1, keepdims=True)
            normals = np.repeat((geo / np.where(nn > 0, nn, 1))[:, None], 3, axis=1)
        double = False
        if prim.material is not None and gltf.materials:
            double = bool(gltf.materials[prim.material].doubleSided)
        mesh_ = Mesh(name, corners, normals, double)
        check_mesh(mesh_, label)
        out.append(mesh_)
    return out
