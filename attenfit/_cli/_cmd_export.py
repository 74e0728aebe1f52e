"""`attenfit export`: a (fitted) family, or an area model, as a GLSL, HLSL, WGSL, C or CUDA
function."""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import sys

from .. import _cache
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

    params = _params(args)
    key = _cache_key(args, params)
    cached = None if key is None else _cache.read("export", key)
    text = None if cached is None else json.loads(cached)["text"]
    if text is None:
        _check_choices(args)
    if args.out is not None:
        check_output(args.out, force=args.force, marks=OWN_MARKS["export"])
    if text is None:
        text = _export_text(args, params, key)
    if args.out is None:
        print(text, end="")
    else:
        atomic_write(args.out, text, force=args.force)
        print(f"attenfit export: wrote {args.out}", file=sys.stderr)
    return EXIT_OK


def _params(args: argparse.Namespace) -> dict[str, float]:
    """The `--param NAME=VALUE` pairs as numbers."""
    params = {}
    for item in args.param:
        key, sep, value = item.partition("=")
        try:
            if not sep or not key.strip():
                raise ValueError
            params[key.strip()] = float(value)
        except ValueError:
            raise BadValueError(f"--param must be NAME=NUMBER, got {item!r}") from None
    return params


def _check_choices(args: argparse.Namespace) -> None:
    from .._shaders import FORMS, LANGUAGES

    if args.lang not in LANGUAGES:
        raise BadValueError(f"--lang must be one of {', '.join(LANGUAGES)}, got {args.lang!r}")
    if args.form not in FORMS:
        raise BadValueError(f"--form must be one of {', '.join(FORMS)}, got {args.form!r}")


def _export_text(args: argparse.Namespace, params: dict[str, float], key: str | None) -> str:
    """The exported text, cached under `key` (`_cache_key`) when the export succeeds, so that
    a warm export of the same arguments imports no JAX; a bad argument is refused by the
    export each time, never cached."""
    from .._shaders import export

    text = export(
        args.source,
        args.lang,
        uniforms=args.uniforms,
        name=args.name,
        params=params or None,
        family=args.family,
        form=args.form,
    )
    if key is not None:
        _cache.write("export", key, json.dumps({"text": text}).encode())
    return text


def _cache_key(args: argparse.Namespace, params: dict[str, float]) -> str | None:
    """The export's cache key: its arguments and, for a fit file, a hash of its bytes (None:
    not cached, for a source that exists but is no regular file, or cannot be read)."""
    source = args.source
    if os.path.isfile(source):
        try:
            with open(source, "rb") as f:
                origin = "file " + hashlib.sha256(f.read()).hexdigest()
        except OSError:
            return None
    elif os.path.lexists(source):
        return None
    else:
        origin = "absent"  # a model's name (a missing path is refused, never cached)
    fields = (source, origin, args.lang, args.form, sorted(params.items()), args.family)
    return json.dumps([*fields, args.uniforms, args.name])
