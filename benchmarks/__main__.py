"""Run the benchmarks: `python -m benchmarks` (all) or `python -m benchmarks fit cost` (some).

Each `benchmarks/bench_<name>.py` has a `main()` that prints its own table: medians over
repeats, and ratios against the peer measured in the same run. Options after the names
(`--name value`) go to the mains that take them, `main(options)`: e.g. `python -m
benchmarks fit --families frostbite_window,spline --rounds 5`.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import sys
import time
from pathlib import Path


def main(argv: list[str]) -> int:
    here = Path(__file__).parent
    names = sorted(
        m.name[len("bench_") :]
        for m in pkgutil.iter_modules([str(here)])
        if m.name.startswith("bench_")
    )
    first_option = next((i for i, a in enumerate(argv) if a.startswith("--")), len(argv))
    argv, options = argv[:first_option], argv[first_option:]
    chosen = argv or names
    unknown = [n for n in chosen if n not in names]
    if unknown:
        print(f"benchmarks: unknown {unknown}; available: {names}", file=sys.stderr)
        return 2
    for name in chosen:
        print(f"\n=== bench_{name} ===", flush=True)
        start = time.perf_counter()
        bench_main = importlib.import_module(f"benchmarks.bench_{name}").main
        if inspect.signature(bench_main).parameters:
            bench_main(options)
        elif options:
            print(f"benchmarks: bench_{name} takes no options {options}", file=sys.stderr)
            return 2
        else:
            bench_main()
        print(f"(bench_{name}: {time.perf_counter() - start:.1f} s)", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
