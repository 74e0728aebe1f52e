"""`fit_many` throughput on the device JAX runs on (a GPU where one is lent; the CPU here).

The problems are `fit_families.problems` (half a disk over a floor, half a sphere sunk into
it; 256 samples, no family exact), 1,000 of them tiled to larger batches, with the starts of
`fit_families.starts`. Each batch is solved once to compile, then timed over `ROUNDS`
repeats (median wall seconds; results come back to the host); the table gives fits per second and the
ratio against the 1,000-problem batch on the same device, in the same run.
"""

from __future__ import annotations

import statistics
import sys
import time

import jax
import numpy as np

import attenfit as af

from .fit_families import TOL, problems, starts

FAMILIES = ("yuksel", "unreal_window", "frostbite_window", "madams_tan", "spline")
ROUNDS = 3


def _sizes() -> tuple[int, ...]:
    on_gpu = jax.devices()[0].platform == "gpu"
    return (1_000, 10_000, 100_000) if on_gpu else (1_000, 4_000)


def bench(name: str, base: dict[str, np.ndarray], size: int) -> tuple[float, int]:
    """Median wall seconds of one `fit_many` over `size` problems, and the failures."""
    cls = af.get_family(name)
    reps = size // len(base["d"])
    d, t = np.tile(base["d"], (reps, 1)), np.tile(base["t"], (reps, 1))
    fixed = {k: v for k, v in cls.defaults().items() if k not in cls.default_free}
    model = cls(**fixed, **starts(cls, size))

    def run():
        return af.fit_many(model, d, t, rtol=TOL, atol=TOL)  # results come back to the host

    res = run()  # compile
    walls = []
    for _ in range(ROUNDS):
        t0 = time.perf_counter()
        res = run()
        walls.append(time.perf_counter() - t0)
    failed = int(np.sum(~np.asarray(res.converged)))
    return statistics.median(walls), failed


def main() -> None:
    jax.config.update("jax_enable_x64", True)
    device = jax.devices()[0]
    print(f"device: {device.platform} {device.device_kind}; jax {jax.__version__}; float64")
    base = problems(1_000)
    print("  family              batch   wall s    fits/s  x batch 1000  not conv.")
    for name in FAMILIES:
        first = None
        for size in _sizes():
            wall, failed = bench(name, base, size)
            rate = size / wall
            first = first or rate
            print(
                f"  {name:18s} {size:7d} {wall:8.3f} {rate:9.0f} {rate / first:12.1f}x {failed:10d}",
                flush=True,
            )


if __name__ == "__main__":
    main()
    sys.exit(0)
