"""glTF 2.0 scenes (`.gltf`, `.glb`): `KHR_lights_punctual` lights and triangle meshes in world
space (glTF is in metres).

The file is parsed and its JSON checked first (`_gltf_doc`: the container, caps, the shape of
every key attenfit reads, the binary layout of every accessor and bufferView); every file it
references (buffers, images) is resolved inside the scene's folder (`_refs.SceneFolder`);
the node graph is checked (one parent per node, no cycle, at most `MAX_NODE_DEPTH` levels);
then the memory the meshes will need (the buffers read, each distinct file once, the
accessors decoded, the triangles of every instance) is checked against the budget. Only then
is a buffer read, and accessors are decoded within bounds already checked (glTF 2.0
specification, section 3.6 "Binary Data Storage"). Buffers come from the GLB's BIN chunk, a
`data:` URI or a file in the scene's folder. Normalized integer accessors
(KHR_mesh_quantization) are scaled to [-1, 1]; Draco- or meshopt-compressed meshes and sparse
accessors are refused.

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
import mimetypes
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .. import _budget
from .._errors import BadValueError, DataFileError
from .._input import LIMITS, read_bytes
from ._gltf_doc import COMPONENTS, MAX_ITEMS, MAX_LIGHTS, WIDTH, check_document, parse
from ._refs import SceneFolder, data_bytes, data_size, is_data_uri
from ._sample import Mesh, check_mesh, transform_normals
from ._types import SceneLight
from ._usd import UsdLight

__all__ = ["GLTF_SUFFIXES", "MAX_NODE_DEPTH", "embedded_document", "read_gltf"]

GLTF_SUFFIXES = (".gltf", ".glb")
_EXT = "KHR_lights_punctual"
_DTYPES = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32, 5126: np.float32}  # fmt: skip
#: The deepest node hierarchy read (an exported rig is tens of levels deep).
MAX_NODE_DEPTH = 256
#: The farthest a light or mesh point may be from the origin (m): distances and their
#: squares stay far inside the float range (1e308 overflowed the sampling's norms).
MAX_COORDINATE = 1e12
#: Memory per decoded accessor component (the raw copy and float64) and per triangle of a
#: mesh instance (world corners and normals, merged, and gathered again to sample), rounded
#: up from `python -m benchmarks` style measurements (0.6 kB at 2,000,000 triangles).
BYTES_PER_COMPONENT = 16
BYTES_PER_TRIANGLE = 768
#: ... and per mesh instance (its arrays' and objects' own overhead).
BYTES_PER_INSTANCE = 2048
_LIMIT = LIMITS["mesh_scene"]
#: Component types per attribute (glTF 2.0 3.7.2.1; KHR_mesh_quantization for integers).
_SEMANTICS = {
    "POSITION": ("VEC3", (5126, 5120, 5121, 5122, 5123)),
    "NORMAL": ("VEC3", (5126, 5120, 5122)),
    "indices": ("SCALAR", (5121, 5123, 5125)),
}


class _Gltf:
    """A checked glTF document, its folder and its buffers (read on demand, each once)."""

    def __init__(self, path: Path, label: str):
        self.label = label
        data = read_bytes(path, f"scene file {label!r}", _LIMIT)
        self.doc, self.bin = parse(data, label)
        del data
        check_document(self.doc, label)
        self.folder = SceneFolder(path, label)
        self.refs: list[Path | None] = []  # a buffer's file, None for GLB and data: buffers
        for k, buf in enumerate(self.doc.get("buffers") or []):
            uri = buf.get("uri")
            if uri is None:
                if k != 0 or self.bin is None:
                    raise DataFileError(
                        f"{label}: buffers[{k}] has no uri and is not a GLB's first buffer"
                    )
                self.refs.append(None)
            elif is_data_uri(uri):
                data_size(uri, f"{label}: buffers[{k}].uri")
                self.refs.append(None)
            else:
                self.refs.append(self.folder.resolve(uri, f"buffers[{k}].uri"))
        self.images: list[Path] = []  # the image files it names (a write-back embeds them)
        for k, img in enumerate(self.doc.get("images") or []):
            uri = img.get("uri")
            if uri is not None and not is_data_uri(uri):
                self.images.append(self.folder.resolve(uri, f"images[{k}].uri"))
        self._buffers: dict[int, Any] = {}

    def buffer_cost(self, k: int) -> int:
        """Bytes reading buffer `k` adds (a file counted once however many buffers name it;
        its checks done here, before it is opened)."""
        uri = self.doc["buffers"][k].get("uri")
        if uri is None:
            return 0
        if is_data_uri(uri):
            return data_size(uri, f"{self.label}: buffers[{k}].uri")
        before = self.folder.total()
        self.folder.check(uri, f"buffers[{k}].uri", _LIMIT)
        return self.folder.total() - before

    def buffer(self, k: int):
        """The first `byteLength` bytes of buffer `k` (a `DataFileError` if it has fewer)."""
        if k in self._buffers:
            return self._buffers[k]
        buf = self.doc["buffers"][k]
        uri = buf.get("uri")
        if uri is None:
            data = self.bin
        elif is_data_uri(uri):
            data = data_bytes(uri, f"{self.label}: buffers[{k}].uri", _LIMIT)
        else:
            real = self.folder.check(uri, f"buffers[{k}].uri", _LIMIT)
            data = self.folder.read(real, uri, f"buffers[{k}].uri", _LIMIT)
        size = buf["byteLength"]
        if data is None or len(data) < size:
            raise DataFileError(
                f"{self.label}: buffers[{k}] holds {0 if data is None else len(data):,} bytes, "
                f"fewer than its byteLength {size:,}"
            )
        self._buffers[k] = memoryview(data)[:size]
        return self._buffers[k]


# ----------------------------------------------------------------------------- nodes
def _local(node: dict[str, Any]) -> np.ndarray | None:
    """The node's local transform as a row-vector matrix (p' = p @ M); None for identity."""
    if "matrix" in node:
        return np.asarray(node["matrix"], dtype=np.float64).reshape(4, 4)  # column-major = M^T
    if not ("translation" in node or "rotation" in node or "scale" in node):
        return None
    t = np.asarray(node.get("translation", (0, 0, 0)), dtype=np.float64)
    q = np.asarray(node.get("rotation", (0, 0, 0, 1)), dtype=np.float64)
    x, y, z, w = q / np.linalg.norm(q)  # a unit quaternion (checked to 1e-3)
    r = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    s = np.asarray(node.get("scale", (1, 1, 1)), dtype=np.float64)
    m = np.eye(4)
    m[:3, :3] = (r * s[None, :]).T  # column vectors R S, transposed for rows
    m[3, :3] = t
    return m


def _world(doc: dict[str, Any], label: str) -> dict[int, np.ndarray]:
    """World transforms of the nodes of the default scene (every root when none is set), in
    the order they are reached; refuses a node with two parents, a cycle and a hierarchy
    deeper than `MAX_NODE_DEPTH`."""
    nodes = doc.get("nodes") or []
    parent = [-1] * len(nodes)
    for p, node in enumerate(nodes):
        for ch in node.get("children", []):
            if parent[ch] != -1 or ch == p:
                other = "itself" if ch == p else f"nodes[{parent[ch]}]"
                raise BadValueError(
                    f"{label}: nodes[{ch}]: a child of nodes[{p}] and of {other}; a node has "
                    "one parent at most"
                )
            parent[ch] = p
    orphans = [k for k in range(len(nodes)) if parent[k] == -1]
    seen = np.zeros(len(nodes), bool)
    stack = list(orphans)
    while stack:  # every node hangs below a parentless one, or is in a cycle
        k = stack.pop()
        seen[k] = True
        stack.extend(nodes[k].get("children", []))
    if not seen.all():
        k = int(np.argmin(seen))
        raise BadValueError(
            f"{label}: nodes[{k}]: its ancestors form a cycle (nodes[{parent[k]}] ...)"
        )
    if doc.get("scenes"):
        s = 0 if doc.get("scene") is None else doc["scene"]
        roots = list(doc["scenes"][s].get("nodes", []))
        for r in roots:
            if parent[r] != -1:
                raise BadValueError(
                    f"{label}: scenes[{s}].nodes: nodes[{r}] is a child of nodes[{parent[r]}], "
                    "not a root"
                )
        if len(set(roots)) != len(roots):
            raise BadValueError(f"{label}: scenes[{s}].nodes: lists a node twice")
    else:
        roots = orphans
    out: dict[int, np.ndarray] = {}
    stack2: list[tuple[int, np.ndarray, int]] = [(k, np.eye(4), 1) for k in reversed(roots)]
    with np.errstate(all="ignore"):  # huge transforms: non-finite, refused where used
        while stack2:
            k, above, depth = stack2.pop()
            if depth > MAX_NODE_DEPTH:
                raise BadValueError(
                    f"{label}: nodes[{k}]: nested {depth} levels deep; attenfit reads at most "
                    f"{MAX_NODE_DEPTH}"
                )
            local = _local(nodes[k])
            out[k] = above if local is None else local @ above
            stack2.extend((c, out[k], depth + 1) for c in reversed(nodes[k].get("children", [])))
    return out


def _node_name(doc: dict[str, Any], k: int) -> str:
    return doc["nodes"][k].get("name") or f"nodes[{k}]"


# ----------------------------------------------------------------------------- reading
def gltf_files(path: str | os.PathLike, label: str) -> tuple[str, ...]:
    """Every file the glTF scene `path` reads or embeds (its own, its buffers', its images'),
    as real paths, each resolved and checked inside its folder; no buffer is read."""
    g = _Gltf(Path(path), label)
    named = [p for p in (*g.refs, *g.images) if p is not None]
    return tuple(dict.fromkeys(os.path.realpath(p) for p in (Path(path), *named)))


def read_gltf(
    path: str | os.PathLike,
    label: str,
    *,
    radius_for: Callable[[str], float | None],
    strict: bool,
    notice: Callable[[str], None],
) -> tuple[list[UsdLight], list[Mesh]]:
    """The lights and meshes of the glTF file `path` (see the module docstring)."""
    g = _Gltf(Path(path), label)
    doc = g.doc
    compressed = {"KHR_draco_mesh_compression", "EXT_meshopt_compression"}
    needed = sorted(compressed & set(doc.get("extensionsRequired", [])))
    if needed:
        raise BadValueError(
            f"{label}: meshes compressed with {needed[0]} are not read; export without it"
        )
    defs = ((doc.get("extensions") or {}).get(_EXT) or {}).get("lights") or []
    world = _world(doc, label)
    plan, light_nodes = [], []
    for k in world:
        node = doc["nodes"][k]
        ne = (node.get("extensions") or {}).get(_EXT) or {}
        if "light" in ne:
            light_nodes.append((k, ne["light"]))
        if "mesh" in node:
            for p in range(len(doc["meshes"][node["mesh"]].get("primitives") or [])):
                plan.append((k, node["mesh"], p))
    if len(light_nodes) > MAX_LIGHTS:
        raise BadValueError(
            f"{label}: {len(light_nodes):,} nodes carry a light; attenfit answers at most "
            f"{MAX_LIGHTS:,}"
        )
    if len(plan) > MAX_ITEMS:
        raise BadValueError(
            f"{label}: {len(plan):,} mesh primitives placed by its nodes; attenfit reads at "
            f"most {MAX_ITEMS:,}"
        )
    plan = _check_memory(g, plan, notice)
    lights: list[UsdLight] = []
    for k, j in light_nodes:
        light = _light(defs[j], j, _node_name(doc, k), world[k], label, radius_for, strict, notice)
        if light is not None:
            lights.append(light)
    meshes: list[Mesh] = []
    decoded: dict[int, np.ndarray] = {}
    checked: set[tuple[int, int]] = set()
    for k, mi, p in plan:
        meshes.append(_mesh(g, decoded, k, mi, p, world[k], checked))
    del decoded
    return lights, _merged(meshes, label)


def _merged(meshes: list[Mesh], label: str) -> list[Mesh]:
    """The checked meshes as one single-sided and one double-sided mesh: sampling loops over
    meshes once per light (100,000 instances took 20 s a light), and their triangles alone
    matter."""
    out = []
    for double in (False, True):
        group = [m for m in meshes if m.double_sided == double]
        if len(group) == 1:
            out.append(group[0])
        elif group:
            corners = np.concatenate([m.corners for m in group])
            normals = np.concatenate([m.normals for m in group])
            out.append(Mesh(f"{label}: {len(group)} mesh primitives", corners, normals, double))
    return out


def _attribute(g: _Gltf, a: int, semantic: str, where: str) -> dict[str, Any]:
    """Accessor `a`, checked for its use as `semantic`."""
    acc = g.doc["accessors"][a]
    kind, comps = _SEMANTICS[semantic]
    if acc["type"] != kind or acc["componentType"] not in comps:
        raise BadValueError(
            f"{g.label}: {where}: accessors[{a}] ({acc['type']} of component type "
            f"{acc['componentType']}) cannot be {semantic}: it must be {kind} of "
            f"{', '.join(map(str, comps))}"
        )
    if semantic == "indices" and acc.get("normalized"):
        raise BadValueError(f"{g.label}: {where}: accessors[{a}]: indices are not normalized")
    if "sparse" in acc:
        raise BadValueError(f"{g.label}: {where}: accessors[{a}]: sparse accessors are not read")
    return acc


def _check_memory(g: _Gltf, plan, notice) -> list[tuple[int, int, int]]:
    """The primitives to read (triangles), their accessors checked; refuses, before any
    buffer is read, meshes that would need more memory than the budget."""
    doc, label = g.doc, g.label
    keep, accessors, buffers, triangles = [], set(), set(), 0
    for k, mi, p in plan:
        prim = doc["meshes"][mi]["primitives"][p]
        where = f"meshes[{mi}].primitives[{p}]"
        mode = prim.get("mode", 4)
        if mode != 4:
            notice(f"{label}: mesh {where} (node {_node_name(doc, k)!r}): mode {mode} is not "
                   "triangles; skipped")  # fmt: skip
            continue
        attrs = prim.get("attributes", {})
        if "POSITION" not in attrs:
            raise BadValueError(f"{label}: {where}: no POSITION attribute")
        pos = _attribute(g, attrs["POSITION"], "POSITION", where)
        used = [attrs["POSITION"]]
        if "NORMAL" in attrs:
            nrm = _attribute(g, attrs["NORMAL"], "NORMAL", where)
            if nrm["count"] != pos["count"]:
                raise BadValueError(
                    f"{label}: {where}: NORMAL has {nrm['count']:,} elements, POSITION "
                    f"{pos['count']:,}; they must match"
                )
            used.append(attrs["NORMAL"])
        n = pos["count"]
        if "indices" in prim:
            n = _attribute(g, prim["indices"], "indices", where)["count"]
            used.append(prim["indices"])
        if n % 3:
            raise BadValueError(f"{label}: {where}: {n:,} corners are not whole triangles")
        triangles += n // 3
        accessors.update(used)
        keep.append((k, mi, p))
    values = 0
    for a in accessors:
        acc = doc["accessors"][a]
        values += acc["count"] * WIDTH[acc["type"]]
        if "bufferView" in acc:
            buffers.add(doc["bufferViews"][acc["bufferView"]]["buffer"])
    files = sum(g.buffer_cost(b) for b in sorted(buffers))
    _budget.check(
        files
        + BYTES_PER_COMPONENT * values
        + BYTES_PER_TRIANGLE * triangles
        + BYTES_PER_INSTANCE * len(keep),
        f"{label}: {triangles:,} triangles in {len(keep):,} mesh instances, {values:,} "
        f"accessor values and {files:,} bytes of buffers",
        "a smaller scene (fewer or simpler meshes)",
    )
    return keep


def _accessor(g: _Gltf, a: int) -> np.ndarray:
    """Accessor `a` decoded ((count, width) float64, or int64 for integers not normalized);
    its bounds were checked against its bufferView and buffer (`_gltf_doc`)."""
    acc = g.doc["accessors"][a]
    comp, width, count = acc["componentType"], WIDTH[acc["type"]], acc["count"]
    dtype = np.dtype(_DTYPES[comp]).newbyteorder("<")
    if "bufferView" not in acc:  # glTF 2.0 3.6.2.1: zeros
        whole = dtype.kind != "f" and not acc.get("normalized")
        return np.zeros((count, width), np.int64 if whole else np.float64)
    view = g.doc["bufferViews"][acc["bufferView"]]
    buf = g.buffer(view["buffer"])
    start = view.get("byteOffset", 0) + acc.get("byteOffset", 0)
    item = COMPONENTS[comp] * width
    stride = view.get("byteStride", item)
    end = start + stride * (count - 1) + item
    if not (0 <= start < end <= view.get("byteOffset", 0) + view["byteLength"] <= len(buf)):
        raise DataFileError(f"{g.label}: accessors[{a}] reads outside its bufferView")
    raw = np.frombuffer(buf, dtype=np.uint8, count=end - start, offset=start)
    if stride == item:
        out = raw.view(dtype).reshape(count, width)
    else:  # rows of `item` bytes, `stride` apart, all within `raw` (checked above)
        rows = np.lib.stride_tricks.as_strided(raw, (count, item), (stride, 1), writeable=False)
        out = np.ascontiguousarray(rows).view(dtype).reshape(count, width)
    if dtype.kind == "f":
        return out.astype(np.float64)
    if acc.get("normalized"):  # glTF 2.0 3.11 (KHR_mesh_quantization): c / (2^(bits-1) - 1)
        return np.maximum(out.astype(np.float64) / np.iinfo(dtype).max, -1.0)
    return out.astype(np.int64)


def _decoded(g: _Gltf, cache: dict[int, np.ndarray], a: int) -> np.ndarray:
    if a not in cache:
        cache[a] = _accessor(g, a)
    return cache[a]


def _mesh(g: _Gltf, cache, k: int, mi: int, p: int, m: np.ndarray, checked: set) -> Mesh:
    doc, label = g.doc, g.label
    mesh = doc["meshes"][mi]
    prim = mesh["primitives"][p]
    name = f"{_node_name(doc, k)}/{mesh.get('name') or f'meshes[{mi}]'}/primitives[{p}]"
    attrs = prim["attributes"]
    pts = _decoded(g, cache, attrs["POSITION"])
    if "indices" in prim:
        idx = _decoded(g, cache, prim["indices"]).reshape(-1)
        if idx.size and idx.max() >= len(pts):
            raise BadValueError(
                f"{label}: mesh {name!r}: index {int(idx.max())} (accessors[{prim['indices']}]) "
                f"is past its {len(pts):,} points"
            )
    else:
        idx = np.arange(len(pts))
    tri = idx.reshape(-1, 3)
    with np.errstate(all="ignore"):
        lin = m[:3, :3]
        det = np.linalg.det(lin) if np.all(np.isfinite(m)) else np.nan
        if not (math.isfinite(det) and det != 0):
            raise BadValueError(
                f"{label}: mesh {name!r}: its node's world transform is not invertible or not "
                "finite (a zero or huge scale)"
            )
        corners = (pts @ lin + m[3, :3])[tri]
        if "NORMAL" in attrs:
            normals = transform_normals(m, _decoded(g, cache, attrs["NORMAL"]))[tri]
        else:  # glTF 2.0 section 3.7.2.1: flat normals when NORMAL is absent
            geo = np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0])
            nn = np.linalg.norm(geo, axis=1, keepdims=True)
            normals = np.repeat((geo / np.where(nn > 0, nn, 1))[:, None], 3, axis=1)
    if corners.size and np.all(np.isfinite(corners)) and np.abs(corners).max() > MAX_COORDINATE:
        raise BadValueError(
            f"{label}: mesh {name!r}: points {np.abs(corners).max():.3g} m from the origin; "
            f"attenfit reads scenes within {MAX_COORDINATE:g} m"
        )
    double = False
    if "material" in prim:
        double = bool(doc["materials"][prim["material"]].get("doubleSided", False))
    out = Mesh(name, corners, normals, double)
    if (mi, p) not in checked:  # an invertible transform keeps a primitive's area non-zero
        check_mesh(out, label)
        checked.add((mi, p))
    elif not (np.all(np.isfinite(corners)) and np.all(np.isfinite(normals))):
        raise BadValueError(f"{label}: mesh {name!r}: non-finite points or normals")
    return out


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
    with np.errstate(all="ignore"):
        s = np.linalg.norm(m[:3, :3], axis=1)
    if not np.all(np.isfinite(m)):
        raise BadValueError(f"{where}: its node's world transform is not finite")
    if np.abs(m[3, :3]).max() > MAX_COORDINATE:
        raise BadValueError(
            f"{where}: {np.abs(m[3, :3]).max():.3g} m from the origin; attenfit reads scenes "
            f"within {MAX_COORDINATE:g} m"
        )
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
    if not intensity > 0:
        raise BadValueError(f"{where}: intensity {intensity:g} cd is not positive")
    rng = d.get("range")
    if rng is not None and not rng > radius:
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


# ----------------------------------------------------------------------------- write-back
#: Memory of a write-back per byte embedded: the bytes, their base64, the JSON text.
_WRITE_FACTOR = 6


def embedded_document(path: str | os.PathLike, label: str) -> dict[str, Any]:
    """The checked JSON of the glTF `path` with every buffer and image file it owns (inside
    its folder: `_refs`) embedded as a `data:` URI, so that a copy stands alone; refused, before
    anything is read, when a reference leaves the folder or the embedding would need more
    memory than the budget."""
    g = _Gltf(Path(path), label)
    doc = g.doc
    buffers = doc.get("buffers") or []
    images = [
        (k, img)
        for k, img in enumerate(doc.get("images") or [])
        if "uri" in img and not is_data_uri(img["uri"])
    ]
    need = sum(g.buffer_cost(k) + buf["byteLength"] for k, buf in enumerate(buffers))
    before = g.folder.total()
    for k, img in images:
        g.folder.check(img["uri"], f"images[{k}].uri", _LIMIT)
    need += g.folder.total() - before
    _budget.check(
        _WRITE_FACTOR * need,
        f"{label}: a write-back embedding {need:,} bytes of buffers and images",
        "a smaller scene, or no --write-back",
    )
    for k, buf in enumerate(buffers):
        blob = bytes(g.buffer(k))
        buf["uri"] = "data:application/octet-stream;base64," + base64.b64encode(blob).decode()
    for k, img in images:
        real = g.folder.check(img["uri"], f"images[{k}].uri", _LIMIT)
        blob = g.folder.read(real, img["uri"], f"images[{k}].uri", _LIMIT)
        mime = img.get("mimeType")
        if not isinstance(mime, str) or not mime.isprintable() or "," in mime:
            mime = mimetypes.guess_type(real.name)[0] or "application/octet-stream"
        img["uri"] = f"data:{mime};base64," + base64.b64encode(blob).decode()
    return doc
