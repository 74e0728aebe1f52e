"""What a command needs in memory against what attenfit announces (the memory budget).

    python -m benchmarks memory

Each workload runs in a fresh process that reports its own peak resident memory
(`ru_maxrss`); two sizes give the cost per unit of work (a receiver, a light-receiver pair,
a pixel) and the baseline. Beside them: attenfit's estimate for the same sizes (the
constants in `attenfit._truth._dataset`, `attenfit._scenes._scene`, `attenfit._report._build`),
which must not be below the measured peak: `ATTENFIT_MEMORY_BUDGET` (docs/errors.md) is
checked against the estimate before any work.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

_CHILD = r"""
import json, resource, sys, tempfile
kind, size = sys.argv[1], int(sys.argv[2])
import jax
jax.config.update("jax_enable_x64", True)
import attenfit as af
disk = af.DiskEmitter([0, 0, 0], [0, 0, -1], 0.5)
if kind == "builder":  # a small one first: the baseline with jax's runtime and programs loaded
    af.random_receivers(disk, 1000, 0.6, 5.0, seed=1)
try:  # resident now (a compile's peak before this point must not hide what follows)
    base = int(open("/proc/self/statm").read().split()[1]) * resource.getpagesize()
except OSError:
    base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
if kind == "builder":
    af.random_receivers(disk, size, 0.6, 5.0, seed=1)
elif kind == "scene":
    planes = "".join(
        f'[[receivers]]\nkind = "plane"\nextent = 3\ncenter = [0, 0, {-0.01 * i}]\nresolution = 256\n'
        for i in range(size)
    )
    text = 'tolerance = 0.05\n[[lights]]\nkind = "disk"\nradius = 0.1\nheight = 2\n' + planes
    path = tempfile.mktemp(suffix=".toml")
    open(path, "w").write(text)
    af.recommend(af.Scene.load(path))
elif kind == "report":
    af.build_report(plane_px=size, fitted=False, cost="counts")
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
print(json.dumps({"peak": peak, "base": base}))
"""


def measure(kind: str, size: int) -> dict[str, int]:
    """Peak resident bytes of one workload in a fresh process (`peak`), and before it (`base`:
    after the imports, and for a builder after a small warm-up call)."""
    with tempfile.TemporaryDirectory() as cache:
        env = {**os.environ, "PYTHONPATH": str(REPO), "ATTENFIT_CACHE_DIR": cache}
        out = subprocess.run(
            [sys.executable, "-c", _CHILD, kind, str(size)],
            capture_output=True,
            text=True,
            env=env,
            check=True,
        )
    return json.loads(out.stdout.strip().splitlines()[-1])


def estimate(kind: str, size: int) -> int:
    """attenfit's announced need for the same workload (what the budget is checked against)."""
    if kind == "builder":
        from attenfit._truth._dataset import BYTES_PER_RECEIVER

        return BYTES_PER_RECEIVER * size
    if kind == "scene":
        from attenfit._scenes._scene import BYTES_BASE, BYTES_PER_PAIR

        return BYTES_BASE + BYTES_PER_PAIR * size * 256**2
    from attenfit._report._build import BYTES_BASE, BYTES_PER_SAMPLE
    from attenfit._report._configs import SWEEP_N

    return BYTES_BASE + 2 * BYTES_PER_SAMPLE * (size**2 + SWEEP_N)


#: (workload, unit, two sizes, units of work per size step).
WORKLOADS = [
    ("builder", "receiver", (100_000, 1_000_000), 1),
    ("scene", "light-receiver pair", (1, 4), 256**2),
    ("report", "pixel of a plane (2 lights)", (96, 256), None),
]


def main() -> None:
    print(f"{'workload':9} {'size':>9} {'peak MB':>9} {'estimate MB':>12} {'est/peak':>9}")
    for kind, unit, sizes, _ in WORKLOADS:
        peaks = []
        for size in sizes:
            m, est = measure(kind, size), estimate(kind, size)
            # a builder's estimate is above the baseline; the others' include it
            peak = m["peak"] - m["base"] if kind == "builder" else m["peak"]
            peaks.append(peak)
            print(f"{kind:9} {size:>9,} {peak / 1e6:>9.0f} {est / 1e6:>12.0f} {est / peak:>9.2f}")
        a, b = sizes
        units = (
            (b - a) * 256**2 if kind == "scene" else (b * b - a * a if kind == "report" else b - a)
        )
        print(f"  {(peaks[1] - peaks[0]) / units:.0f} bytes per {unit} above the baseline")


if __name__ == "__main__":
    main()
