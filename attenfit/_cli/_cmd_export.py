"""`attenfit export`: a (fitted) family, or an area model, as a GLSL, HLSL, WGSL, C or CUDA
function."""

from __future__ import annotations

import argparse
import sys

from .._errors import BadValueError
from ._common import EXIT_OK, OWN_MARKS, check_output


def add_parser(sub, parents: list) -> None:
    p = sub.add_parser(
        "export",
        parents=parents,
        help="write a (fitted) family or an area model as a GLSL, HLSL, WGSL, C or CUDA function",
        description="Print (or write with --out) a self-contained shader, C or CUDA function of "
        "a family, f(d): its shader form (the engines' expression, the default) or its stable "
        "form (the guarded expression the JAX code evaluates); or of an area model, "
        "E/I(d, cos_r, cos_e, r, cos_n, g): its shader form.",
    )
    p.add_argument(
        "source",
        metavar="MODEL|FIT.json",
        help="a family or area model name (see `attenfit families`) or a fit written by "
        "`attenfit fit --out`",
    )
    p.add_argument(
        "--lang", default="glsl", help="glsl (default), hlsl, wgsl, c or cuda", metavar="LANG"
    )
    p.add_argument(
        "--form",
        default="shader",
        metavar="FORM",
        help="shader (default: the engines' expression, no guards) or stable (attenfit's "
        "guarded form; families only)",
    )
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
        help="the fit to export when FIT.json holds several families (not for an area model)",
    )
    p.add_argument(
        "--uniforms",
        action="store_true",
        help="read parameters from uniforms (C: function arguments) instead of baking them in",
    )
    p.add_argument(
        "--name", default=None, help="function name (default attenfit_<family or model>)"
    )
    p.add_argument("--out", default=None, metavar="FILE", help="write to FILE instead of stdout")
    p.add_argument("--force", action="store_true", help="overwrite an existing --out file")
    p.set_defaults(run=_run_export)


def _run_export(args: argparse.Namespace) -> int:
    from .._atomic import atomic_write
    from .._shaders import FORMS, LANGUAGES, export

    if args.lang not in LANGUAGES:
        raise BadValueError(f"--lang must be one of {', '.join(LANGUAGES)}, got {args.lang!r}")
    if args.form not in FORMS:
        raise BadValueError(f"--form must be one of {', '.join(FORMS)}, got {args.form!r}")
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
        check_output(args.out, force=args.force, marks=OWN_MARKS["export"])
    text = export(
        args.source,
        args.lang,
        uniforms=args.uniforms,
        name=args.name,
        params=params or None,
        family=args.family,
        form=args.form,
    )
    if args.out is None:
        print(text, end="")
    else:
        atomic_write(args.out, text, force=args.force)
        print(f"attenfit export: wrote {args.out}", file=sys.stderr)
    return EXIT_OK
