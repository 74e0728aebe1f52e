"""`attenfit truth` and `attenfit gen`: a dataset of one emitter's irradiance, exact or
rendered by Mitsuba 3 (`data_gen`)."""

from __future__ import annotations

import argparse
import contextlib
import sys

from .. import _progress
from .._errors import AttenfitError, BadValueError
from ._common import EXIT_OK, OWN_MARKS, check_output, configuration_emitter


def add_parser(sub, parents: list) -> None:
    """The `truth` and `gen` verbs."""
    _add_truth(sub, parents)
    _add_gen(sub, parents)


def _add_truth(sub, parents: list) -> None:
    p = sub.add_parser(
        "truth",
        parents=parents,
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

    for name in ("radius", "intensity", "length", "height", "extent"):
        v = getattr(args, name)
        if v is not None and not math.isfinite(v):
            raise BadValueError(f"--{name} must be finite, got {v}")
    if not args.radius > 0:
        raise BadValueError(f"--radius must be > 0, got {args.radius}")
    if args.samples is not None and args.samples < 1:
        raise BadValueError(f"--samples must be >= 1, got {args.samples}")
    if args.seed < 0:
        raise BadValueError(f"--seed must be a non-negative integer, got {args.seed}")


def _configuration_dataset(args: argparse.Namespace, dtype: str):
    """The exact dataset (attenfit.irradiance) of the emitter and receivers the options describe."""

    if dtype == "float64":
        import jax

        jax.config.update("jax_enable_x64", True)
    from .._truth import facing_sweep, plane_receivers, random_receivers

    r = args.radius
    half = (4 * r if args.length is None else args.length) / 2
    if args.emitter == "capsule" and half < 0:
        raise BadValueError(f"--length must be >= 0, got {args.length}")
    emitter = configuration_emitter(
        args.emitter, r, args.intensity, two_sided=args.two_sided, half_length=half
    )
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
    if not args.out.endswith(".npz"):
        raise BadValueError(f"--out must name a .npz file, got {args.out!r}")
    _check_configuration(args)
    check_output(args.out, force=args.force, marks=OWN_MARKS["dataset"])
    ds = _configuration_dataset(args, args.dtype)
    path = ds.save(args.out, force=args.force)
    print(
        f"wrote {path}: {len(ds)} {args.receivers} receivers, {args.emitter} r={args.radius:g}, "
        f"E in [{float(ds.E.min()):.6g}, {float(ds.E.max()):.6g}] W/m^2 ({ds.E.dtype})"
    )
    return EXIT_OK


def _add_gen(sub, parents: list) -> None:
    p = sub.add_parser(
        "gen",
        parents=parents,
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


class _RenderBar:
    """data_gen's `progress(done, total)` as a bar on the command's progress (a terminal)."""

    def __init__(self, text: str):
        self.text, self.done, self.bar, self.stack = text, 0, None, contextlib.ExitStack()

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = self.stack.enter_context(_progress.count(total, self.text))
        self.bar.update(done - self.done)
        self.done = done


def _run_gen(args: argparse.Namespace) -> int:
    import time

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
    check_output(args.out, force=args.force, marks=OWN_MARKS["dataset"])
    if args.spp < 2:
        raise BadValueError(f"--spp must be at least 2, got {args.spp}")
    if args.chunk is not None and args.chunk < 1:
        raise BadValueError(f"--chunk must be a positive integer, got {args.chunk}")
    _progress.stage("receivers and their exact irradiance")
    template = _gen_template(args)
    start = time.perf_counter()
    bar = _RenderBar(f"rendering {len(template)} receivers with Mitsuba")
    options = dict(spp=args.spp, seed=args.seed, variant=args.variant, progress=bar)
    if args.chunk is None:
        with bar.stack:
            data = render_dataset(template, **options)
        data.save(args.out, force=args.force)
    else:
        try:
            with bar.stack:
                data = render_batch(
                    template, args.out, chunk=args.chunk, force=args.force, **options
                )
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
