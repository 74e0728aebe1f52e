"""The `attenfit` command line: a thin layer over the Python API.

`get_parser()` builds the parser; `main(argv)` runs one verb and returns its exit code:
0 success, 2 bad input (one line on stderr, no traceback), 3 a fit that did not converge,
1 anything else. Each verb is one small function that calls the API.
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Sequence

from ._errors import AttenfitError

__all__ = ["EXIT_BAD_INPUT", "EXIT_ERROR", "EXIT_NOT_CONVERGED", "EXIT_OK", "get_parser", "main"]

EXIT_OK, EXIT_ERROR, EXIT_BAD_INPUT, EXIT_NOT_CONVERGED = 0, 1, 2, 3


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line and exit 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _UsageError(f"{self.prog}: {message} (see {self.prog} --help)")


class _UsageError(Exception):
    pass


# ----------------------------------------------------------------------------- families
def _add_families(sub) -> None:
    p = sub.add_parser(
        "families", help="list the attenuation families with formula, parameters and source"
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=_run_families)


def _run_families(args: argparse.Namespace) -> int:
    from ._family import get_family, list_families

    rows = [get_family(name).describe() for name in list_families()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    for row in rows:
        params = (
            ", ".join(
                f"{p}={v['default']:g}"
                if isinstance(v["default"], float)
                else f"{p}={v['default']}"
                for p, v in row["params"].items()
            )
            or "none"
        )
        print(
            f"{row['name']}\n  f(d)   = {row['formula']}\n  params : {params}\n  source : {row['source']}\n"
        )
    return EXIT_OK


# ----------------------------------------------------------------------------- other verbs
def _not_yet(verb: str):
    def run(args: argparse.Namespace) -> int:
        print(f"attenfit {verb}: not available in this version", file=sys.stderr)
        return EXIT_ERROR

    return run


def _add_truth(sub) -> None:
    p = sub.add_parser("truth", help="write an exact ground-truth irradiance dataset (.npz)")
    p.set_defaults(run=_not_yet("truth"))


def _add_gen(sub) -> None:
    p = sub.add_parser("gen", help="render a ground-truth dataset independently with Mitsuba 3")
    p.set_defaults(run=_not_yet("gen"))


def _add_fit(sub) -> None:
    p = sub.add_parser("fit", help="fit families to a dataset or a built-in configuration")
    p.set_defaults(run=_not_yet("fit"))


def _add_report(sub) -> None:
    p = sub.add_parser("report", help="write the comparison report (the main job)")
    p.set_defaults(run=_not_yet("report"))


def _add_scene(sub) -> None:
    p = sub.add_parser(
        "scene", help="fit what a scene file needs and recommend the cheapest family"
    )
    p.set_defaults(run=_not_yet("scene"))


def _add_export(sub) -> None:
    p = sub.add_parser("export", help="write a (fitted) family as a GLSL, HLSL, WGSL or C function")
    p.set_defaults(run=_not_yet("export"))


# ----------------------------------------------------------------------------- entry point
def get_parser() -> argparse.ArgumentParser:
    """The `attenfit` argument parser."""
    parser = _Parser(
        prog="attenfit",
        description="How well does a cheap light-attenuation curve stand in for a real light?",
    )
    from . import __version__

    parser.add_argument("--version", action="version", version=f"attenfit {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB", parser_class=_Parser)
    for add in (
        _add_families,
        _add_truth,
        _add_gen,
        _add_fit,
        _add_report,
        _add_scene,
        _add_export,
    ):
        add(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with `argv` (default: `sys.argv[1:]`); return the exit code."""
    parser = get_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "run", None):
            parser.print_help(sys.stderr)
            return EXIT_BAD_INPUT
        return int(args.run(args))
    except _UsageError as exc:
        print(exc, file=sys.stderr)
        return EXIT_BAD_INPUT
    except AttenfitError as exc:
        print(f"attenfit: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("attenfit: interrupted; no output was written", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # a bug: say what, in one line, without a traceback
        print(f"attenfit: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_ERROR


if __name__ == "__main__":
    sys.exit(main())
