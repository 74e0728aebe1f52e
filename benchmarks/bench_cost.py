"""What each attenuation curve costs: throughput, operation counts, shader cost; numpy as the peer.

For every registered family: nanoseconds per evaluation (jitted JAX, float32, parameters
baked in, 2^18 log-spaced distances; median of interleaved repeats, each the fastest of a
few calls), its ratio to `inverse_square` measured in the same run, the operation counts
and weighted shader cost of `attenfit.cost`, and the same family evaluated with numpy
float32 ufuncs (the traced program run operation by operation: what a plain numpy
implementation of the same stable form does), with the JAX/numpy speed ratio.

Run: `python -m benchmarks cost` (about half a minute on 2 cores).
"""

from __future__ import annotations

import time

import numpy as np

import attenfit
from attenfit import cost
from attenfit._shaders import trace

from .timing import median_seconds

N = 1 << 18
REPEATS = 11
NUMPY_REPEATS = 5


def _numpy_ns(program, d: np.ndarray) -> float:
    return median_seconds(program.evaluate_numpy, d, repeats=NUMPY_REPEATS) / d.size * 1e9


def main() -> None:
    import jax

    names = attenfit.list_families()
    print(f"JAX {jax.__version__} on {jax.default_backend()}, float32, n = {N}, {REPEATS} repeats")
    start = time.perf_counter()
    table = cost.cost_table(names, n=N, repeats=REPEATS)
    print(f"(JAX timing and counting: {time.perf_counter() - start:.1f} s)")
    d = np.geomspace(1e-3, 1e3, N).astype(np.float32)
    numpy_ns = {name: _numpy_ns(trace(attenfit.get_family(name)()), d) for name in names}
    ref = numpy_ns["inverse_square"]

    head = (
        f"{'family':17s} {'ns/eval':>8s} {'IQR':>6s} {'x inv-sq':>8s} {'numpy ns':>9s} "
        f"{'np x inv-sq':>11s} {'jax/np':>7s} {'shader':>6s}  "
        "add mul fma div sqrt trans sel cmp cvt unif"
    )
    print(head)
    print("-" * len(head))
    for name, c in table.items():
        o = c.ops
        print(
            f"{name:17s} {c.ns_per_eval:8.3f} {c.ns_iqr:6.3f} {c.ratio_to_inverse_square:8.2f} "
            f"{numpy_ns[name]:9.2f} {numpy_ns[name] / ref:11.2f} "
            f"{c.ns_per_eval / numpy_ns[name]:7.3f} {c.shader_cost:6g}  "
            f"{o['add']:3d} {o['mul']:3d} {o['fma']:3d} {o['div']:3d} {o['sqrt']:4d} "
            f"{o['transcendental']:5d} {o['select']:3d} {o['compare']:3d} {o['convert']:3d} "
            f"{o['uniform']:4d}"
        )
    by_shader = sorted(table.values(), key=lambda c: c.shader_cost)
    by_time = sorted(table.values(), key=lambda c: c.ns_per_eval)
    print("cheapest by shader cost:", ", ".join(c.family for c in by_shader[:5]))
    print("cheapest by measured time:", ", ".join(c.family for c in by_time[:5]))
    rho = _spearman(
        [c.shader_cost for c in table.values()], [c.ns_per_eval for c in table.values()]
    )
    print(f"Spearman rank correlation, shader cost vs measured JAX time: {rho:.2f}")


def _spearman(a, b) -> float:
    ra = np.argsort(np.argsort(a))
    rb = np.argsort(np.argsort(b))
    return float(np.corrcoef(ra, rb)[0, 1])


if __name__ == "__main__":
    main()
