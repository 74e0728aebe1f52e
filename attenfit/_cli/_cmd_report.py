"""`attenfit report`: the comparison report."""

from __future__ import annotations

import argparse

from .. import _progress
from .._errors import AttenfitError, BadValueError
from ._common import EXIT_OK, OWN_MARKS, check_output


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
        help="emitters to compare against: sphere, disk (default: both); rect, tube add "
        "the rectangle's and the tube's ceiling and decision rows, judged on planes beside "
        "them (e.g. --emitters rect,tube; a minute or more each)",
    )
    p.add_argument(
        "--shape-grid",
        type=int,
        default=33,
        metavar="N",
        help="grid points per side of the rect and tube worst-case search (default 33)",
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

    from .._fit import enable_persistent_cache
    from .._report import build_report, split_shapes
    from .._truth import Dataset

    emitters, shapes = split_shapes(args.emitters)
    if args.shape_grid < 3:
        raise BadValueError(f"--shape-grid must be at least 3, got {args.shape_grid}")
    check_output(
        args.out, force=args.force, marks=OWN_MARKS["report"], folder=True
    )  # before any work
    enable_persistent_cache()  # a second run loads the compiled solves instead of compiling
    datasets = {}
    for path in args.mitsuba:
        # the file's stem names the configuration: letters, digits and '_.+-' (it names files)
        name = re.sub(r"[^A-Za-z0-9_.+-]", "_", Path(path).stem).lstrip("_.+-")[:48] or "dataset"
        ds = Dataset.load(path)
        _check_grid(path, ds)
        datasets[name if name not in datasets else f"{name}-{len(datasets) + 1}"] = ds
    witness = None
    if not args.no_mitsuba:  # once the options are known to be good (no thread left behind)
        from .._report import resolve_emitters, resolve_families

        resolve_families(args.families)
        if min(args.sweep_n, args.plane_px) >= 8:
            witness = _Witness(resolve_emitters(emitters))
    rep = build_report(
        families=args.families,
        emitters=emitters,
        shapes=shapes,
        shape_grid=args.shape_grid,
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


def _check_grid(path: str, ds) -> None:
    """Refuse, before any work, a `--mitsuba` dataset whose provenance describes a receiver
    grid the report cannot draw: what the report reads (`shape`, `grid_index`, the axes
    `up`, `x_axis`, `y_axis`, `extent`; `variant` beside `spp`) must be what `plane_receivers`
    and `attenfit gen` write, and the image must fit the memory budget."""
    import math

    import numpy as np

    from .. import _budget
    from .._input import text_name

    prov = ds.provenance
    where = f"--mitsuba {text_name(path)!r}"  # at most PATH_MAX: the command line checks

    def bad(what: str, value) -> BadValueError:
        return BadValueError(f"{where}: its provenance {what}, got {repr(value)[:60]}")

    def whole(v) -> bool:
        return isinstance(v, int) and not isinstance(v, bool)

    def vector(v) -> bool:
        return (
            isinstance(v, list)
            and len(v) == 3
            and all((whole(x) or isinstance(x, float)) and math.isfinite(x) for x in v)
            and any(x != 0 for x in v)
        )

    if "spp" in prov and "variant" not in prov:
        raise bad("gives 'spp' without 'variant'", prov["spp"])
    shape = prov.get("shape")
    if shape is None:
        return
    if not isinstance(shape, list) or not all(whole(v) and v > 0 for v in shape):
        raise bad("'shape' must be a list of positive integers", shape)
    if len(shape) != 2:
        return  # not an image: the report does not draw it
    cells = shape[0] * shape[1]
    _budget.check(cells * 128, f"the {shape[0]} x {shape[1]} grid of {where}", "a smaller grid")
    index = prov.get("grid_index", list(range(cells)) if cells == len(ds) else None)
    if not isinstance(index, list) or len(index) != len(ds):
        raise bad(f"'grid_index' must list the grid cell of each of its {len(ds)} receivers", index)
    if not all(whole(i) for i in index):
        raise bad("'grid_index' must hold integers", next(i for i in index if not whole(i)))
    flat = np.asarray(index, np.int64)
    if flat.size and not (flat.min() >= 0 and flat.max() < cells):
        outside = flat[(flat < 0) | (flat >= cells)]
        raise bad(f"'grid_index' must lie in [0, {cells}) for a {shape} grid", int(outside[0]))
    cells_used, counts = np.unique(flat, return_counts=True)
    if np.any(counts > 1):
        raise bad("'grid_index' must name each grid cell once", int(cells_used[counts > 1][0]))
    for key in ("up", "x_axis", "y_axis"):
        if key in prov and not vector(prov[key]):
            raise bad(f"{key!r} must be 3 finite numbers, not all 0", prov[key])
    extent = prov.get("extent")
    if extent is not None and not (
        (whole(extent) or isinstance(extent, float)) and math.isfinite(extent) and extent > 0
    ):
        raise bad("'extent' must be a finite number > 0", extent)


class _Witness:
    """The Mitsuba witness rendered in a background thread while the report builds.

    `data_gen.witness` (imported here, lazily, as `attenfit gen` does: attenfit's library
    never imports data_gen) builds the floor and random receivers of each light, their exact
    values and a Mitsuba render. The probe of the LLVM variant runs in a child process and
    the kernels outside the GIL, so on two cores most of it hides behind the report's fits.
    """

    def __init__(self, emitters):
        import threading

        from .._report import cached_witness, witness_key

        self.emitters, self.value, self.error, self.seconds = emitters, None, None, 0.0
        self.key = witness_key(emitters, "data_gen", call="render_witness(emitters), x64")
        self.cached = cached_witness(self.key)  # the same lights and renderer: no render
        self.thread = threading.Thread(target=self._run, name="mitsuba-witness", daemon=True)
        if self.cached is None:
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

        from .._report import store_witness, witness_section

        if self.cached is not None:
            return self.cached
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
        section = witness_section(self.value, seconds=self.seconds)
        store_witness(self.key, section)
        return section
