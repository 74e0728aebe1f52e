"""`attenfit report`: the comparison report."""

from __future__ import annotations

import argparse
import sys

from ._common import EXIT_OK


def add_parser(sub) -> None:
    p = sub.add_parser(
        "report",
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
    p.add_argument(
        "--force", action="store_true", help="replace an existing non-empty output folder"
    )
    p.set_defaults(run=_run_report)


def _run_report(args: argparse.Namespace) -> int:
    import time

    t0 = time.perf_counter()
    # A signal's exception can be swallowed when it lands in a callback that ignores
    # exceptions (JAX's garbage-collection hook prints "Exception ignored"): remember every
    # SIGINT/SIGTERM and re-raise it at the next progress line, before the report is moved
    # into place, so an interrupted report is never committed.
    caught: list[tuple[int, object]] = []
    restore = _remember_signals(caught)

    def say(msg: str) -> None:
        if caught:
            signum, handler = caught[0]
            if callable(handler):
                handler(signum, None)  # raises as the original handler does
            raise KeyboardInterrupt
        print(
            f"attenfit report: [{time.perf_counter() - t0:5.1f} s] {msg}",
            file=sys.stderr,
            flush=True,
        )

    try:
        return _report_with(args, say, t0)
    finally:
        restore()


def _remember_signals(caught: list):
    """Wrap the SIGINT/SIGTERM handlers to record the signal first; return the undo."""
    import signal

    previous = {}
    for sig in (signal.SIGINT, signal.SIGTERM):
        try:
            prev = signal.getsignal(sig)
            if prev in (signal.SIG_IGN, None):
                continue

            def handler(signum, frame, prev=prev):
                caught.append((signum, prev))
                if callable(prev):
                    prev(signum, frame)
                raise KeyboardInterrupt

            signal.signal(sig, handler)
            previous[sig] = prev
        except (ValueError, OSError):  # not the main thread: leave the handlers alone
            pass

    def restore() -> None:
        for sig, prev in previous.items():
            signal.signal(sig, prev)

    return restore


def _report_with(args: argparse.Namespace, say, t0: float) -> int:
    import time

    from .._atomic import check_output_path
    from .._report import build_report

    check_output_path(args.out, force=args.force, folder=True)  # refuse before any work
    from .._fit import enable_persistent_cache

    enable_persistent_cache()  # a second run loads the compiled solves instead of compiling
    datasets = {}
    if args.mitsuba:
        from .._truth import Dataset

        for path in args.mitsuba:
            from pathlib import Path

            name = Path(path).stem
            datasets[name if name not in datasets else f"{name}-{len(datasets) + 1}"] = (
                Dataset.load(path)
            )
    rep = build_report(
        families=args.families,
        emitters=args.emitters,
        datasets=datasets,
        fitted=not args.no_fit,
        sweep_n=args.sweep_n,
        plane_px=args.plane_px,
        progress=say,
    )
    say("writing figures and tables")
    out = rep.write(args.out, force=args.force, progress=say)
    failed = sum(1 for r in rep.results if r["status"] != "ok")
    say(
        f"wrote {out}/report.md ({len(rep.results)} results, {failed} marked failed) "
        f"in {time.perf_counter() - t0:.1f} s"
    )
    return EXIT_OK
