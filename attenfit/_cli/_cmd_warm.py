"""`attenfit warm`: prepare, once, what scenes compile, so that later scenes start warm."""

from __future__ import annotations

import argparse
import contextlib
import io
from pathlib import Path

from .. import _progress
from .._errors import BadValueError
from ._common import EXIT_OK

#: attenfit's example scenes, beside the package in a source checkout.
_EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "warm",
        parents=parents,
        help="prepare the compiled programs scenes use, once (later scenes start warm)",
        description="Answer each scene FILE once, quietly (nothing on stdout), so that "
        "attenfit's cache holds what answering it compiles: the solves that fit every "
        "family (one per shape of fit, shared by every scene with the same size of "
        "receivers), the lights' exact irradiance, and the answer itself. A later "
        "`attenfit scene` of these files, or of scenes of the same lights and sizes, "
        "compiles nothing. Without FILE: attenfit's example scenes (examples/scenes in a "
        "source checkout). A USD or glTF FILE takes the side file FILE.side.toml beside "
        "it, when there is one.",
    )
    p.add_argument(
        "files",
        nargs="*",
        metavar="FILE",
        help="scene files (TOML, USD, glTF) to prepare for (default: the example scenes)",
    )
    p.set_defaults(run=_run_warm)


def _examples() -> list[Path]:
    """The example scenes, when attenfit runs from its source checkout."""
    if not _EXAMPLES.is_dir():
        return []
    blender = _EXAMPLES / "blender"
    return sorted(_EXAMPLES.glob("*.toml")) + [
        f for f in (blender / "room.usda", blender / "room.glb") if f.is_file()
    ]


def _side(file: Path) -> Path | None:
    side = file.with_name(f"{file.stem}.side.toml")
    return side if side.is_file() else None


def _run_warm(args: argparse.Namespace) -> int:
    files = [Path(f) for f in args.files] or _examples()
    if not files:
        raise BadValueError(
            "no scene FILE given, and attenfit's example scenes are not beside it: "
            "name the scenes to prepare for (attenfit warm FILE ...)"
        )
    for f in files:
        if not f.is_file():
            raise BadValueError(f"{f}: no such scene file")
    import jax

    from .._fit import enable_persistent_cache

    jax.config.update("jax_enable_x64", True)  # as `attenfit scene` runs
    enable_persistent_cache()
    with _progress.count(len(files), f"preparing {len(files)} scenes") as bar:
        for f in files:
            bar.note(f.name)
            _answer(f)
            bar.update()
    _progress.done(f"prepared {len(files)} scenes; later runs of them load what they compiled")
    return EXIT_OK


def _answer(file: Path) -> None:
    """Answer one scene as `attenfit scene FILE` does, saying nothing (its stages quiet)."""
    from .._scenes import Scene, answer_file, is_mesh_scene, recommend

    quiet = _progress.Progress("attenfit warm", quiet=True)
    with _progress.active(quiet), contextlib.redirect_stdout(io.StringIO()):
        if is_mesh_scene(str(file)):
            side = _side(file)
            answer_file(str(file), side=None if side is None else str(side))
        else:
            recommend(Scene.load(file))
