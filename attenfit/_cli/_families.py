"""`attenfit families`: the families with formula, parameters and source."""

from __future__ import annotations

import argparse
import json

from ._common import EXIT_OK


def add_parser(sub) -> None:
    p = sub.add_parser(
        "families", help="list the attenuation families with formula, parameters and source"
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=_run_families)


def _run_families(args: argparse.Namespace) -> int:
    from .._curves import get_family, list_families

    rows = [get_family(name).describe() for name in list_families()]
    if args.json:
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    for row in rows:
        params = (
            ", ".join(f"{p}={_fmt_default(v['default'])}" for p, v in row["params"].items())
            or "none"
        )
        print(
            f"{row['name']}\n  f(d)   = {row['formula']}\n  params : {params}\n  source : {row['source']}\n"
        )
    return EXIT_OK


def _fmt_default(value) -> str:
    """A parameter default for the table: numbers with %g, arrays as short lists."""
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_fmt_default(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
