"""How long a scene recommendation takes: ground truth, then fitting and judging, per example.

For each example scene (`examples/scenes/*.toml`): the time of `Scene.ground_truth()` (the
exact irradiance at the scene's receivers; the peer), of `attenfit.recommend` on a first
call in the process (compiling one solve per family; shapes are padded so that later scenes
reuse them) and of a warm call (median of repeats), and the warm/truth ratio. By default a
subset of families keeps the run short; `ATTENFIT_BENCH_ALL=1` uses every family.

Run: `python -m benchmarks scene` (well under two minutes on 2 idle cores).
"""

from __future__ import annotations

import dataclasses
import os
import time
from pathlib import Path

import jax

from .timing import median_seconds

jax.config.update("jax_enable_x64", True)  # as the CLI

import attenfit  # noqa: E402
from attenfit.scene import Scene  # noqa: E402

SCENES = Path(__file__).resolve().parent.parent / "examples" / "scenes"
FAMILIES = ("inverse_square", "clamped", "disk_facing", "yuksel", "cryengine_linear")
REPEATS = 5


def main() -> None:
    every = os.environ.get("ATTENFIT_BENCH_ALL") == "1"
    print(f"families: {'all' if every else ', '.join(FAMILIES)}; medians of {REPEATS}")
    print(f"{'scene':<22}{'truth s':>10}{'first s':>10}{'warm s':>10}{'warm/truth':>12}  winner")
    for path in sorted(SCENES.glob("*.toml")):
        scene = Scene.load(path)
        if not every:
            scene = dataclasses.replace(scene, families=FAMILIES)
        truth = median_seconds(scene.ground_truth, repeats=REPEATS, warm=False)
        start = time.perf_counter()
        rec = attenfit.recommend(scene, measure=False)
        first = time.perf_counter() - start
        warm = median_seconds(
            lambda s=scene: attenfit.recommend(s, measure=False), repeats=REPEATS, warm=False
        )
        winner = rec.winner.label if rec.winner else "none"
        print(
            f"{path.name:<22}{truth:>10.3f}{first:>10.2f}{warm:>10.3f}{warm / truth:>12.2f}  {winner}"
        )


if __name__ == "__main__":
    main()
