"""`attenfit report`: the comparison report."""

from __future__ import annotations

import argparse

from .. import _progress
from .._errors import AttenfitError
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
        "--no-mitsuba",
        action="store_true",
        help="skip the Mitsuba witness (a ~10 s render of each light's floor and random "
        "receivers, z-scores against the exact values)",
    )
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
    import re
    from pathlib import Path

    from .._atomic import check_output_path
    from .._fit import enable_persistent_cache
    from .._report import build_report
    from .._truth import Dataset

    check_output_path(args.out, force=args.force, folder=True)  # refuse before any work
    enable_persistent_cache()  # a second run loads the compiled solves instead of compiling
    datasets = {}
    for path in args.mitsuba:
        # the file's stem names the configuration: letters, digits and '_.+-' (it names files)
        name = re.sub(r"[^A-Za-z0-9_.+-]", "_", Path(path).stem).lstrip("_.+-")[:48] or "dataset"
        datasets[name if name not in datasets else f"{name}-{len(datasets) + 1}"] = Dataset.load(
            path
        )
    witness = None
    if not args.no_mitsuba:  # once the options are known to be good (no thread left behind)
        from .._report import resolve_emitters, resolve_families

        resolve_families(args.families)
        if min(args.sweep_n, args.plane_px) >= 8:
            witness = _Witness(resolve_emitters(args.emitters))
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
    if witness is not None:
        rep.witness = witness.result()
    _progress.stage("writing figures and tables")
    out = rep.write(args.out, force=args.force, svg=args.svg, progress=_progress.stage)
    failed = sum(1 for r in rep.results if r["status"] != "ok")
    _progress.done(f"wrote {out}/report.md ({len(rep.results)} results, {failed} marked failed)")
    return EXIT_OK


class _Witness:
    """The Mitsuba witness rendered in a background thread while the report builds.

    `data_gen.witness` (imported here, lazily, as `attenfit gen` does: attenfit's library
    never imports data_gen) builds the floor and random receivers of each light, their exact
    values and a Mitsuba render. The probe of the LLVM variant runs in a child process and
    the kernels outside the GIL, so on two cores most of it hides behind the report's fits.
    """

    def __init__(self, emitters):
        import threading

        self.emitters, self.value, self.error, self.seconds = emitters, None, None, 0.0
        self.thread = threading.Thread(target=self._run, name="mitsuba-witness", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        import time

        import jax

        start = time.perf_counter()
        try:
            from data_gen.variants import require_mitsuba
            from data_gen.witness import render_witness

            require_mitsuba()
            with jax.enable_x64(True):  # thread-local, as in build_report
                self.value = render_witness(self.emitters)
        except BaseException as exc:  # handed to the main thread by result()
            self.error = exc
        self.seconds = time.perf_counter() - start

    def result(self):
        """The report's witness section, or None (with a notice) without data_gen or Mitsuba."""
        import sys

        from .._report import witness_section

        if self.thread.is_alive():
            _progress.stage("waiting for the Mitsuba witness")
        self.thread.join()
        if isinstance(self.error, ImportError | AttenfitError):
            print(
                f"attenfit report: no Mitsuba witness ({self.error}); --no-mitsuba skips it",
                file=sys.stderr,
            )
            return None
        if self.error is not None:
            raise self.error
        return witness_section(self.value, seconds=self.seconds)
