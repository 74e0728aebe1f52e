"""`attenfit scene`: what a scene file needs, and the cheapest family that gives it."""

from __future__ import annotations

import argparse
import json

from .. import _progress
from ._common import EXIT_OK


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "scene",
        parents=parents,
        help="fit what a scene file needs and recommend the cheapest family",
        description="Generate ground truth only for the scene's lights and receivers, fit every "
        "family its constraints allow, and recommend the cheapest within its tolerance. "
        "Exit 0 even when no family meets the tolerance (the output says so); 2 for a bad "
        "scene file.",
    )
    p.add_argument("file", metavar="FILE", help="a TOML scene file (docs/scenes.md)")
    p.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="write recommendation.md/.json, the winner's shaders and errors.png into DIR",
    )
    p.add_argument("--force", action="store_true", help="replace an existing non-empty DIR")
    p.add_argument("--json", action="store_true", help="print the recommendation as JSON")
    p.add_argument(
        "--measure",
        action="store_true",
        help="also time each candidate on this machine (reported beside its shader cost)",
    )
    p.set_defaults(run=_run_scene)


def _run_scene(args: argparse.Namespace) -> int:
    from .._atomic import check_output_path
    from .._fit import enable_persistent_cache
    from .._scenes import Scene, recommend

    scene = Scene.load(args.file)
    if args.out is not None:
        check_output_path(args.out, force=args.force, folder=True)
    import jax

    jax.config.update("jax_enable_x64", True)  # truth and fits in float64 (float32: a constraint)
    enable_persistent_cache()
    rec = recommend(scene, measure=args.measure)
    if args.json:
        print(json.dumps(rec.to_dict(), indent=2))
    else:
        print(rec.to_markdown(), end="")
    if args.out is not None:
        _progress.stage(f"writing {args.out}")
        rec.save(args.out, force=args.force)
    wrote = f"; wrote {args.out}" if args.out is not None else ""
    _progress.done(f"{rec.summary()}{wrote}")
    return EXIT_OK
