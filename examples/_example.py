"""What every example script shares: its command line, its output folder, its figures.

Each script in `examples/` runs as `python examples/NAME.py [--out DIR] [--force]`, builds
its figures in a temporary folder and moves the folder into place only when everything
succeeded (`attenfit._atomic.atomic_dir`), so an interrupted run never leaves a half-written
output. Besides the PNGs it writes `numbers.json`: the values the script printed and checked,
which `tests/test_examples.py` asserts on. A script owns the folders it wrote (a marker file,
`OWNER`, names it) and replaces them when run again; any other non-empty folder is kept
unless `--force` is given.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import sys
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from attenfit import AttenfitError
from attenfit._atomic import atomic_dir, check_output_path
from attenfit._fit import enable_persistent_cache

EXAMPLES = Path(__file__).resolve().parent
#: The marker file naming the script that wrote an output folder.
OWNER = ".written-by"


def parser(name: str, description: str) -> argparse.ArgumentParser:
    """An argument parser with the options every example takes (`--out`, `--force`)."""
    p = argparse.ArgumentParser(prog=f"python examples/{name}.py", description=description)
    p.add_argument(
        "--out",
        type=Path,
        default=EXAMPLES / "out" / name,
        help=f"output folder (default: examples/out/{name})",
    )
    p.add_argument("--force", action="store_true", help="replace an existing output folder")
    return p


def parse_args(p: argparse.ArgumentParser, argv: Sequence[str] | None) -> argparse.Namespace:
    """Parse `argv` and refuse a taken output folder before any work starts.

    A folder this script wrote before (its `OWNER` marker names `p.prog`) is not taken: the
    script replaces it, as re-running it is meant to.
    """
    args = p.parse_args(argv)
    args.owner = p.prog
    marker = Path(args.out) / OWNER
    if marker.is_file() and marker.read_text(encoding="utf-8").strip() == args.owner:
        args.force = True
    check_output_path(args.out, force=args.force, folder=True)
    return args


@contextlib.contextmanager
def output_folder(args: argparse.Namespace) -> Iterator[Path]:
    """A temporary folder that becomes `args.out` when the block succeeds (atomic), marked as
    written by this script."""
    with atomic_dir(args.out, force=args.force) as tmp:
        (tmp / OWNER).write_text(args.owner + "\n", encoding="utf-8")
        yield tmp


def save_figure(fig, folder: Path, name: str) -> Path:
    """Write `fig` as `folder/name.png` (the folder is the temporary one, moved atomically)."""
    path = folder / f"{name}.png"
    fig.savefig(path, dpi=110, bbox_inches="tight")
    return path


def _jsonable(x: Any) -> Any:
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray) or hasattr(x, "__array__"):
        arr = np.asarray(x)
        return _jsonable(arr.tolist()) if arr.ndim else _jsonable(arr.item())
    if isinstance(x, float) and not np.isfinite(x):
        return str(x)  # "inf", "nan": JSON has no infinities
    return x


def write_numbers(folder: Path, numbers: dict[str, Any]) -> Path:
    """Write the checked values as `folder/numbers.json`."""
    path = folder / "numbers.json"
    path.write_text(json.dumps(_jsonable(numbers), indent=2) + "\n", encoding="utf-8")
    return path


def table(rows: Sequence[Sequence[Any]], header: Sequence[str]) -> str:
    """A plain-text table of numbers (6 significant digits) for the console."""

    def fmt(v: Any) -> str:
        if isinstance(v, float | np.floating):
            return f"{float(v):.6g}"
        return str(v)

    cells = [list(map(str, header))] + [[fmt(v) for v in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    lines = ["  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def run(main: Callable[[Sequence[str] | None], Any]) -> None:
    """Run an example's `main` as a script: a user error is one line on stderr, exit 2.

    Also turns on JAX's persistent compilation cache (as the CLI does), so that a second
    run loads the compiled programs instead of compiling them again.
    """
    enable_persistent_cache()
    try:
        main(None)
    except AttenfitError as exc:
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
