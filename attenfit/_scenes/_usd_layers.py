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
  usd-core parses it, measured, a binary layer is read lazily).

The opened layers are kept in the result: `Usd.Stage.Open` finds them in usd-core's layer
registry instead of reading the files again, so it only ever composes checked layers.
Value clips given by a template (`templateAssetPath`) are refused: which files they name
depends on times, not on the file. Each file read is recorded as an input of the running
command (`attenfit._input.inputs()`), so no output may replace it.
"""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path
from typing import Any

from .. import _budget
from .._errors import DataFileError
from .._input import LIMITS, check_file

__all__ = ["USD_SUFFIXES", "UsdLayers", "pxr_error", "usd_layers"]

USD_SUFFIXES = (".usd", ".usda", ".usdc")
#: The most layers one scene may hold (a scene exported from a DCC has a handful).
MAX_LAYERS = 4096
#: Memory usd-core needs per byte of a layer while it holds it: a text layer's parser peaked
#: at 30.6 bytes per byte (an 8 MB `.usda` of arrays), rounded up; a binary (crate) layer
#: is mapped and its values read when asked for (its meshes are estimated in `_usd`).
BYTES_PER_TEXT_BYTE = 32
BYTES_PER_CRATE_BYTE = 1
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


def _clip_paths(layer, label: str, where: str) -> list[tuple[str, str]]:
    """The asset paths of the value clips authored in `layer`: (kind, path) pairs."""
    from pxr import Sdf

    found: list[tuple[str, str]] = []
    stack = list(layer.pseudoRoot.nameChildren)
    while stack:
        spec = stack.pop()
        stack.extend(spec.nameChildren)
        for vset in spec.variantSets.values():
            stack.extend(v.primSpec for v in vset.variants.values())
        if not spec.HasInfo("clips"):
            continue
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


def _memory(real: str, size: int) -> int:
    with open(real, "rb") as fh:  # a regular file: checked just before
        crate = fh.read(len(_CRATE_MAGIC)) == _CRATE_MAGIC
    return size * (BYTES_PER_CRATE_BYTE if crate else BYTES_PER_TEXT_BYTE)


def _resolve(layer, asset: str, folder: str, label: str, what: str) -> tuple[str, str]:
    """The path (as usd-core names it) and real path of `asset` named in `layer`, checked to
    lie in `folder` and to be a USD layer's name."""
    from pxr import Ar, Sdf

    if not asset or ":SDF_FORMAT_ARGS:" in asset or asset.endswith("]") or "[" in asset:
        raise DataFileError(
            f"{label}: {what} {asset!r}: attenfit reads plain layer files (no file format "
            "arguments, no package members)"
        )
    base = os.path.dirname(layer.realPath)
    path = os.path.normpath(asset if os.path.isabs(asset) else os.path.join(base, asset))
    real = os.path.realpath(path)
    if not _inside(real, folder):
        raise DataFileError(
            f"{label}: {what} {asset!r} resolves to {real}, outside the scene's folder "
            f"{folder}; a USD scene may read only files inside its own folder"
        )
    if Path(path).suffix.lower() not in USD_SUFFIXES:
        raise DataFileError(
            f"{label}: {what} {asset!r}: not a USD layer (.usd, .usda, .usdc); attenfit reads "
            "no other file formats and no .usdz packages"
        )
    if not os.path.lexists(path):
        raise DataFileError(f"{label}: {what} {asset!r} does not exist (looked for {path})")
    try:
        resolved = str(Ar.GetResolver().Resolve(Sdf.ComputeAssetPathRelativeToLayer(layer, asset)))
    except Exception:  # a resolver error: refused below as a different file
        resolved = ""
    if not resolved or os.path.realpath(resolved) != real:
        raise DataFileError(
            f"{label}: {what} {asset!r}: usd-core resolves it to {resolved or 'nothing'!r}, "
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
    total = _memory(real, size)
    _budget.check(total, f"{label}: its root layer", "a smaller scene")
    root = _open_layer(real, label, "")
    files, layers = [real], [root]
    seen = {real}
    queue = [root]
    while queue:
        layer = queue.pop(0)
        where = f"layer {_rel(layer.realPath, folder)!r}"
        subs = set(layer.subLayerPaths)
        deps = [
            ("sublayer" if a in subs else "reference or payload", a)
            for a in layer.GetCompositionAssetDependencies()
            if a  # '' is a reference inside the layer itself
        ]
        for kind, asset in deps + _clip_paths(layer, label, where):
            what = f"{kind} {asset!r} in {where}"
            dep_path, dep_real = _resolve(layer, asset, folder, label, f"{kind} in {where}")
            if dep_real in seen:
                continue
            seen.add(dep_real)
            if len(seen) > MAX_LAYERS:
                raise DataFileError(
                    f"{label}: more than {MAX_LAYERS} layers (at {what}); attenfit reads at "
                    f"most {MAX_LAYERS}"
                )
            dep_size = check_file(dep_path, f"{label}: {what}", limit)
            total += _memory(dep_real, dep_size)
            _budget.check(
                total,
                f"{label}: its {len(seen)} layers (up to {what})",
                "a smaller scene",
            )
            dep = _open_layer(dep_real, label, f"{what}: ")
            files.append(dep_real)
            layers.append(dep)
            queue.append(dep)
    return UsdLayers(root, folder, tuple(files), tuple(layers), total)
