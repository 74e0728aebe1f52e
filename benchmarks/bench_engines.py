"""Engines x example lights: the error attenfit claims (its curve checked at the light's
receivers) and the error the engine renders with attenfit's properties (the engine witness,
`attenfit._judge._engine_shading`), per engine and per light of the example scenes:
examples/scenes/*.toml (`answer_scene`) and the Blender room, examples/scenes/blender/
room.usda and room.glb with their side file (`answer_file`).

Prints the Markdown table of docs/usd-gltf.md ("What the engine renders"). Each cell:
claimed / engine-rendered worst case, "fail" where no settings of the engine bring the light
within the scene's tolerance (the closest found given: the engine's best over every
property it exposes for the light, `attenfit._scenes._engine_search`). Each scene's wall time
per engine (answer and search; fits and ground truth are cached after a first run) and the
load go to stderr.

Run: `python -m benchmarks engines` (about ten minutes on 2 busy cores), or
`python benchmarks/bench_engines.py --samples 512` for a quick look (the doc's table uses
the default receivers per light of a USD or glTF file).
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)  # as the CLI

from attenfit._scenes import Scene  # noqa: E402
from attenfit._scenes._answer import answer_file, answer_scene  # noqa: E402
from attenfit._scenes._engine import ENGINES  # noqa: E402

SCENES = Path(__file__).resolve().parent.parent / "examples" / "scenes"
BLENDER = SCENES / "blender"
FILES = (BLENDER / "room.usda", BLENDER / "room.glb")


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.3g}%"


def answers(path: Path, samples: int | None):
    """(engine, FileAnswer, wall seconds) for every engine, for one example scene."""
    for engine in ENGINES:
        t = time.perf_counter()
        if path.suffix == ".toml":
            ans = answer_scene(Scene.load(path), engine)
        else:
            side = BLENDER / "room.side.toml"
            ans = answer_file(path, side=side, engine=engine, samples=samples)
        yield engine, ans, time.perf_counter() - t


def table(samples: int | None = None) -> str:
    """The Markdown table (module docstring)."""
    paths = [*FILES, *sorted(SCENES.glob("*.toml"))]
    engines = list(ENGINES)
    lines = [
        "| scene | light | kind | " + " | ".join(engines) + " |",
        "|---|---|---|" + "---|" * len(engines),
    ]
    for path in paths:
        rows: dict[str, list[str]] = {}
        for engine, ans, wall in answers(path, samples):
            for c in ans.choices:
                key = f"| {path.name} | {c.name} | {c.file_kind} |"
                cell = f"{_pct(c.checked_error)} / {_pct(c.engine_error)}"
                rows.setdefault(key, []).append(cell + ("" if c.status == "pass" else " fail"))
            load = os.getloadavg()[0]
            print(f"  {path.name}: {engine} {wall:.1f} s (load {load:.1f})", file=sys.stderr)
        lines += [f"{k} {' | '.join(v)} |" for k, v in rows.items()]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    """`python -m benchmarks engines [--samples N]` or `python -m benchmarks.bench_engines`."""
    ap = argparse.ArgumentParser(
        prog="python -m benchmarks engines", description=__doc__.split("\n\n")[0]
    )
    ap.add_argument("--samples", type=int, default=None, help="receivers per light of a file")
    print(table(ap.parse_args(argv).samples), flush=True)


if __name__ == "__main__":
    main()
