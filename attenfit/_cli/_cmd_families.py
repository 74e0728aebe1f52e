"""`attenfit families`: the families, then the area models, with formula, parameters and
source."""

from __future__ import annotations

import argparse
import json

from .. import _cache
from ._common import EXIT_OK

#: The cache entry of the listing (`attenfit._cache`, kind "families": checked in shape there).
CACHE_KEY = "describe"


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "families",
        parents=parents,
        help="list the attenuation families and the area models with formula, parameters and "
        "source",
    )
    p.add_argument(
        "--json",
        action="store_true",
        help='machine-readable output: {"families": [...], "area_models": [...]}',
    )
    p.set_defaults(run=_run_families)


def _descriptions() -> dict[str, list[dict]]:
    """Every built-in family's and area model's `describe()`, from the cache when this code
    wrote it (so that listing them does not import JAX), else from the models themselves."""
    cached = _cache.read("families", CACHE_KEY)
    if cached is not None:
        try:
            return json.loads(cached)
        except ValueError:
            pass
    from .._curves import get_area_model, get_family, list_area_models, list_families

    rows = {
        "families": [get_family(name).describe() for name in list_families()],
        "area_models": [get_area_model(name)().describe() for name in list_area_models()],
    }
    _cache.write("families", CACHE_KEY, json.dumps(rows).encode())
    return rows


def _run_families(args: argparse.Namespace) -> int:
    rows = _descriptions()
    if args.json:
        print(json.dumps(rows, indent=2))
        return EXIT_OK
    for row in rows["families"]:
        print(
            f"{row['name']}\n  f(d)   = {row['formula']}\n  params : {_params(row)}\n"
            f"  source : {row['source']}\n"
        )
    print(
        "Area models: E/I from the receiver geometry (d, cos_r, cos_e, r, cos_n, g; docs/area.md)\n"
    )
    for row in rows["area_models"]:
        family = f" of {row['family']}" if row.get("family") else ""
        print(
            f"{row['name']} (lights: {row['light']}{family})\n  E/I    = {row['formula']}\n"
            f"  params : {_params(row)}\n  source : {row['source']}\n"
        )
    return EXIT_OK


def _params(row: dict) -> str:
    """`name=default, ...` of a row's parameters, or "none"."""
    return (
        ", ".join(f"{p}={_fmt_default(v['default'])}" for p, v in row["params"].items()) or "none"
    )


def _fmt_default(value) -> str:
    """A parameter default for the table: numbers with %g, arrays as short lists."""
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_fmt_default(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)
