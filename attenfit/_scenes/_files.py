"""A USD or glTF file as a `Scene`: its lights, receivers sampled on its meshes where each
light reaches (`_sample`), and the options a file does not carry (tolerance, precision,
radius, threshold, sample count, engine) from keyword arguments or a TOML side file.

Side file keys (`SIDE_KEYS`; every one optional, an option given directly wins)::

    tolerance = 0.05        # largest relative error of the irradiance
    precision = "float32"   # float64 | float32 | float16
    threshold = 0.01        # visibility threshold: absolute irradiance (intensity units / m^2)
    samples = 4096          # receivers per light
    radius = 0.05           # radius (m) of every light that has none (glTF, treatAsPoint)
    engine = "godot"
    strict = false
    seed = 0
    time = 1                # USD time code (default: see `_usd_attrs.UsdTime`)
    error_floor = 0.0
    [lights."Lamp"]         # per light, by name: glTF light or node name, USD prim path or name
    radius = 0.1
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from .. import _input
from .._errors import BadTypeError, BadValueError, UnknownNameError
from .._input import LIMITS, load_toml, read_text
from ._engine import ENGINES, Engine, get_engine
from ._gltf import GLTF_SUFFIXES, gltf_files, read_gltf
from ._sample import sample_receivers
from ._scene import Scene
from ._toml import SCENE_PRECISIONS
from ._types import PointReceivers
from ._usd import USD_SUFFIXES, read_usd
from ._usd_attrs import check_time
from ._usd_layers import usd_diagnostics, usd_layers

__all__ = [
    "SIDE_KEYS",
    "ImportedScene",
    "SceneFiles",
    "is_mesh_scene",
    "load_mesh_scene",
    "scene_files",
]

SIDE_KEYS = {
    "tolerance": "largest acceptable relative error of the irradiance, in (0, 1]; default 0.05",
    "precision": "float64 | float32 | float16; default float64",
    "threshold": "visibility threshold (absolute irradiance): ranges are chosen to keep the error within tolerance wherever the truth is above it",
    "samples": "receivers sampled per light, 16..65536; default 4096",
    "radius": "radius (m) of every light the file gives none (glTF lights, USD treatAsPoint)",
    "engine": f"one of {', '.join(ENGINES)}: only what that engine can express",
    "strict": "refuse unsupported lights (dome, directional, shaped rect, elliptic cylinder) instead of skipping them",
    "time": "USD time code to read the scene at; default: each value's default, or the stage's start time code for a value authored only as time samples",
    "seed": "seed of the receiver sampling; default 0",
    "error_floor": "as in a TOML scene; default 0",
    "lights": "a table per light name with `radius`",
}
DEFAULT_SAMPLES = 4096
DEFAULT_TOLERANCE = 0.05


def is_mesh_scene(path: str | os.PathLike) -> bool:
    """Whether `path` names a USD or glTF file (by its suffix)."""
    return Path(path).suffix.lower() in (*USD_SUFFIXES, *GLTF_SUFFIXES)


@dataclasses.dataclass(frozen=True)
class ImportedScene:
    """A scene read from a USD or glTF file, with what the file said about each light."""

    scene: Scene
    path: Path
    format: str  # "usd" | "gltf"
    names: tuple[str, ...]
    refs: tuple[str | int, ...]  # USD prim path; glTF light index (for a write-back)
    file_kinds: tuple[str, ...]
    published_ranges: tuple[float | None, ...]
    samples: int
    drawn: tuple[int, ...]  # points drawn per light (kept ones are its receivers)
    threshold: float | None
    engine: Engine | None
    notices: tuple[str, ...]
    #: every file the scene read (real paths: a USD scene's layers, a glTF's buffers), which
    #: no output may replace
    inputs: tuple[str, ...] = ()


@dataclasses.dataclass(frozen=True)
class SceneFiles:
    """The files a USD or glTF scene reads (`files`, real paths, the scene's own first),
    found and checked before the scene is read; `held` keeps a USD scene's opened layers,
    so that reading the scene does not parse them again."""

    files: tuple[str, ...]
    held: Any = None


def scene_files(path: str | os.PathLike) -> SceneFiles:
    """Every file the USD or glTF scene `path` reads, checked as its reader checks them and
    recorded as inputs of the running command (`attenfit._input.inputs()`), so that a
    command can refuse an output that would replace one before any work: a USD scene's
    layers (`_usd_layers.usd_layers`: inside the scene's folder, regular files within their
    size limit), a glTF file and the buffers and images it names (`gltf_files`)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix in USD_SUFFIXES:  # usd-core's warnings: reported when the scene is read
        with usd_diagnostics():
            layers = usd_layers(path, path.name)
        return SceneFiles(layers.files, layers)
    if suffix not in GLTF_SUFFIXES:
        raise BadValueError(
            f"{path.name}: not a USD (.usd, .usda, .usdc) or glTF (.gltf, .glb) file"
        )
    files = gltf_files(path, path.name)
    _input.declare(files)
    return SceneFiles(files)


@contextlib.contextmanager
def _reading() -> Iterator[set[str]]:
    """The files read inside the block (real paths), still counted as the running
    command's inputs afterwards."""
    read: set[str] = set()
    try:
        with _input.tracking():
            yield read
            read.update(_input.inputs())
    finally:
        _input.declare(read)


def _side(path: str | os.PathLike | None) -> dict[str, Any]:
    if path is None:
        return {}
    label = Path(path).name
    d = load_toml(read_text(path, f"side file {label!r}", LIMITS["scene"]), f"side file {label!r}")
    for k in d:
        if k not in SIDE_KEYS:
            raise UnknownNameError(f"{label}: unknown key {k!r}; allowed: {', '.join(SIDE_KEYS)}")
    lights = d.get("lights", {})
    if not isinstance(lights, dict) or not all(isinstance(v, dict) for v in lights.values()):
        raise BadTypeError(f"{label}: lights: must be tables [lights.'NAME'] with radius = R")
    for name, t in lights.items():
        for k in t:
            if k != "radius":
                raise UnknownNameError(
                    f"{label}: lights.{name!r}: unknown key {k!r}; allowed: radius"
                )
        _positive(t.get("radius", 1.0), f"{label}: lights.{name!r}.radius")
    d["_label"] = label
    return d


def _base(name: str) -> str:
    return name.rsplit("/", 1)[-1]


def _positive(v: Any, where: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v) or v <= 0:
        raise BadValueError(f"{where}: must be a positive number, got {v!r}")
    return float(v)


@dataclasses.dataclass(frozen=True)
class _Options:
    """The options of `load_mesh_scene`, checked: given directly, or from the side file."""

    tolerance: float
    precision: str
    threshold: float | None
    samples: int
    radius: float | None
    engine: Engine | None
    strict: bool
    seed: int
    time: float | None
    error_floor: float
    per_light: dict[str, Any]
    side_label: str


def _options(sd: dict[str, Any], given: dict[str, Any]) -> _Options:
    def opt(key, default):
        value = given.get(key)
        return value if value is not None else sd.get(key, default)

    tol = opt("tolerance", DEFAULT_TOLERANCE)
    if isinstance(tol, bool) or not isinstance(tol, int | float) or not 0 < tol <= 1:
        raise BadValueError(f"tolerance: must be a relative error in (0, 1], got {tol!r}")
    prec = opt("precision", "float64")
    if prec not in SCENE_PRECISIONS:
        raise BadValueError(
            f"precision: must be one of {', '.join(SCENE_PRECISIONS)}, got {prec!r}"
        )
    thr = opt("threshold", None)
    n = opt("samples", DEFAULT_SAMPLES)
    if isinstance(n, bool) or not isinstance(n, int) or not 16 <= n <= 65536:
        raise BadValueError(f"samples: must be an integer from 16 to 65536, got {n!r}")
    r_all = opt("radius", None)
    eng_name = opt("engine", None)
    seed_ = opt("seed", 0)
    if isinstance(seed_, bool) or not isinstance(seed_, int) or seed_ < 0:
        raise BadValueError(f"seed: must be a non-negative integer, got {seed_!r}")
    return _Options(
        tolerance=float(tol),
        precision=prec,
        threshold=None if thr is None else _positive(thr, "threshold"),
        samples=n,
        radius=None if r_all is None else _positive(r_all, "radius"),
        engine=get_engine(eng_name) if eng_name is not None else None,
        strict=bool(opt("strict", False)),
        seed=seed_,
        time=check_time(opt("time", None)),
        error_floor=float(sd.get("error_floor", 0.0)),
        per_light=sd.get("lights", {}),
        side_label=sd.get("_label", "side file"),
    )


def load_mesh_scene(
    path: str | os.PathLike,
    *,
    side: str | os.PathLike | None = None,
    tolerance: float | None = None,
    precision: str | None = None,
    threshold: float | None = None,
    samples: int | None = None,
    radius: float | None = None,
    engine: str | None = None,
    strict: bool | None = None,
    seed: int | None = None,
    time: float | None = None,
    notice: Callable[[str], None] | None = None,
) -> ImportedScene:
    """Read a USD or glTF scene into a `Scene` (see the module docstring for the options).

    Every light gets up to `samples` receivers on the meshes it reaches; a light that
    reaches none is refused (one line naming it). `time` is the USD time code the scene is
    read at (default: each value's default, or the stage's start time code for a value
    authored only as time samples; `_usd_attrs.UsdTime`); a glTF scene takes none. `notice`
    receives one line per skipped prim (default: standard error).
    """
    path = Path(path)
    label = path.name
    o = _options(
        _side(side),
        dict(
            tolerance=tolerance,
            precision=precision,
            threshold=threshold,
            samples=samples,
            radius=radius,
            engine=engine,
            strict=strict,
            seed=seed,
            time=time,
        ),
    )
    used: set[str] = set()

    def radius_for(name: str) -> float | None:
        for key in (name, _base(name)):  # a USD prim's path, or its name
            if key in o.per_light and "radius" in o.per_light[key]:
                used.add(key)
                return float(o.per_light[key]["radius"])
        return o.radius

    notices: list[str] = []

    def note(msg: str) -> None:
        notices.append(msg)
        (notice or (lambda m: print(f"note: {m}", file=sys.stderr)))(msg)

    suffix = path.suffix.lower()
    if suffix not in (*USD_SUFFIXES, *GLTF_SUFFIXES):
        raise BadValueError(f"{label}: not a USD (.usd, .usda, .usdc) or glTF (.gltf, .glb) file")
    kw: dict[str, Any] = dict(radius_for=radius_for, strict=o.strict, notice=note)
    if suffix in USD_SUFFIXES:
        kw["time"] = o.time
    elif o.time is not None:
        raise BadValueError(f"time: {label}: a glTF scene has no time codes (time is for USD)")
    with _reading() as read:
        lights, meshes = (read_usd if suffix in USD_SUFFIXES else read_gltf)(path, label, **kw)
    unknown = set(o.per_light) - used - {x.name for x in lights} - {_base(x.name) for x in lights}
    if unknown:
        raise UnknownNameError(
            f"{o.side_label}: lights.{sorted(unknown)[0]!r}: no light of {label} has that "
            f"name; its lights: {', '.join(x.name for x in lights) or 'none'}"
        )
    if not lights:
        raise BadValueError(f"{label}: no sphere, disk, spot or point light to fit")
    if not meshes:
        raise BadValueError(f"{label}: no mesh to sample receivers on")
    receivers, drawn = _receivers(lights, meshes, o, label)
    return _imported(path, suffix, lights, receivers, drawn, o, notices, read)


def _receivers(lights, meshes, o: _Options, label: str) -> tuple[list, list[int]]:
    """Each light's receivers sampled on the meshes it reaches, and the points drawn."""
    receivers, drawn = [], []
    for i, x in enumerate(lights):
        pts, nrm, tried = sample_receivers(
            x.light, meshes, o.samples, np.random.default_rng([o.seed, i])
        )
        if len(pts) == 0:
            raise BadValueError(
                f"{label}: light {x.name}: reaches no mesh face (none within its range, in "
                "front of it and facing it)"
            )
        receivers.append(PointReceivers(points=pts, normals=nrm, light=i))
        drawn.append(tried)
    return receivers, drawn


def _imported(path, suffix, lights, receivers, drawn, o: _Options, notices, read) -> ImportedScene:
    eng = o.engine
    scene = Scene(
        lights=tuple(x.light for x in lights),
        receivers=tuple(receivers),
        tolerance=o.tolerance,
        error_floor=o.error_floor,
        precision=o.precision,
        families=eng.families if eng is not None else None,
        name=path.name,
        seed=o.seed,
        source=path.name,
        fixed=dict(eng.fixed) if eng is not None else None,
        spot_falloffs=eng.spot_falloffs if eng is not None else None,
    )
    return ImportedScene(
        scene=scene,
        path=path,
        format="usd" if suffix in USD_SUFFIXES else "gltf",
        names=tuple(x.name for x in lights),
        refs=tuple(x.ref for x in lights),
        file_kinds=tuple(x.kind for x in lights),
        published_ranges=tuple(x.published_range for x in lights),
        samples=o.samples,
        drawn=tuple(drawn),
        threshold=o.threshold,
        engine=eng,
        notices=tuple(notices),
        inputs=(os.path.realpath(path), *sorted(read - {os.path.realpath(path)})),
    )


def engine_scene(scene: Scene, engine: Engine) -> Scene:
    """`scene` restricted to what `engine` can express (a TOML scene with `--engine`)."""
    return dataclasses.replace(
        scene,
        families=engine.families,
        fixed=dict(engine.fixed),
        spot_falloffs=engine.spot_falloffs,
    )
