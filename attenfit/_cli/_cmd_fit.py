"""`attenfit fit`: families fitted to a dataset or a built-in configuration."""

from __future__ import annotations

import argparse
import json
import sys

from .. import _progress
from .._errors import BadValueError
from ._common import EXIT_NOT_CONVERGED, EXIT_OK, OWN_MARKS, check_output, configuration_emitter


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "fit", parents=parents, help="fit families to a dataset or a built-in configuration"
    )
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
    """The dataset of `--data`, or the facing sweep `--emitter` describes; and its description."""
    import numpy as np

    from .._input import text_name
    from .._truth import Dataset, facing_sweep

    if args.data is not None:  # the name goes into fits.json: as UTF-8 text whatever the locale
        return Dataset.load(args.data), f"dataset {text_name(args.data)}"
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
    emitter = configuration_emitter(args.emitter, r)
    return facing_sweep(emitter, lo, hi, n=args.n), desc


def _fit_one(cls, classes, free, source, args):
    """Fit family `cls` (of the command's `classes`) to `source`, freeing what `--free` names."""
    from .._fit import fit_dataset

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
    return fit_dataset(model, source, **options)


def _run_fit(args: argparse.Namespace) -> int:
    from .._atomic import atomic_dir
    from .._curves import get_family
    from .._fit import enable_persistent_cache

    names = [n.strip() for n in args.family.split(",") if n.strip()]
    classes = [get_family(n) for n in names]  # unknown names fail here, before any work
    if args.out is not None:
        check_output(args.out, force=args.force, marks=OWN_MARKS["fits"], folder=True)
    free = (
        None if args.free is None else tuple(p.strip() for p in args.free.split(",") if p.strip())
    )
    import jax

    jax.config.update("jax_enable_x64", True)  # reference fits run in float64
    _progress.stage("the data")
    source, desc = _fit_configuration(args)
    enable_persistent_cache()
    results = []
    with _progress.count(len(classes), f"fitting {len(classes)} families") as bar:
        for cls in classes:
            results.append(_fit_one(cls, classes, free, source, args))
            bar.update()
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
    _progress.done(f"{len(results)} fits converged" + (f"; wrote {args.out}" if args.out else ""))
    return EXIT_OK
