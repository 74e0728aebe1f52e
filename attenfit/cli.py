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


# ----------------------------------------------------------------------------- other verbs
def _not_yet(verb: str):
    def run(args: argparse.Namespace) -> int:
        print(f"attenfit {verb}: not available in this version", file=sys.stderr)
        return EXIT_ERROR

    return run


def _add_truth(sub) -> None:
    p = sub.add_parser(
        "truth",
        help="write an exact ground-truth irradiance dataset (.npz)",
        description="Exact irradiance (attenfit.irradiance) from one emitter at the origin at "
        "facing, plane or random receivers, written as an attenfit dataset (.npz). The sphere "
        "sits at the origin, the disk at the origin facing -z, the capsule along x centred on "
        "the origin.",
    )
    _add_configuration_args(p, height_help="plane: depth of the plane below the centre (default r)")
    p.add_argument("--seed", type=int, default=0, help="random receivers' seed (default 0)")
    p.add_argument("--dtype", choices=["float32", "float64"], default="float64")
    p.add_argument("--out", required=True, help="output file, FILE.npz")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.set_defaults(run=_run_truth)


def _parse_range(text: str) -> tuple[float, float]:
    from ._errors import BadValueError

    parts = text.split(":")
    try:
        if len(parts) != 2:
            raise ValueError
        lo, hi = float(parts[0]), float(parts[1])
    except ValueError:
        raise BadValueError(f"--range must be A:B with two numbers, got {text!r}") from None
    if not (0 < lo <= hi < float("inf")):
        raise BadValueError(f"--range A:B needs 0 < A <= B < inf, got {text!r}")
    return lo, hi


def _add_configuration_args(p, *, height_help: str) -> None:
    """The emitter and receiver options of `attenfit truth` and `attenfit gen` (one configuration)."""
    p.add_argument("--emitter", required=True, choices=["sphere", "disk", "capsule"])
    p.add_argument("--radius", required=True, type=float, help="emitter radius (m)")
    p.add_argument(
        "--intensity", type=float, default=1.0, help="point-equivalent intensity I (default 1)"
    )
    p.add_argument(
        "--length", type=float, default=None, help="capsule segment length (default 4 radius)"
    )
    p.add_argument("--two-sided", action="store_true", help="two-sided disk")
    p.add_argument("--receivers", choices=["facing", "plane", "random"], default="facing")
    p.add_argument(
        "--range",
        default=None,
        metavar="A:B",
        help="distance range (m) for facing/random receivers (default 1.001 r:1000 r; disk 0.001 r:1000 r)",
    )
    p.add_argument("--height", type=float, default=None, help=height_help)
    p.add_argument(
        "--extent", type=float, default=None, help="plane: half-width of the grid (default 10 r)"
    )
    p.add_argument(
        "--samples",
        type=int,
        default=None,
        help="receivers (facing/random, default 256) or grid points per side (plane, default 64)",
    )


def _check_configuration(args: argparse.Namespace) -> None:
    """Eager checks of the options `_add_configuration_args` declares (before any output check)."""
    import math

    from ._errors import BadValueError

    for name in ("radius", "intensity", "length", "height", "extent"):
        v = getattr(args, name)
        if v is not None and not math.isfinite(v):
            raise BadValueError(f"--{name} must be finite, got {v}")
    if not args.radius > 0:
        raise BadValueError(f"--radius must be > 0, got {args.radius}")
    if args.samples is not None and args.samples < 1:
        raise BadValueError(f"--samples must be >= 1, got {args.samples}")


def _configuration_dataset(args: argparse.Namespace, dtype: str):
    """The exact dataset (attenfit.irradiance) of the emitter and receivers the options describe."""
    from ._errors import BadValueError

    if dtype == "float64":
        import jax

        jax.config.update("jax_enable_x64", True)
    from ._dataset import facing_sweep, plane_receivers, random_receivers
    from .emitters import CapsuleEmitter, DiskEmitter, SphereEmitter

    r = args.radius
    if args.emitter == "sphere":
        emitter = SphereEmitter([0.0, 0.0, 0.0], r, args.intensity)
    elif args.emitter == "disk":
        emitter = DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], r, args.intensity, args.two_sided)
    else:
        half = (4 * r if args.length is None else args.length) / 2
        if half < 0:
            raise BadValueError(f"--length must be >= 0, got {args.length}")
        emitter = CapsuleEmitter([-half, 0.0, 0.0], [half, 0.0, 0.0], r, args.intensity)
    if args.range is None:
        lo, hi = (1e-3 * r if args.emitter == "disk" else 1.001 * r), 1000 * r
    else:
        lo, hi = _parse_range(args.range)
    if args.receivers == "facing":
        return facing_sweep(emitter, lo, hi, n=args.samples or 256, dtype=dtype)
    if args.receivers == "random":
        return random_receivers(emitter, args.samples or 256, lo, hi, seed=args.seed, dtype=dtype)
    height = r if args.height is None else args.height
    extent = 10 * r if args.extent is None else args.extent
    return plane_receivers(emitter, height, extent, n=args.samples or 64, dtype=dtype)


def _run_truth(args: argparse.Namespace) -> int:
    from ._atomic import check_output_path
    from ._errors import BadValueError

    if not args.out.endswith(".npz"):
        raise BadValueError(f"--out must name a .npz file, got {args.out!r}")
    _check_configuration(args)
    check_output_path(args.out, force=args.force)
    ds = _configuration_dataset(args, args.dtype)
    path = ds.save(args.out, force=args.force)
    print(
        f"wrote {path}: {len(ds)} {args.receivers} receivers, {args.emitter} r={args.radius:g}, "
        f"E in [{float(ds.E.min()):.6g}, {float(ds.E.max()):.6g}] W/m^2 ({ds.E.dtype})"
    )
    return EXIT_OK


def _add_gen(sub) -> None:
    p = sub.add_parser(
        "gen",
        help="render a ground-truth dataset independently with Mitsuba 3",
        description="Render irradiance with Mitsuba 3 (Monte Carlo, a standard error per "
        "receiver) at the receivers `attenfit truth` would use for the same options, and write "
        "it as an attenfit dataset (.npz).",
    )
    _add_configuration_args(p, height_help="plane: depth below the centre (default r)")
    p.add_argument("--spp", type=int, default=4096, help="Monte Carlo samples per receiver")
    p.add_argument("--seed", type=int, default=0, help="seed of the samples and random receivers")
    p.add_argument(
        "--variant",
        choices=["auto", "scalar_rgb", "llvm_ad_rgb"],
        default="auto",
        help="Mitsuba variant (auto: llvm_ad_rgb when a working libLLVM is found)",
    )
    p.add_argument("--out", required=True, help="output file, FILE.npz")
    p.add_argument("--force", action="store_true", help="overwrite an existing output")
    p.add_argument(
        "--chunk",
        type=int,
        default=None,
        metavar="N",
        help="batch mode: N receivers per chunk in FILE.npz.parts/; re-run to resume",
    )
    p.set_defaults(run=_run_gen)


def _gen_template(args: argparse.Namespace):
    """The exact dataset whose receivers `attenfit gen` renders: `attenfit truth`'s, float64."""
    _check_configuration(args)
    return _configuration_dataset(args, "float64")


def _gen_progress(label: str):
    """A progress callback for stderr: a live bar on a terminal (after the first second),
    otherwise a line every 10 s (and a last one) once a render has run for 10 s."""
    import time

    start = time.perf_counter()
    tty = sys.stderr.isatty()
    state = {"last": start, "shown": False}

    def progress(done: int, total: int) -> None:
        now = time.perf_counter()
        elapsed = now - start
        finished = done >= total
        wait = 0.2 if tty else 10.0
        if (elapsed < (1.0 if tty else 10.0) or now - state["last"] < wait) and not (
            finished and state["shown"]
        ):
            return
        frac = done / max(total, 1)
        left = f", {elapsed * (1 - frac) / frac:.0f} s left" if 0 < frac < 1 else ""
        bar = "#" * int(30 * frac) + "." * (30 - int(30 * frac))
        line = f"{label} [{bar}] {done}/{total}, {elapsed:.0f} s{left}"
        end = "\n" if (finished or not tty) else ""
        print(("\r" if tty else "") + line, end=end, file=sys.stderr, flush=True)
        state["last"], state["shown"] = now, True

    return progress


def _run_gen(args: argparse.Namespace) -> int:
    import time

    from ._atomic import check_output_path
    from ._errors import BadValueError

    try:  # the one place attenfit uses data_gen: imported only when this verb runs
        from data_gen import render_batch, render_dataset
        from data_gen.variants import require_mitsuba
    except ImportError as exc:
        raise AttenfitError(
            f"attenfit gen needs the data_gen package (from attenfit's source tree) and "
            f"Mitsuba 3 (pip install mitsuba): {exc}"
        ) from None
    if not args.out.endswith(".npz"):
        raise BadValueError(f"--out must name a .npz file, got {args.out!r}")
    require_mitsuba()
    check_output_path(args.out, force=args.force)
    if args.spp < 2:
        raise BadValueError(f"--spp must be at least 2, got {args.spp}")
    if args.chunk is not None and args.chunk < 1:
        raise BadValueError(f"--chunk must be a positive integer, got {args.chunk}")
    template = _gen_template(args)
    progress = _gen_progress(f"attenfit gen ({len(template)} receivers)")
    start = time.perf_counter()
    options = dict(spp=args.spp, seed=args.seed, variant=args.variant, progress=progress)
    if args.chunk is None:
        data = render_dataset(template, **options)
        data.save(args.out, force=args.force)
    else:
        try:
            data = render_batch(template, args.out, chunk=args.chunk, force=args.force, **options)
        except KeyboardInterrupt:
            from pathlib import Path

            kept = len(list(Path(f"{args.out}.parts").glob("chunk_*.npz")))
            if kept:
                print(
                    f"attenfit gen: {kept} finished chunks are kept in {args.out}.parts; "
                    "run the same command again to resume",
                    file=sys.stderr,
                )
            raise
    rel = data.stderr[data.E > 0] / data.E[data.E > 0]
    med = f"{float(sorted(rel)[len(rel) // 2]):.2g}" if len(rel) else "n/a"
    print(
        f"wrote {args.out}: {len(data)} receivers, {data.provenance['variant']}, "
        f"spp {args.spp}, median relative stderr {med}, {time.perf_counter() - start:.1f} s"
    )
    return EXIT_OK


def _add_fit(sub) -> None:
    p = sub.add_parser("fit", help="fit families to a dataset or a built-in configuration")
    p.add_argument(
        "--family", required=True, metavar="NAME[,NAME...]", help="families to fit (comma list)"
    )
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--data", metavar="FILE.npz", help="a dataset written by `attenfit truth/gen`")
    src.add_argument(
        "--emitter", choices=("sphere", "disk"), help="a built-in configuration: facing receivers"
    )
    p.add_argument("--radius", type=float, default=None, help="emitter radius (with --emitter)")
    p.add_argument(
        "--range",
        default=None,
        metavar="A:B",
        help="distances from the centre (default: 1.05R:20R for a sphere, 0.05R:20R for a disk)",
    )
    p.add_argument("--n", type=int, default=256, help="samples of a built-in configuration")
    p.add_argument("--loss", default="relative", help="relative (default), log or absolute")
    p.add_argument(
        "--solver",
        default="levenberg_marquardt",
        help="levenberg_marquardt (default), dogleg, gauss_newton, bfgs or optimistix_lm",
    )
    p.add_argument(
        "--free",
        default=None,
        metavar="P[,P...]",
        help="parameters to fit (default: each family's)",
    )
    p.add_argument(
        "--out", default=None, metavar="DIR", help="write fits.json and fits.txt into DIR"
    )
    p.add_argument("--force", action="store_true", help="replace an existing --out folder")
    p.add_argument("--json", action="store_true", help="print the results as JSON")
    p.set_defaults(run=_run_fit)


def _fit_configuration(args: argparse.Namespace):
    """(d, target, weights-or-None, description) of `--emitter`, or the dataset of `--data`."""
    import numpy as np

    from . import __dict__ as api
    from ._errors import BadValueError

    if args.data is not None:
        if "Dataset" not in api:
            raise BadValueError("--data needs attenfit.Dataset, which this version lacks")
        return api["Dataset"].load(args.data), f"dataset {args.data}"
    if args.radius is None or not (args.radius > 0) or not np.isfinite(args.radius):
        raise BadValueError(f"--emitter {args.emitter} needs --radius R > 0, got {args.radius}")
    r = args.radius
    lo, hi = (1.05 * r if args.emitter == "sphere" else 0.05 * r), 20 * r
    if args.range is not None:
        try:
            lo, hi = (float(x) for x in args.range.split(":"))
        except ValueError:
            raise BadValueError(
                f"--range must be A:B with numbers A < B, got {args.range!r}"
            ) from None
    if not (0 <= lo < hi) or not np.isfinite(hi) or (args.emitter == "sphere" and lo <= r):
        raise BadValueError(
            f"--range {lo:g}:{hi:g} must satisfy 0 <= A < B"
            + (f" and A > R = {r:g} (outside the sphere)" if args.emitter == "sphere" else "")
        )
    if args.n < 4:
        raise BadValueError(f"--n must be at least 4, got {args.n}")
    desc = f"{args.emitter} of radius {r:g}, facing receivers at d in [{lo:g}, {hi:g}] ({args.n} samples)"
    if "facing_sweep" in api:
        emitter = (
            api["SphereEmitter"]([0.0, 0.0, 0.0], r)
            if args.emitter == "sphere"
            else api["DiskEmitter"]([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], r)
        )
        return api["facing_sweep"](emitter, lo, hi, n=args.n), desc
    # Closed forms of the facing configurations (DESIGN.md section 1, unit intensity):
    # a sphere is exactly inverse-square outside itself; a facing disk gives 1/(d^2 + r^2).
    d = np.linspace(lo, hi, args.n)
    target = 1 / d**2 if args.emitter == "sphere" else 1 / (d * d + r * r)
    return (d, target), desc


def _run_fit(args: argparse.Namespace) -> int:
    from ._atomic import atomic_dir, check_output_path
    from ._compile_cache import enable_persistent_cache
    from ._family import get_family
    from ._fit import fit, fit_dataset

    names = [n.strip() for n in args.family.split(",") if n.strip()]
    classes = [get_family(n) for n in names]  # unknown names fail here, before any work
    if args.out is not None:
        check_output_path(args.out, force=args.force, folder=True)
    free = (
        None if args.free is None else tuple(p.strip() for p in args.free.split(",") if p.strip())
    )
    import jax

    jax.config.update("jax_enable_x64", True)  # reference fits run in float64
    source, desc = _fit_configuration(args)
    enable_persistent_cache()
    results = []
    for cls in classes:
        model = cls()
        fam_free = free
        if free is not None:
            fam_free = tuple(p for p in free if p in cls.param_names())
            for p in free:
                if not any(p in c.param_names() for c in classes):
                    cls.constraint(p)  # raises UnknownNameError naming it
            if not fam_free:
                fam_free = None
        options = dict(loss=args.loss, solver=args.solver, free=fam_free)
        if isinstance(source, tuple):
            res = fit(model, *source, **options)
        else:
            res = fit_dataset(model, source, **options)
        results.append(res)
    rows = [{"configuration": desc, **r.to_dict()} for r in results]
    text = f"# attenfit fit: {desc}\n\n" + "\n\n".join(str(r) for r in results) + "\n"
    if args.out is not None:
        with atomic_dir(args.out, force=args.force) as tmp:
            (tmp / "fits.json").write_text(json.dumps(rows, indent=2) + "\n", encoding="utf-8")
            (tmp / "fits.txt").write_text(text, encoding="utf-8")
    if args.json:
        print(json.dumps(rows, indent=2))
    else:
        print(text, end="")
    bad = [r for r, n in zip(results, names, strict=True) if not r.converged]
    if bad:
        print(f"attenfit fit: {len(bad)} of {len(results)} fits did not converge", file=sys.stderr)
        return EXIT_NOT_CONVERGED
    return EXIT_OK


def _add_report(sub) -> None:
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

    from ._atomic import check_output_path
    from .report import build_report

    check_output_path(args.out, force=args.force, folder=True)  # refuse before any work
    from ._compile_cache import enable_persistent_cache

    enable_persistent_cache()  # a second run loads the compiled solves instead of compiling
    datasets = {}
    if args.mitsuba:
        from ._dataset import Dataset

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


def _add_scene(sub) -> None:
    p = sub.add_parser(
        "scene",
        help="fit what a scene file needs and recommend the cheapest family",
        description="Generate ground truth only for the scene's lights and receivers, fit every "
        "family its constraints allow, and recommend the cheapest within its tolerance. "
        "Exit 0 even when no family meets the tolerance (the output says so); 2 for a bad "
        "scene file.",
    )
    p.add_argument("file", metavar="FILE", help="a TOML scene file (see README, Scene files)")
    p.add_argument(
        "--out",
        default=None,
        metavar="DIR",
        help="write recommendation.md/.json, the winner's shaders and errors.png into DIR",
    )
    p.add_argument("--force", action="store_true", help="replace an existing non-empty DIR")
    p.add_argument("--json", action="store_true", help="print the recommendation as JSON")
    p.add_argument(
        "--no-measure",
        action="store_true",
        help="rank by operation count and error only (skip timing the families)",
    )
    p.set_defaults(run=_run_scene)


def _run_scene(args: argparse.Namespace) -> int:
    from ._atomic import check_output_path
    from ._compile_cache import enable_persistent_cache
    from ._recommend import recommend
    from .scene import Scene

    scene = Scene.load(args.file)
    if args.out is not None:
        check_output_path(args.out, force=args.force, folder=True)
    import jax

    jax.config.update("jax_enable_x64", True)  # truth and fits in float64 (float32: a constraint)
    enable_persistent_cache()
    rec = recommend(scene, measure=not args.no_measure)
    if args.json:
        print(json.dumps(rec.to_dict(), indent=2))
    else:
        print(rec.to_markdown(), end="")
    if args.out is not None:
        rec.save(args.out, force=args.force)
        print(f"attenfit scene: wrote {args.out}", file=sys.stderr)
    return EXIT_OK


def _add_export(sub) -> None:
    p = sub.add_parser(
        "export",
        help="write a (fitted) family as a GLSL, HLSL, WGSL or C function",
        description="Print (or write with --out) a self-contained shader or C function of a "
        "family, generated from the expression the JAX code evaluates.",
    )
    p.add_argument(
        "source",
        metavar="FAMILY|FIT.json",
        help="a family name (see `attenfit families`) or a fit written by `attenfit fit --out`",
    )
    p.add_argument("--lang", default="glsl", help="glsl (default), hlsl, wgsl or c", metavar="LANG")
    p.add_argument(
        "--param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="set a parameter (repeatable); overrides a fit's value",
    )
    p.add_argument(
        "--family",
        default=None,
        metavar="NAME",
        help="the fit to export when FIT.json holds several families",
    )
    p.add_argument(
        "--uniforms",
        action="store_true",
        help="read parameters from uniforms (C: function arguments) instead of baking them in",
    )
    p.add_argument("--name", default=None, help="function name (default attenfit_<family>)")
    p.add_argument("--out", default=None, metavar="FILE", help="write to FILE instead of stdout")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.set_defaults(run=_run_export)


def _run_export(args: argparse.Namespace) -> int:
    from ._atomic import atomic_write, check_output_path
    from ._errors import BadValueError
    from .export import LANGUAGES, export

    if args.lang not in LANGUAGES:
        raise BadValueError(f"--lang must be one of {', '.join(LANGUAGES)}, got {args.lang!r}")
    params = {}
    for item in args.param:
        key, sep, value = item.partition("=")
        try:
            if not sep or not key.strip():
                raise ValueError
            params[key.strip()] = float(value)
        except ValueError:
            raise BadValueError(f"--param must be NAME=NUMBER, got {item!r}") from None
    if args.out is not None:
        check_output_path(args.out, force=args.force)
    text = export(
        args.source,
        args.lang,
        uniforms=args.uniforms,
        name=args.name,
        params=params or None,
        family=args.family,
    )
    if args.out is None:
        print(text, end="")
    else:
        atomic_write(args.out, text, force=args.force)
        print(f"attenfit export: wrote {args.out}", file=sys.stderr)
    return EXIT_OK


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


def _on_signal(signum, frame) -> None:
    """SIGINT and SIGTERM: note the signal (no output is committed after it) and unwind."""
    from ._atomic import PENDING, Interrupted

    PENDING.append(signum)
    raise Interrupted(signum)


def _quiet_interrupts(hook):
    """An unraisable-exception hook that drops interrupts raised inside callbacks.

    Python swallows (and prints) an exception raised in e.g. a garbage-collection callback;
    the interrupt is acted on at the next commit point instead (`attenfit._atomic.PENDING`).
    """

    def quiet(unraisable) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            hook(unraisable)

    return quiet


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with `argv` (default: `sys.argv[1:]`); return the exit code.

    SIGINT (Ctrl-C) and SIGTERM unwind through the verb's `finally` blocks, so temporary
    outputs are removed and previous outputs stay as they were; exit 130 and 143.
    """
    import signal
    import threading

    from . import _atomic

    saved = {}
    hook = sys.unraisablehook
    if threading.current_thread() is threading.main_thread():
        saved = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        sys.unraisablehook = _quiet_interrupts(hook)
    _atomic.PENDING.clear()
    try:
        return _main(argv)
    finally:
        for s, handler in saved.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        sys.unraisablehook = hook
        _atomic.PENDING.clear()


def _main(argv: Sequence[str] | None) -> int:
    parser = get_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "run", None):
            parser.print_help(sys.stderr)
            return EXIT_BAD_INPUT
        return int(args.run(args))
    except _UsageError as exc:
        print(str(exc).replace("\n", " "), file=sys.stderr)
        return EXIT_BAD_INPUT
    except AttenfitError as exc:
        print(f"attenfit: error: {exc}".replace("\n", " "), file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt as exc:
        import signal

        signum = getattr(exc, "signum", signal.SIGINT)
        what = "terminated" if signum == signal.SIGTERM else "interrupted"
        print(f"attenfit: {what}; any previous output is unchanged", file=sys.stderr)
        return 128 + int(signum)
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # a bug: say what, in one line, without a traceback
        print(f"attenfit: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
        return EXIT_ERROR


def run() -> None:
    """The console entry point: `main()`, then exit with its code.

    After Ctrl-C or SIGTERM the process leaves through `os._exit` once its output is
    flushed: an interrupt that lands while XLA is compiling can otherwise crash the
    interpreter's shutdown (a segfault instead of exit 130/143). Nothing is lost: every
    output was already committed or removed by the verb's own clean-up.
    """
    import os

    code = main()
    if code in (130, 143):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
