"""How long a USD scene takes to answer: the Blender room (examples/scenes/blender/room.usda:
a sphere, a spot, a disk and a rectangle light) with 6,667 receivers per light (26,668 in all).

Per configuration, the first call in the process (compiling the solves of the families'
groups and the truth's programs) and the warm call (median of repeats) of `answer_file`,
split into reading and sampling, ground truth, and fitting plus judging plus the per-light
choices (and the range trade, with a threshold). Configurations: every family; `--engine
godot` with the range trade; every family with `precision = float32`. The goal (issue
21): <= 5 s warm.

Run: `python -m benchmarks usd` (a few minutes cold on 2 busy cores).
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)  # as the CLI

from attenfit._fit import enable_persistent_cache  # noqa: E402
from attenfit._scenes._answer import answer_file  # noqa: E402
from attenfit._scenes._files import load_mesh_scene  # noqa: E402

ROOM = Path(__file__).resolve().parent.parent / "examples" / "scenes" / "blender" / "room.usda"
SAMPLES = 6667
REPEATS = 2
CONFIGS = {
    "every family": {},
    "godot + range trade": {"engine": "godot", "threshold": 0.1},
    "every family, float32": {"precision": "float32"},
}


def _quiet(_msg: str) -> None:
    return None


def main() -> None:
    enable_persistent_cache()
    lights = len(load_mesh_scene(ROOM, samples=SAMPLES, notice=_quiet).scene.lights)
    print(f"{ROOM.name}: {lights} lights x {SAMPLES} receivers; warm = median of {REPEATS}")
    print(f"{'configuration':<26}{'first s':>9}{'warm s':>9}{'read s':>9}{'truth s':>9}  per light")
    for label, opts in CONFIGS.items():
        start = time.perf_counter()
        ans = answer_file(ROOM, samples=SAMPLES, notice=_quiet, **opts)
        first = time.perf_counter() - start
        warm, read, truth = [], [], []
        for _ in range(REPEATS):
            t0 = time.perf_counter()
            im = load_mesh_scene(ROOM, samples=SAMPLES, notice=_quiet, **opts)
            t1 = time.perf_counter()
            im.scene.ground_truth()
            t2 = time.perf_counter()
            ans = answer_file(ROOM, samples=SAMPLES, notice=_quiet, **opts)
            warm.append(time.perf_counter() - t2)
            read.append(t1 - t0)
            truth.append(t2 - t1)
        print(
            f"{label:<26}{first:>9.2f}{statistics.median(warm):>9.2f}"
            f"{statistics.median(read):>9.2f}{statistics.median(truth):>9.2f}  {ans.summary()}"
        )


if __name__ == "__main__":
    main()
