"""Resumable batch renders: large sweeps in chunks that survive interruption.

`render_batch(template, out, spp=..., seed=..., chunk=...)` renders `chunk` receivers at a
time into a work folder `<out>.parts/` beside the output, each chunk written atomically
(`attenfit._atomic.atomic_write`: a temporary name renamed into place) with a fingerprint of
the run (receivers, emitter, spp, seed, variant, occluder). Re-running the same command skips
the chunks already there; Ctrl-C loses at most the chunk in progress and never leaves a
half-written file. When every chunk is done the dataset is saved atomically to `out` and the
work folder removed. A receiver's numbers depend only on the seed and its index
(`data_gen.estimate`), so a chunked render equals an unchunked one.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from attenfit import BadValueError, DataFileError, Dataset, OutputExistsError
from attenfit._atomic import atomic_write, check_output_path
from attenfit._input import read_npz

from .estimate import Estimate, estimate_detail
from .render import dataset_from_estimate, fingerprint, occluder_for, unit_receivers
from .scenes import Plane, lights_from_emitter
from .variants import select_variant

__all__ = ["parts_dir", "render_batch"]

_FIELDS = ("E", "stderr", "mc_stderr", "bias_bound")


def parts_dir(out: str | os.PathLike) -> Path:
    """The work folder of a batch render to `out`: `<out>.parts` beside it."""
    out = Path(out)
    return out.with_name(out.name + ".parts")


def _chunk_path(folder: Path, k: int) -> Path:
    return folder / f"chunk_{k:06d}.npz"


def _write_chunk(path: Path, est: Estimate, header: dict) -> None:
    arrays = {name: getattr(est, name) for name in _FIELDS}

    def write(tmp: Path) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, header=np.asarray(json.dumps(header)), **arrays)

    atomic_write(path, write, force=True)


def _read_chunk(path: Path, header: dict) -> Estimate | None:
    """The chunk at `path` if it belongs to this run (same header), else None."""
    n = header["stop"] - header["start"]
    try:  # a chunk's arrays and header: well under 64 bytes a receiver, and some
        npz = read_npz(path, f"chunk {path.name!r}", 64 * n + (1 << 20))
        if json.loads(str(npz["header"])) != header:
            return None
        arrays = {name: np.asarray(npz[name], dtype=np.float64) for name in _FIELDS}
    except (DataFileError, KeyError, ValueError):  # damaged or foreign: re-render it
        return None
    if any(a.shape != (n,) or not np.all(np.isfinite(a)) for a in arrays.values()):
        return None
    return Estimate(variant=header["variant"], **arrays)


def render_batch(
    template: Dataset,
    out: str | os.PathLike,
    *,
    spp: int,
    seed: int,
    chunk: int = 256,
    variant: str = "auto",
    plane: Plane | str | None = "auto",
    force: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> Dataset:
    """Render `template`'s receivers with Mitsuba in chunks of `chunk`; save to `out`; return it.

    Resumes from the chunks in `parts_dir(out)` that match this run. A chunk folder holding
    chunks of a different run (other receivers, spp, seed, variant) is refused with
    `OutputExistsError` unless `force`, which discards them. `out` must not exist unless
    `force`. `progress(done, total)` counts receivers, finished chunks included.
    """
    out = check_output_path(out, force=force)
    if isinstance(chunk, bool) or not isinstance(chunk, int) or chunk < 1:
        raise BadValueError(f"chunk must be a positive integer, got {chunk!r}")
    if isinstance(plane, str):
        if plane != "auto":
            raise BadValueError(f"plane must be 'auto', None or a Plane, got {plane!r}")
        plane = occluder_for(template)
    name = select_variant(variant).name
    lights = lights_from_emitter(template.emitter)
    points, normals = unit_receivers(template)
    total = len(template)
    run = fingerprint(template, spp=spp, seed=seed, variant=name, plane=plane)
    folder = parts_dir(out)
    folder.mkdir(exist_ok=True)
    starts = list(range(0, total, chunk))
    expected = {_chunk_path(folder, k).name for k in range(len(starts))}
    stale = [p for p in folder.glob("chunk_*.npz") if p.name not in expected]
    results: list[Estimate | None] = []
    for k, start in enumerate(starts):
        header = {"run": run, "variant": name, "start": start, "stop": min(total, start + chunk)}
        path = _chunk_path(folder, k)
        got = _read_chunk(path, header) if path.exists() else None
        if path.exists() and got is None:
            stale.append(path)
        results.append(got)
    if stale:
        if not force:
            raise OutputExistsError(
                f"{str(folder)!r} holds chunks of a different run (receivers, spp, seed or "
                "variant differ)",
                "discard them (or delete the folder)",
            )
        for path in stale:
            path.unlink()
    try:
        _render_missing(
            _Run(lights, points, normals, spp, seed, name, plane, run, folder),
            results,
            starts,
            chunk,
            progress,
        )
    except BaseException:
        with contextlib.suppress(OSError):
            folder.rmdir()  # only if no chunk was finished: leave no empty folder behind
        raise
    merged = Estimate(
        *(np.concatenate([getattr(r, f) for r in results if r is not None]) for f in _FIELDS),
        variant=name,
    )
    dataset = dataset_from_estimate(template, merged, spp=spp, seed=seed, plane=plane)
    dataset.save(out, force=force)
    shutil.rmtree(folder, ignore_errors=True)
    return dataset


@dataclass(frozen=True)
class _Run:
    """What fixes a batch render's numbers, and where its chunks go."""

    lights: list
    points: np.ndarray
    normals: np.ndarray
    spp: int
    seed: int
    variant: str
    plane: Plane | None
    fingerprint: str
    folder: Path


def _render_missing(
    run: _Run,
    results: list[Estimate | None],
    starts: list[int],
    chunk: int,
    progress: Callable[[int, int], None] | None,
) -> None:
    """Render the chunks missing from `results` (in place), writing each as it finishes."""
    total = len(run.points)
    done = sum(len(r.E) for r in results if r is not None)
    if progress is not None and done:
        progress(done, total)
    for k, start in enumerate(starts):
        if results[k] is not None:
            continue
        stop = min(total, start + chunk)
        base = done

        def tick(i: int, _n: int, base: int = base) -> None:
            if progress is not None:
                progress(base + i, total)

        est = estimate_detail(
            run.lights,
            run.points[start:stop],
            run.normals[start:stop],
            spp=run.spp,
            seed=run.seed,
            variant=run.variant,
            plane=run.plane,
            first_index=start,
            progress=_per_receiver(tick, stop - start),
        )
        header = {"run": run.fingerprint, "variant": run.variant, "start": start, "stop": stop}
        _write_chunk(_chunk_path(run.folder, k), est, header)
        results[k] = est
        done += stop - start


def _per_receiver(tick: Callable[[int, int], None], count: int) -> Callable[[int, int], None]:
    """Turn the estimator's (done, total) over components into receivers done in this chunk."""

    def progress(done: int, total: int) -> None:
        tick(done * count // max(total, 1), count)

    return progress
