"""`attenfit cache`: what attenfit keeps between runs, and clearing it."""

from __future__ import annotations

import argparse
import json

from .. import _cache
from ._common import EXIT_OK


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "cache",
        parents=parents,
        help="show or clear what attenfit keeps between runs (compiled solves)",
        description="attenfit keeps traced and compiled solves on disk so that a later run "
        "skips that work (about 1-3 s per solve). Entries of another attenfit or JAX version "
        "are never used. The folder is $ATTENFIT_CACHE_DIR, else $XDG_CACHE_HOME/attenfit, "
        "else ~/.cache/attenfit.",
    )
    what = p.add_mutually_exclusive_group()
    what.add_argument("--info", action="store_true", help="show its folder and size (default)")
    what.add_argument("--clear", action="store_true", help="delete everything in it")
    p.add_argument("--json", action="store_true", help="machine-readable output (with --info)")
    p.set_defaults(run=_run_cache)


def _mb(size: int) -> str:
    return f"{size / 1e6:.1f} MB"


def _run_cache(args: argparse.Namespace) -> int:
    if args.clear:
        files, size = _cache.clear()
        print(f"attenfit cache: removed {files} files ({_mb(size)}) from {_cache.folder()}")
        return EXIT_OK
    info = _cache.info()
    if args.json:
        print(json.dumps(info, indent=2))
        return EXIT_OK
    print(f"folder: {info['folder']}")
    print(f"code version: {info['code_version']} (attenfit's sources and library versions)")
    for kind, (files, size) in info["entries"].items():
        print(f"  {kind}: {files} entries, {_mb(size)}")
    if not info["entries"]:
        print("  no entries for this version yet")
    files, size = info["jax_compilation_cache"]
    print(f"JAX's compiled executables: {files} files, {_mb(size)}")
    stale = info["stale_versions"]
    if stale:
        n = sum(f for f, _ in stale.values())
        total = sum(s for _, s in stale.values())
        print(
            f"stale: {len(stale)} other versions, {n} files, {_mb(total)} (never used; "
            "`attenfit cache --clear` deletes them)"
        )
    return EXIT_OK
