"""A glTF 2.0 document (`.gltf` JSON or `.glb` container) parsed and checked before anything
it describes is read.

The JSON is parsed with the standard library after the checks every input gets
(`attenfit._input`: a regular file, at most 256 MiB) and one more: its count of values
(objects, arrays, commas) against a cap and the memory budget, before `json.loads` builds
them; its nesting is then checked (at most 32 deep, as every JSON input). Then `check_document` validates the shape of everything attenfit
reads, with messages naming the key path (`nodes[3].rotation`), against the glTF 2.0
specification (section 5, the JSON schema; section 3.6 for binary data) and attenfit's caps:

* arrays of objects (`nodes`, `meshes`, `accessors`, ...) at most `MAX_ITEMS` long, lights at
  most `MAX_LIGHTS`; indices integers in range; numbers finite; `rotation` 4 numbers (a unit
  quaternion), `translation` and `scale` 3, `matrix` 16;
* `bufferView`: `byteOffset` >= 0, `byteLength` >= 1, inside its buffer's `byteLength`,
  `byteStride` 4..252 and a multiple of 4;
* `accessor`: a known `componentType` (5120, 5121, 5122, 5123, 5125, 5126) and `type`,
  `count` >= 1, `byteOffset` >= 0; offsets aligned to the component size; its last element
  inside its bufferView (the stride, when given, at least one element and a multiple of the
  component size); `normalized` only on 8- and 16-bit integers.

The document stays plain JSON (dicts and lists): unknown keys, extensions and `extras` are
kept as written, for a write-back.
"""

from __future__ import annotations

import json
import math
import struct
from typing import Any

import numpy as np

from .. import _budget
from .._errors import BadTypeError, BadValueError, DataFileError
from .._input import MAX_DEPTH

__all__ = ["MAX_ITEMS", "MAX_LIGHTS", "WIDTH", "check_document", "element_size", "parse"]

#: The most items of one top-level array (nodes, meshes, accessors, ...): a large exported
#: level holds tens of thousands of nodes.
MAX_ITEMS = 100_000
#: The most lights (each is answered on its own: seconds each).
MAX_LIGHTS = 1_000
#: The most JSON values (objects, arrays, numbers, ...) a document may hold.
MAX_VALUES = 8_000_000
#: Bytes of memory per JSON value `json.loads` builds (an object ~200 B, others ~40 B).
_BYTES_PER_OBJECT, _BYTES_PER_VALUE = 256, 48

#: The largest byte length, offset or count read (2^53: exact as a float).
_BIG = 2**53
COMPONENTS = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_EXT = "KHR_lights_punctual"
_JSON, _BIN = 0x4E4F534A, 0x004E4942


def _show(v: Any) -> str:
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def element_size(component: int, kind: str) -> int:
    """Bytes of one accessor element, matrix columns padded to 4 bytes (spec 3.6.2.4)."""
    size = COMPONENTS[component]
    if kind in ("MAT2", "MAT3") and size < 4:
        n = 2 if kind == "MAT2" else 3
        return n * (-(-n * size // 4) * 4)
    return WIDTH[kind] * size


# ----------------------------------------------------------------------------- the file
def parse(data: bytes, label: str) -> tuple[dict[str, Any], memoryview | None]:
    """The JSON document of a `.gltf` or `.glb` file's bytes, and the GLB's BIN chunk."""
    bin_chunk = None
    if data[:4] == b"glTF":
        text, bin_chunk = _glb(memoryview(data), label)
    else:
        text = data
    counts = np.frombuffer(text, np.uint8)
    objects = int(np.count_nonzero(counts == ord("{")))
    values = (
        objects
        + int(np.count_nonzero(counts == ord("[")))
        + int(np.count_nonzero(counts == ord(",")))
    )
    del counts
    if values > MAX_VALUES:
        raise DataFileError(
            f"{label}: its JSON holds about {values:,} values; attenfit reads at most "
            f"{MAX_VALUES:,} (a glTF's JSON describes, its buffers hold the data)"
        )
    _budget.check(
        3 * len(text) + _BYTES_PER_OBJECT * objects + _BYTES_PER_VALUE * values,
        f"{label}: a glTF JSON of {len(text):,} bytes and {values:,} values",
        "a smaller scene",
    )
    try:
        decoded = text.decode("utf-8").removeprefix("\ufeff")
    except UnicodeDecodeError:
        raise DataFileError(f"{label}: not a glTF 2.0 file (its JSON is not UTF-8)") from None
    doc = _loads(decoded, label)
    del decoded
    return doc, bin_chunk


def _loads(text: str, label: str) -> dict[str, Any]:
    """`json.loads(text)`, its nesting then checked (at most `MAX_DEPTH`). The C parser stops
    at Python's recursion limit by itself; the regular expression `load_json` blanks strings
    with takes ~100 bytes of memory per character of a long string (an 80 MB embedded
    buffer: 9 GB), so a glTF's JSON is not given to it."""
    try:
        doc = json.loads(text)
    except RecursionError:
        raise DataFileError(f"{label}: glTF JSON nests too deeply to read") from None
    except ValueError as exc:  # JSONDecodeError; an integer of over 4300 digits
        raise DataFileError(f"{label}: glTF JSON is not valid JSON: {exc}") from None
    stack = [(doc, 1)]
    while stack:
        v, depth = stack.pop()
        if depth > MAX_DEPTH:
            raise DataFileError(
                f"{label}: glTF JSON nests arrays or objects more than {MAX_DEPTH} deep; "
                f"attenfit reads at most {MAX_DEPTH}"
            )
        for x in v.values() if isinstance(v, dict) else v:
            if isinstance(x, dict | list):
                stack.append((x, depth + 1))
    if not isinstance(doc, dict):
        raise DataFileError(f"{label}: not a glTF 2.0 file (its JSON is not an object)")
    return doc


def _glb(data: memoryview, label: str) -> tuple[bytes, memoryview | None]:
    """The JSON and BIN chunks of a GLB container (glTF 2.0 section 4.4)."""
    bad = f"{label}: not a glTF 2.0 file"
    if len(data) < 20:
        raise DataFileError(f"{bad} (a GLB of {len(data)} bytes, shorter than its header)")
    _, version, length = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise DataFileError(f"{bad} (GLB version {version}; attenfit reads version 2)")
    if length > len(data):
        raise DataFileError(f"{bad} (its GLB header says {length:,} bytes; it has {len(data):,})")
    chunks, pos = [], 12
    while pos + 8 <= length:
        size, kind = struct.unpack_from("<II", data, pos)
        if pos + 8 + size > length:
            raise DataFileError(f"{bad} (a GLB chunk at byte {pos} runs past the file's end)")
        chunks.append((kind, data[pos + 8 : pos + 8 + size]))
        pos += 8 + size
    if not chunks or chunks[0][0] != _JSON:
        raise DataFileError(f"{bad} (a GLB whose first chunk is not JSON)")
    binary = chunks[1][1] if len(chunks) > 1 and chunks[1][0] == _BIN else None
    return bytes(chunks[0][1]).rstrip(b"\x00"), binary  # some writers pad with NULs


# ----------------------------------------------------------------------------- checks
class _Check:
    """Typed access to the document, with messages naming the key path."""

    def __init__(self, label: str):
        self.label = label

    def fail(self, path: str, msg: str, cls: type[Exception] = BadValueError) -> Exception:
        return cls(f"{self.label}: {path}: {msg}")

    def obj(self, v: Any, path: str) -> dict[str, Any]:
        if not isinstance(v, dict):
            raise self.fail(path, f"must be a JSON object, got {_show(v)}", BadTypeError)
        return v

    def objects(self, v: Any, path: str, cap: int = MAX_ITEMS) -> list[dict[str, Any]]:
        if v is None:
            return []
        if not isinstance(v, list):
            raise self.fail(path, f"must be a list of objects, got {_show(v)}", BadTypeError)
        if len(v) > cap:
            raise self.fail(path, f"{len(v):,} items; attenfit reads at most {cap:,}")
        for k, x in enumerate(v):
            self.obj(x, f"{path}[{k}]")
        return v

    def integer(self, v: Any, path: str, lo: int = 0, hi: float = math.inf) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(path, f"must be an integer, got {_show(v)}", BadTypeError)
        if not lo <= v <= hi:
            what = f"from {lo} to {hi:,}" if hi < math.inf else f"at least {lo}"
            raise self.fail(path, f"must be an integer {what}, got {_show(v)}")
        return v

    def index(self, v: Any, path: str, n: int, of: str) -> int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.fail(path, f"must be an index into {of}, got {_show(v)}", BadTypeError)
        if not 0 <= v < n:
            raise self.fail(path, f"index {v} is out of range: {of} has {n} items")
        return v

    def number(self, v: Any, path: str) -> float:
        if isinstance(v, bool) or not isinstance(v, int | float):
            raise self.fail(path, f"must be a number, got {_show(v)}", BadTypeError)
        try:
            x = float(v)
        except OverflowError:
            x = math.inf
        if not math.isfinite(x):
            raise self.fail(path, f"must be a finite number, got {_show(v)}")
        return x

    def numbers(self, v: Any, path: str, n: int) -> list[float]:
        if not isinstance(v, list) or len(v) != n:
            raise self.fail(path, f"must be a list of {n} numbers, got {_show(v)}", BadTypeError)
        return [self.number(x, f"{path}[{k}]") for k, x in enumerate(v)]

    def string(self, v: Any, path: str) -> str:
        if not isinstance(v, str):
            raise self.fail(path, f"must be a string, got {_show(v)}", BadTypeError)
        return v

    def boolean(self, v: Any, path: str) -> bool:
        if not isinstance(v, bool):
            raise self.fail(path, f"must be true or false, got {_show(v)}", BadTypeError)
        return v


def check_document(doc: dict[str, Any], label: str) -> None:
    """Validate the shape of `doc` (see the module docstring); raises a one-line
    `BadValueError`/`BadTypeError` naming the key path."""
    c = _Check(label)
    asset = doc.get("asset")
    if asset is not None:
        version = c.obj(asset, "asset").get("version", "2.0")
        if not isinstance(version, str) or not version.startswith("2."):
            raise DataFileError(f"{label}: not a glTF 2.0 file (asset.version {_show(version)})")
    for key in ("extensionsUsed", "extensionsRequired"):
        v = doc.get(key, [])
        if not isinstance(v, list) or not all(isinstance(x, str) for x in v):
            raise c.fail(key, f"must be a list of names, got {_show(v)}", BadTypeError)
    arrays = {}
    for key in ("scenes", "nodes", "meshes", "materials", "accessors", "bufferViews",
                "buffers", "images"):  # fmt: skip
        arrays[key] = c.objects(doc.get(key), key)
    n = {k: len(v) for k, v in arrays.items()}
    if doc.get("scene") is not None:
        c.index(doc["scene"], "scene", n["scenes"], "scenes")
    for s, scene in enumerate(arrays["scenes"]):
        roots = scene.get("nodes", [])
        if not isinstance(roots, list):
            raise c.fail(f"scenes[{s}].nodes", f"must be a list, got {_show(roots)}", BadTypeError)
        for k, x in enumerate(roots):
            c.index(x, f"scenes[{s}].nodes[{k}]", n["nodes"], "nodes")
    ext = doc.get("extensions")
    lights: list[dict[str, Any]] = []
    if ext is not None and c.obj(ext, "extensions").get(_EXT) is not None:
        punctual = c.obj(ext[_EXT], f"extensions.{_EXT}")
        lights = c.objects(punctual.get("lights"), f"extensions.{_EXT}.lights", MAX_LIGHTS)
    for j, light in enumerate(lights):
        _light(c, light, f"extensions.{_EXT}.lights[{j}]")
    for k, node in enumerate(arrays["nodes"]):
        _node(c, node, f"nodes[{k}]", n, len(lights))
    for k, mesh in enumerate(arrays["meshes"]):
        _mesh(c, mesh, f"meshes[{k}]", n)
    for k, mat in enumerate(arrays["materials"]):
        if "doubleSided" in mat:
            c.boolean(mat["doubleSided"], f"materials[{k}].doubleSided")
    for k, buf in enumerate(arrays["buffers"]):
        c.integer(buf.get("byteLength"), f"buffers[{k}].byteLength", 1, _BIG)
        if "uri" in buf:
            c.string(buf["uri"], f"buffers[{k}].uri")
    for k, img in enumerate(arrays["images"]):
        if "uri" in img:
            c.string(img["uri"], f"images[{k}].uri")
        if "bufferView" in img:
            c.index(img["bufferView"], f"images[{k}].bufferView", n["bufferViews"], "bufferViews")
    for k, view in enumerate(arrays["bufferViews"]):
        _view(c, view, f"bufferViews[{k}]", arrays["buffers"])
    for k, acc in enumerate(arrays["accessors"]):
        _accessor(c, acc, f"accessors[{k}]", arrays["bufferViews"])


def _light(c: _Check, d: dict[str, Any], path: str) -> None:
    if "type" in d:
        c.string(d["type"], f"{path}.type")
    if "name" in d:
        c.string(d["name"], f"{path}.name")
    for key in ("intensity", "range"):
        if key in d:
            c.number(d[key], f"{path}.{key}")
    if "spot" in d:
        spot = c.obj(d["spot"], f"{path}.spot")
        for key in ("innerConeAngle", "outerConeAngle"):
            if key in spot:
                c.number(spot[key], f"{path}.spot.{key}")


def _node(c: _Check, d: dict[str, Any], path: str, n: dict[str, int], lights: int) -> None:
    if "name" in d:
        c.string(d["name"], f"{path}.name")
    children = d.get("children", [])
    if not isinstance(children, list):
        raise c.fail(f"{path}.children", f"must be a list, got {_show(children)}", BadTypeError)
    for k, x in enumerate(children):
        c.index(x, f"{path}.children[{k}]", n["nodes"], "nodes")
    if "mesh" in d:
        c.index(d["mesh"], f"{path}.mesh", n["meshes"], "meshes")
    if "matrix" in d:
        c.numbers(d["matrix"], f"{path}.matrix", 16)
    for key, size in (("translation", 3), ("rotation", 4), ("scale", 3)):
        if key in d:
            c.numbers(d[key], f"{path}.{key}", size)
    if "rotation" in d:
        norm = math.sqrt(sum(x * x for x in d["rotation"]))
        if abs(norm - 1) > 1e-3:
            raise c.fail(
                f"{path}.rotation", f"must be a unit quaternion, got {_show(d['rotation'])}"
            )
    ext = d.get("extensions")
    if ext is not None and c.obj(ext, f"{path}.extensions").get(_EXT) is not None:
        ne = c.obj(ext[_EXT], f"{path}.extensions.{_EXT}")
        if "light" in ne:
            c.index(ne["light"], f"{path}.extensions.{_EXT}.light", lights, f"{_EXT}.lights")


def _mesh(c: _Check, d: dict[str, Any], path: str, n: dict[str, int]) -> None:
    if "name" in d:
        c.string(d["name"], f"{path}.name")
    for p, prim in enumerate(c.objects(d.get("primitives"), f"{path}.primitives")):
        where = f"{path}.primitives[{p}]"
        attrs = c.obj(prim.get("attributes", {}), f"{where}.attributes")
        for name, x in attrs.items():
            c.index(x, f"{where}.attributes.{name}", n["accessors"], "accessors")
        if "indices" in prim:
            c.index(prim["indices"], f"{where}.indices", n["accessors"], "accessors")
        if "material" in prim:
            c.index(prim["material"], f"{where}.material", n["materials"], "materials")
        if "mode" in prim:
            c.integer(prim["mode"], f"{where}.mode", 0, 6)


def _view(c: _Check, d: dict[str, Any], path: str, buffers: list[dict[str, Any]]) -> None:
    b = c.index(d.get("buffer"), f"{path}.buffer", len(buffers), "buffers")
    offset = c.integer(d.get("byteOffset", 0), f"{path}.byteOffset", 0, _BIG)
    length = c.integer(d.get("byteLength"), f"{path}.byteLength", 1, _BIG)
    if "byteStride" in d:
        stride = c.integer(d["byteStride"], f"{path}.byteStride", 4, 252)
        if stride % 4:
            raise c.fail(f"{path}.byteStride", f"must be a multiple of 4, got {stride}")
    size = buffers[b]["byteLength"]
    if offset + length > size:
        raise c.fail(
            path,
            f"bytes {offset:,} to {offset + length:,} run past buffers[{b}], "
            f"whose byteLength is {size:,}",
        )


def _accessor(c: _Check, d: dict[str, Any], path: str, views: list[dict[str, Any]]) -> None:
    comp = d.get("componentType")
    if isinstance(comp, bool) or not isinstance(comp, int) or comp not in COMPONENTS:
        raise c.fail(
            f"{path}.componentType",
            f"must be one of {', '.join(map(str, COMPONENTS))}, got {_show(comp)}",
        )
    kind = d.get("type")
    if not isinstance(kind, str) or kind not in WIDTH:
        raise c.fail(f"{path}.type", f"must be one of {', '.join(WIDTH)}, got {_show(kind)}")
    count = c.integer(d.get("count"), f"{path}.count", 1, _BIG)
    offset = c.integer(d.get("byteOffset", 0), f"{path}.byteOffset", 0, _BIG)
    if "normalized" in d and c.boolean(d["normalized"], f"{path}.normalized"):
        if comp in (5125, 5126):
            raise c.fail(f"{path}.normalized", "is only for 8- and 16-bit integer components")
    size = COMPONENTS[comp]
    if "bufferView" not in d:
        if offset:
            raise c.fail(f"{path}.byteOffset", "must be 0 without a bufferView")
        return
    v = c.index(d["bufferView"], f"{path}.bufferView", len(views), "bufferViews")
    view = views[v]
    if offset % size or (view.get("byteOffset", 0) + offset) % size:
        raise c.fail(
            f"{path}.byteOffset",
            f"{offset} (bufferViews[{v}] at {view.get('byteOffset', 0)}) is not aligned to its "
            f"{size}-byte components",
        )
    item = element_size(comp, kind)
    stride = view.get("byteStride", item)
    if stride < item or stride % size:
        raise c.fail(
            path,
            f"bufferViews[{v}].byteStride {stride} must be at least its {item}-byte elements "
            f"and a multiple of {size}",
        )
    end = offset + stride * (count - 1) + item
    if end > view["byteLength"]:
        raise c.fail(
            path,
            f"{count:,} elements of {item} bytes (stride {stride}) from byte {offset:,} need "
            f"{end:,} bytes; bufferViews[{v}] has {view['byteLength']:,}",
        )
