"""`attenfit scene`: what a scene file needs, and the cheapest family that gives it. A TOML
scene (docs/scenes.md) or a USD/glTF file (docs/usd-gltf.md), answered per light."""

from __future__ import annotations

import argparse
import json

from .. import _progress
from .._errors import BadValueError
from ._common import EXIT_OK, OWN_MARKS, check_output

#: The engines `--engine` takes: `attenfit._scenes._engine.ENGINES`, named here so that
#: `--help` does not import the scene stage (JAX); tests/test_architecture.py checks them.
ENGINE_NAMES = ("godot", "threejs", "unreal", "filament", "bevy", "unity", "gltf")

_FILE_ONLY = ("side", "tolerance", "precision", "threshold", "samples", "radius", "time", "write_back")  # fmt: skip


def add_parser(sub, parents: list) -> None:

    p = sub.add_parser(
        "scene",
        parents=parents,
        help="fit what a scene file needs and recommend the cheapest family",
        description="Generate ground truth only for the scene's lights and receivers, fit every "
        "family its constraints allow, and recommend the cheapest within its tolerance. "
        "A USD (.usd, .usda, .usdc) or glTF (.gltf, .glb) file is answered per light, "
        "receivers sampled on its meshes. Exit 0 even when no family meets the tolerance "
        "(the output says so); 2 for a bad scene file.",
    )
    p.add_argument(
        "file",
        metavar="FILE",
        help="a TOML scene file (docs/scenes.md), or a USD or glTF scene (docs/usd-gltf.md)",
    )
    p.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="write recommendation.md/.json, the winner's shaders and errors.png into DIR",
    )
    p.add_argument(
        "--force", action="store_true", help="replace an existing DIR or write-back file"
    )
    p.add_argument("--json", action="store_true", help="print the recommendation as JSON")
    p.add_argument(
        "--measure",
        action="store_true",
        help="also time each candidate on this machine (reported beside its shader cost)",
    )
    p.add_argument(
        "--engine",
        choices=ENGINE_NAMES,
        default=None,
        help="only what this engine can express; per light, the engine's own properties",
    )
    g = p.add_argument_group("USD and glTF scenes")
    g.add_argument("--side", metavar="TOML", help="a side file of options (docs/usd-gltf.md)")
    g.add_argument("--tolerance", type=float, help="largest relative error (default 0.05)")
    g.add_argument("--precision", choices=("float64", "float32", "float16"), default=None)
    g.add_argument(
        "--threshold",
        type=float,
        help="visibility threshold (absolute irradiance): choose each light's smallest range",
    )
    g.add_argument("--samples", type=int, help="receivers per light (default 4096)")
    g.add_argument("--radius", type=float, help="radius (m) of every light the file gives none")
    g.add_argument(
        "--strict",
        action="store_true",
        help="refuse lights attenfit cannot model (dome, distant, shaped rect, ...) instead of skipping them",
    )
    g.add_argument(
        "--time",
        type=float,
        metavar="T",
        help="USD time code to read every value at (default: each value's default, or the "
        "stage's start time code for a value authored only as time samples)",
    )
    g.add_argument(
        "--write-back",
        metavar="OUT",
        help="write a copy of the scene with the answers (OUT.gltf or OUT.usda)",
    )
    p.set_defaults(run=_run_scene)


#: What `attenfit scene --out DIR` writes (a TOML scene's recommendation, a file's answer):
#: `--force` replaces an existing DIR only when it holds one, i.e. when attenfit wrote it.
def _run_scene(args: argparse.Namespace) -> int:
    from .._atomic import check_distinct
    from .._fit import enable_persistent_cache
    from .._scenes import Scene, is_mesh_scene, recommend

    mesh = is_mesh_scene(args.file)
    if not mesh:
        given = [k for k in _FILE_ONLY if getattr(args, k) is not None] + (
            ["strict"] if args.strict else []
        )
        if given:
            raise BadValueError(
                f"--{given[0].replace('_', '-')} applies to USD and glTF scenes; a TOML scene "
                "says it in the file"
            )
    held = None
    if mesh:  # before any work: the outputs apart, and every file the scene reads found
        from .._scenes import WRITE_BACK_MARKS, scene_files

        check_distinct({"--out": args.out, "--write-back": args.write_back})
        held = scene_files(args.file)  # recorded as inputs: no output may replace one
    if args.out is not None:
        check_output(args.out, force=args.force, marks=OWN_MARKS["answer"], folder=True)
    if mesh and args.write_back is not None:
        check_output(args.write_back, force=args.force, marks=WRITE_BACK_MARKS)
    import jax

    jax.config.update("jax_enable_x64", True)  # truth and fits in float64 (float32: a constraint)
    enable_persistent_cache()
    if mesh:
        code = _run_file(args)
        del held  # a USD scene's layers, opened once, kept open until here
        return code
    scene = Scene.load(args.file)
    if args.engine is not None:
        return _run_engine(args, scene)
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


def _run_engine(args: argparse.Namespace, scene) -> int:
    """A TOML scene with `--engine`: answered per light as a file is (`answer_scene`): each
    light's engine properties and the error the engine renders with them."""
    from .._scenes import answer_scene

    return _print_answer(args, answer_scene(scene, args.engine, measure=args.measure))


def _run_file(args: argparse.Namespace) -> int:
    from .._scenes import answer_file

    ans = answer_file(
        args.file,
        measure=args.measure,
        side=args.side,
        tolerance=args.tolerance,
        precision=args.precision,
        threshold=args.threshold,
        samples=args.samples,
        radius=args.radius,
        engine=args.engine,
        strict=True if args.strict else None,
        time=args.time,
    )
    return _print_answer(args, ans)


def _print_answer(args: argparse.Namespace, ans) -> int:
    """Print a per-light answer (Markdown, or JSON with `--json`), write `--out` and
    `--write-back` where asked."""
    if args.json:
        print(json.dumps(ans.to_dict(), indent=2))
    else:
        print(ans.to_markdown(), end="")
    wrote = []
    if args.out is not None:
        _progress.stage(f"writing {args.out}")
        ans.save(args.out, force=args.force)
        wrote.append(args.out)
    if args.write_back is not None:
        ans.write_back(args.write_back, force=args.force)
        wrote.append(args.write_back)
    _progress.done(ans.summary() + (f"; wrote {', '.join(wrote)}" if wrote else ""))
    return EXIT_OK
