"""The files a USD scene reads, found and checked before usd-core composes any of them.

`usd_layers(path)` walks the scene's layer graph itself: it checks the root file, opens it
as one `Sdf.Layer` (a layer alone: nothing it names is opened), reads the layer's
composition asset dependencies (sublayers, references and payloads, those inside variants
too) and its value clips (`clips` metadata: `assetPaths`, `manifestAssetPath`), resolves
each against the folder of the layer that names it, checks it, opens it and recurses. A
file is accepted only when it

* lies inside the scene's folder (the folder holding the root file, symbolic links
  resolved), so a scene can name nothing outside it (`@../../etc/passwd@`, `@/dev/zero@`);
* is a regular file (not a FIFO, device, socket or folder), opened without blocking;
* is a USD layer by its name (`.usd`, `.usda`, `.usdc`: no `.usdz` packages, no file format
  arguments, no other file formats a plugin might read), and usd-core's resolver names the
  same file (no search paths);
* is at most `LIMITS["mesh_scene"]` bytes, and the layers together fit the memory budget
  (`attenfit._budget`; a text layer needs about 32 bytes of memory per byte of file while
  usd-core parses it, measured; a binary layer what its headers declare: its structure and
  every array value, which compress 1,000 to 1 on disk, `_usd_crate`).

The opened layers are kept in the result: `Usd.Stage.Open` finds them in usd-core's layer
registry instead of reading the files again, so it only ever composes checked layers.
Value clips given by a template (`templateAssetPath`) are refused: which files they name
depends on times, not on the file. Each file read is recorded as an input of the running
command (`attenfit._input.inputs()`), so no output may replace it.
"""

from __future__ import annotations

import contextlib
import dataclasses
import os
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .. import _budget
from .._errors import AttenfitError, DataFileError, OutputExistsError
from .._input import LIMITS, check_file
from ._usd_crate import crate_memory

__all__ = [
    "MAX_PRIMS",
    "USD_SUFFIXES",
    "UsdLayers",
    "composed_prims_bound",
    "pxr_error",
    "usd_diagnostics",
    "usd_layers",
]

USD_SUFFIXES = (".usd", ".usda", ".usdc")
#: The most layers one scene may hold (a scene exported from a DCC has a handful).
MAX_LAYERS = 4096
#: The most prims a scene may compose (instance proxies counted; `composed_prims_bound`):
#: usd-core composes and attenfit visits about 60,000 a second.
MAX_PRIMS = 200_000
#: The deepest nesting a scene may have, of brackets in a text layer and of composed prims:
#: usd-core's parser and composition recurse, and crash (a segmentation fault, not an
#: error) on a text layer of 100,000 nested prims or dictionaries; 30,000 passed.
MAX_NESTING = 1000
#: Memory usd-core needs per byte of a text layer while it parses it: 30.6 bytes per byte
#: at the peak (an 8 MB `.usda` of arrays), rounded up. A binary (crate) layer compresses,
#: so its size says nothing: its headers are read instead (`_usd_crate.crate_memory`).
BYTES_PER_TEXT_BYTE = 32
_CRATE_MAGIC = b"PXR-USDC"


@dataclasses.dataclass(frozen=True)
class UsdLayers:
    """A USD scene's checked layers: `files` (real paths, the root's first), the opened
    `Sdf.Layer` objects (held so that usd-core does not read the files again) and the
    scene's `folder`."""

    root: Any  # Sdf.Layer
    folder: str
    files: tuple[str, ...]
    layers: tuple[Any, ...]
    memory: int  # estimated bytes usd-core holds for the layers


def _inside(real: str, folder: str) -> bool:
    return real == folder or real.startswith(folder.rstrip(os.sep) + os.sep)


def _rel(real: str, folder: str) -> str:
    return os.path.relpath(real, folder) if _inside(real, folder) else real


@dataclasses.dataclass
class _Specs:
    """What the layers' prim specs say about the composed namespace, pooled by path (a
    variant's specs as its prim's): each prim's children, its arcs' targets (references
    and payloads into another layer with no prim path: that layer's default prim, resolved
    once the layers are known), and each layer's root prims."""

    kids: dict[str, set[str]] = dataclasses.field(default_factory=dict)
    arcs: dict[str, set[str]] = dataclasses.field(default_factory=dict)
    default_arcs: list[tuple[str, str, str]] = dataclasses.field(default_factory=list)
    roots: dict[str, set[str]] = dataclasses.field(default_factory=dict)


def _scan(layer, specs: _Specs, label: str, where: str) -> list[tuple[str, str]]:
    """One pass over the prim specs of `layer` (variants' too): their children and arcs
    into `specs`, and the asset paths of the value clips they author, (kind, path) pairs."""
    from pxr import Sdf

    lreal = os.path.realpath(layer.realPath)
    clips_found: list[tuple[str, str]] = []
    roots = specs.roots.setdefault(lreal, set())
    stack = [(spec, True) for spec in layer.pseudoRoot.nameChildren]
    while stack:
        spec, top = stack.pop()
        spec_path = spec.path
        path = spec_path.StripAllVariantSelections()
        key = str(path)
        if spec_path.IsPrimVariantSelectionPath():
            pass  # a variant: its children and arcs are its prim's
        elif top:
            roots.add(key)
        else:
            specs.kids.setdefault(str(path.GetParentPath()), set()).add(key)
        keys = spec.ListInfoKeys()
        out = specs.arcs.setdefault(key, set())
        for field, items in (("references", "referenceList"), ("payload", "payloadList")):
            if field not in keys:
                continue
            for item in getattr(spec, items).GetAddedOrExplicitItems():
                target = item.primPath
                if not target.isEmpty:
                    out.add(str(target.MakeAbsolutePath(path).StripAllVariantSelections()))
                elif item.assetPath:
                    specs.default_arcs.append((key, layer.realPath, item.assetPath))
        for field, items in (("inheritPaths", "inheritPathList"), ("specializes", "specializesList")):  # fmt: skip
            if field in keys:
                for target in getattr(spec, items).GetAddedOrExplicitItems():
                    out.add(str(target.MakeAbsolutePath(path).StripAllVariantSelections()))
        if "clips" in keys:
            clips_found += _clips(spec, label, where, Sdf)
        stack.extend((child, False) for child in spec.nameChildren)
        for vset in spec.variantSets.values():
            stack.extend((v.primSpec, top) for v in vset.variants.values())
    return clips_found


def _clips(spec, label: str, where: str, Sdf) -> list[tuple[str, str]]:
    """The asset paths of the value clips `spec` authors: (kind, path) pairs."""
    found: list[tuple[str, str]] = []
    clips = spec.GetInfo("clips")
    for name, clip in clips.items() if isinstance(clips, dict) else []:
        if not isinstance(clip, dict):
            continue
        if "templateAssetPath" in clip:
            raise DataFileError(
                f"{label}: {where}: prim {spec.path}: value clips {name!r} are given by a "
                f"template ({clip['templateAssetPath']!r}); attenfit reads only clips "
                "listed in assetPaths"
            )
        for a in clip.get("assetPaths", []) or []:
            if isinstance(a, Sdf.AssetPath):
                found.append((f"value clip of {spec.path}", a.path))
        m = clip.get("manifestAssetPath")
        if isinstance(m, Sdf.AssetPath) and m.path:
            found.append((f"clip manifest of {spec.path}", m.path))
    return found


def pxr_error(exc: BaseException) -> str:
    """The message of a usd-core error in one line (pxr raises `Tf.ErrorException` with a
    header and the message quoted, over several lines)."""
    text = " ".join(x.strip() for x in str(exc).splitlines() if x.strip())
    why = text.rsplit(" : ", 1)[-1].strip().strip("'").strip()
    return why if len(why) <= 300 else why[:297] + "..."


@contextlib.contextmanager
def usd_diagnostics() -> Iterator[list[str]]:
    """usd-core's warnings inside the block (a reference to a missing prim, a number out of
    range...), kept off standard error and gathered, one line each, for the caller to report
    as notices; a refusal raised inside gets the first appended, so that it stays one line
    and still says what usd-core saw. (Errors still raise `Tf.ErrorException`.)"""
    from pxr import Tf

    warned: list[str] = []
    with Tf.DiagnosticTrap() as trap:
        try:
            yield warned
        except AttenfitError as exc:
            _gather(trap, warned)
            if not warned or isinstance(exc, OutputExistsError):
                raise
            more = f" and {len(warned) - 1} more" if len(warned) > 1 else ""
            raise type(exc)(f"{exc} (usd-core warned: {warned[0]}{more})") from None
        finally:
            _gather(trap, warned)
            trap.Clear()


#: The end of usd-core's composition warnings: the stage and its address in memory.
_STAGE_NOTE = re.compile(r"\s*\(instantiating stage on stage @[^@]*@ <0x[0-9a-f]+>\)$")


def _gather(trap, warned: list[str]) -> None:
    for w in trap.GetWarnings():
        text = _STAGE_NOTE.sub("", " ".join(str(w.commentary).split()))
        text = text if len(text) <= 300 else text[:297] + "..."
        if text not in warned:
            warned.append(text)


def _open_layer(real: str, label: str, what: str):
    from pxr import Sdf

    try:
        layer = Sdf.Layer.FindOrOpen(real)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise DataFileError(
            f"{label}: {what}not a USD file usd-core can open ({pxr_error(exc)})"
        ) from None
    if layer is None:
        raise DataFileError(f"{label}: {what}not a USD file usd-core can open")
    return layer


# What may hold brackets that do not nest in a text layer: strings, asset paths, prim paths
# (variant selections) and comments, blanked before the brackets are counted.
_USDA_OPAQUE = re.compile(
    rb'"""(?:[^\\]|\\.)*?"""|\'\'\'(?:[^\\]|\\.)*?\'\'\'|"(?:[^"\\\n]|\\.)*"'
    rb"|'(?:[^'\\\n]|\\.)*'|@@@.*?@@@|@[^@\n]*@|<[^<>\n]*>|#[^\n]*",
    re.S,
)
_STEP = np.zeros(256, np.int8)
_STEP[list(b"{([")] = 1
_STEP[list(b"})]")] = -1


def _nesting(text: bytes) -> int:
    """The deepest nesting of brackets in a text layer (strings and comments blanked)."""
    steps = _STEP[np.frombuffer(_USDA_OPAQUE.sub(b"", text), np.uint8)]
    run = np.cumsum(steps[steps != 0], dtype=np.int64)
    return int(run.max(initial=0))


def _check_layer(real: str, size: int, label: str, what: str) -> int:
    """The memory usd-core needs for the layer `real` (a regular file of `size` bytes, just
    checked); a text layer nested deeper than `MAX_NESTING` is refused before it is parsed."""
    with open(real, "rb") as fh:
        head = fh.read(len(_CRATE_MAGIC))
        if head == _CRATE_MAGIC:
            return crate_memory(real, size, f"{label}: {what}".rstrip(": "))
        depth = _nesting(head + fh.read(size))
    if depth > MAX_NESTING:
        raise DataFileError(
            f"{label}: {what}nests brackets {depth:,} deep; attenfit reads at most "
            f"{MAX_NESTING:,} levels (usd-core's parser recurses)"
        )
    return size * BYTES_PER_TEXT_BYTE


def _resolve(layer, asset: str, folder: str, label: str, what: str) -> tuple[str, str]:
    """The path (as usd-core names it) and real path of `asset` named in `layer`, checked to
    lie in `folder` and to be a USD layer's name."""
    from pxr import Ar, Sdf

    if not asset or ":SDF_FORMAT_ARGS:" in asset or asset.endswith("]") or "[" in asset:
        raise DataFileError(
            f"{label}: {what}: attenfit reads plain layer files (no file format "
            "arguments, no package members)"
        )
    base = os.path.dirname(layer.realPath)
    path = os.path.normpath(asset if os.path.isabs(asset) else os.path.join(base, asset))
    real = os.path.realpath(path)
    if not _inside(real, folder):
        raise DataFileError(
            f"{label}: {what} resolves to {real}, outside the scene's folder "
            f"{folder}; a USD scene may read only files inside its own folder"
        )
    if Path(path).suffix.lower() not in USD_SUFFIXES:
        raise DataFileError(
            f"{label}: {what}: not a USD layer (.usd, .usda, .usdc); attenfit reads "
            "no other file formats and no .usdz packages"
        )
    if not os.path.lexists(path):
        raise DataFileError(f"{label}: {what} does not exist (looked for {path})")
    try:
        resolved = str(Ar.GetResolver().Resolve(Sdf.ComputeAssetPathRelativeToLayer(layer, asset)))
    except Exception:  # a resolver error: refused below as a different file
        resolved = ""
    if not resolved or os.path.realpath(resolved) != real:
        raise DataFileError(
            f"{label}: {what}: usd-core resolves it to {resolved or 'nothing'!r}, "
            f"not to {path}; attenfit reads only layers named by their path"
        )
    return path, real


def usd_layers(path: str | os.PathLike, label: str) -> UsdLayers:
    """Find, check and open every layer of the USD scene `path` (see the module docstring);
    raises `DataFileError` (one line naming the file and the reference) for one refused."""
    path = Path(path)
    if path.suffix.lower() not in USD_SUFFIXES:
        raise DataFileError(f"{label}: not a USD file (.usd, .usda, .usdc)")
    limit = LIMITS["mesh_scene"]
    size = check_file(path, f"scene file {label!r}", limit)
    real = os.path.realpath(path)
    folder = os.path.dirname(real)
    total = _check_layer(real, size, label, "")
    _budget.check(total, f"{label}: its root layer", "a smaller scene")
    root = _open_layer(real, label, "")
    files, layers = [real], [root]
    seen = {real}
    queue = [root]
    by_real = {real: root}
    edges: dict[tuple[str, str], str] = {}  # (layer, asset path) -> the real path it names
    sublayers: dict[str, set[str]] = {}  # real path -> its sublayers' real paths
    specs = _Specs()
    while queue:
        layer = queue.pop(0)
        where = f"layer {_rel(layer.realPath, folder)!r}"
        subs = set(layer.subLayerPaths)
        deps = [
            ("sublayer" if a in subs else "reference or payload", a)
            for a in layer.GetCompositionAssetDependencies()
            if a  # '' is a reference inside the layer itself
        ]
        for kind, asset in deps + _scan(layer, specs, label, where):
            what = f"{kind} {asset!r} in {where}"
            dep_path, dep_real = _resolve(layer, asset, folder, label, what)
            edges[(layer.realPath, asset)] = dep_real
            if kind == "sublayer":
                sublayers.setdefault(os.path.realpath(layer.realPath), set()).add(dep_real)
            if dep_real in seen:
                continue
            seen.add(dep_real)
            if len(seen) > MAX_LAYERS:
                raise DataFileError(
                    f"{label}: more than {MAX_LAYERS} layers (at {what}); attenfit reads at "
                    f"most {MAX_LAYERS}"
                )
            dep_size = check_file(dep_path, f"{label}: {what}", limit)
            total += _check_layer(dep_real, dep_size, label, f"{what}: ")
            _budget.check(
                total,
                f"{label}: its {len(seen)} layers (up to {what})",
                "a smaller scene",
            )
            dep = _open_layer(dep_real, label, f"{what}: ")
            files.append(dep_real)
            layers.append(dep)
            by_real[dep_real] = dep
            queue.append(dep)
    root_stack, todo = {real}, [real]  # the root layer and its sublayers, recursively
    while todo:
        for sub in sublayers.get(todo.pop(), ()):
            if sub not in root_stack:
                root_stack.add(sub)
                todo.append(sub)
    bound, depth = composed_prims_bound(specs, by_real, edges, root_stack, MAX_PRIMS)
    if bound > MAX_PRIMS:
        raise DataFileError(
            f"{label}: its references, payloads, inherits and instances compose more than "
            f"{MAX_PRIMS:,} prims; attenfit reads at most {MAX_PRIMS:,}"
        )
    if depth > MAX_NESTING:
        raise DataFileError(
            f"{label}: its prims (references followed) nest up to {depth:,} deep; attenfit "
            f"reads at most {MAX_NESTING:,} levels"
        )
    return UsdLayers(root, folder, tuple(files), tuple(layers), total)


def composed_prims_bound(specs: _Specs, by_real, edges, root_stack, cap: int) -> tuple[int, int]:
    """Upper bounds on the prims usd-core composes for the stage (instance proxies
    counted; saturating just above `cap`) and on their nesting depth, from the layers' prim
    specs alone (`_scan`).

    Every layer's specs are pooled by path (variants' specs as their prim's): a prim at path
    P counts 1, plus its children, plus what each of its arcs brings (references and
    payloads: the target prim, or the target layer's default prim; inherits and
    specializes: the class). Summing where usd-core merges same-named children only
    overestimates. A handful of prims referencing each other can stand for billions
    (`/L1` holding four references to `/L0`, `/L2` four to `/L1`, ...): usd-core takes
    minutes composing them, and this bound refuses them first. An arc that closes a cycle
    counts nothing (usd-core drops it too). The roots are those of the root layer stack."""
    for key, layer_path, asset in specs.default_arcs:
        dep = by_real.get(edges.get((layer_path, asset), ""))
        if dep is not None and dep.defaultPrim:
            specs.arcs.setdefault(key, set()).add("/" + str(dep.defaultPrim).lstrip("/"))
    roots = set().union(*(specs.roots.get(r, set()) for r in root_stack))
    return _count(roots, specs.kids, specs.arcs, cap)


def _count(
    roots: set[str], kids: dict[str, set[str]], arcs: dict[str, set[str]], cap: int
) -> tuple[int, int]:
    """(prims, depth): the sum over `roots` of size(p) = 1 + the sizes of its children and of
    its arcs' targets (saturating at `cap + 1`), and the deepest nesting, depth(p) = the
    larger of 1 + its children's and its targets' depths; without recursion."""
    size: dict[str, int] = {}
    depth: dict[str, int] = {}
    open_: set[str] = set()
    total = deepest = 0
    for root in sorted(roots):
        todo = [(root, False)]
        while todo:
            p, done = todo.pop()
            if done:
                ks, ts = kids.get(p, ()), arcs.get(p, ())
                n = 1 + sum(size.get(q, 0) for q in (*ks, *ts))
                size[p] = min(n, cap + 1)
                depth[p] = max(
                    1 + max((depth.get(q, 0) for q in ks), default=0),
                    max((depth.get(q, 0) for q in ts), default=0),
                )
                open_.discard(p)
                continue
            if p in size or p in open_:
                continue  # counted, or on the path to here: a cycle counts nothing
            open_.add(p)
            todo.append((p, True))
            todo.extend((q, False) for q in (*kids.get(p, ()), *arcs.get(p, ())) if q not in size)
        total = min(total + size.get(root, 0), cap + 1)
        deepest = max(deepest, depth.get(root, 0))
    return total, deepest
