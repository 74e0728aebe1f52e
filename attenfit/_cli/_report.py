"""`attenfit report`: the comparison report."""

from __future__ import annotations

import argparse

from .. import _progress
from ._common import EXIT_OK


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "report",
        parents=parents,
        help="write the comparison report (the main job)",
        description="Compare every attenuation family with exact sphere and disk lights, as "
        "published and fitted: report.md, report.json, results.csv and figures.",
    )
    p.add_argument(
        "--out",
        default="attenfit-report",
        metavar="DIR",
        help="output folder (default: %(default)s)",
    )
    p.add_argument(
        "--emitters",
        nargs="+",
        metavar="NAME",
        help="emitters to compare against: sphere, disk (default: both)",
    )
    p.add_argument(
        "--families", nargs="+", metavar="NAME", help="families to compare (default: all)"
    )
    p.add_argument(
        "--mitsuba",
        nargs="+",
        default=[],
        metavar="FILE.npz",
        help="Monte Carlo datasets (attenfit gen) to add as configurations",
    )
    p.add_argument("--no-fit", action="store_true", help="as published only, no fitted mode")
    p.add_argument(
        "--sweep-n", type=int, default=160, metavar="N", help="distances per sweep (default 160)"
    )
    p.add_argument(
        "--plane-px", type=int, default=96, metavar="N", help="pixels per plane side (default 96)"
    )
    p.add_argument("--svg", action="store_true", help="also write every figure as SVG")
    p.add_argument(
        "--ceiling",
        action="store_true",
        help="add the section 'what no distance curve can fix' (area-light models; minutes)",
    )
    p.add_argument(
        "--force", action="store_true", help="replace an existing non-empty output folder"
    )
    p.set_defaults(run=_run_report)


def _run_report(args: argparse.Namespace) -> int:
    from pathlib import Path

    from .._atomic import check_output_path
    from .._fit import enable_persistent_cache
    from .._report import build_report
    from .._truth import Dataset

    check_output_path(args.out, force=args.force, folder=True)  # refuse before any work
    enable_persistent_cache()  # a second run loads the compiled solves instead of compiling
    datasets = {}
    for path in args.mitsuba:
        name = Path(path).stem
        datasets[name if name not in datasets else f"{name}-{len(datasets) + 1}"] = Dataset.load(
            path
        )
    rep = build_report(
        families=args.families,
        emitters=args.emitters,
        datasets=datasets,
        fitted=not args.no_fit,
        sweep_n=args.sweep_n,
        plane_px=args.plane_px,
        figures_early=True,
        ceiling=args.ceiling,
        progress=_progress.stage,
    )
    _progress.stage("writing figures and tables")
    out = rep.write(args.out, force=args.force, svg=args.svg, progress=_progress.stage)
    failed = sum(1 for r in rep.results if r["status"] != "ok")
    _progress.done(f"wrote {out}/report.md ({len(rep.results)} results, {failed} marked failed)")
    return EXIT_OK
