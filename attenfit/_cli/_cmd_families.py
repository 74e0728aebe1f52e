"""`attenfit families`: the families with formula, parameters and source."""

from __future__ import annotations

import argparse
import json

from .. import _cache
from ._common import EXIT_OK


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "families",
        parents=parents,
        help="list the attenuation families with formula, parameters and source",
    )
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(run=_run_families)


def _descriptions() -> list[dict]:
    """Every built-in family's `describe()`, from the cache when this code wrote it (so that
    listing them does not import JAX), else from the families themselves."""
    cached = _cache.read("families", "describe")
    if cached is not None:
        try:
            return json.loads(cached)
        except ValueError:
            pass
    from .._curves import get_family, list_families

    rows = [get_family(name).describe() for name in list_families()]
    _cache.write("families", "describe", json.dumps(rows).encode())
    return rows


def _run_families(args: argparse.Namespace) -> int:
    rows = _descriptions()
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
