"""Evaluation speed of every family, and what the stable forms cost.

Each registered family (defaults) is jitted and evaluated on 1,000,000 float32 distances
(log-uniform in [1e-4, 1e2] m); the table gives the median time per call over repeats and
the ratio to `inverse_square` measured in the same run. Two peers isolate the price of
stability: Yuksel's eq. 7 in the naive form 2/r^2 (1 - d/sqrt(d^2 + r^2)) (which cancels: 5%
off at d = 1e3 r, 0 beyond 1e4 r in float32) against `yuksel`'s 2/(s (s + d)) with an
overflow-free hypot, and the plain (1 - (d/r_max)^4)+^2 window against `smooth_window`'s
factored form. Medians over repeats; the machine is shared, so read the ratios.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

import attenfit
from attenfit import parts

from .timing import median_seconds

N = 1_000_000
REPEATS = 15


def main() -> None:
    rng = np.random.default_rng(0)
    d = jnp.asarray(10.0 ** rng.uniform(-4, 2, N), dtype=jnp.float32)
    rows = []
    for name in attenfit.list_families():
        fam = attenfit.get_family(name)()
        rows.append((name, median_seconds(jax.jit(lambda x, fam=fam: fam(x)), d, repeats=REPEATS)))

    def naive_yuksel(x, r=0.1):
        return 2 / r**2 * (1 - x / jnp.sqrt(x * x + r * r))

    def naive_window(x, r_max=10.0):
        return jnp.maximum(1 - (x / r_max) ** 4, 0) ** 2

    def stable_window(x):
        return parts.smooth_window(x, jnp.float32(10.0))

    peers = [
        ("yuksel eq. 7, naive form", median_seconds(jax.jit(naive_yuksel), d, repeats=REPEATS)),
        ("window, naive (1-x^4)+^2", median_seconds(jax.jit(naive_window), d, repeats=REPEATS)),
        ("window, parts.smooth_window", median_seconds(jax.jit(stable_window), d, repeats=REPEATS)),
    ]
    base = dict(rows)["inverse_square"]
    print(f"{N:,} float32 distances, median of {REPEATS} jitted calls")
    print(f"{'family':32s} {'ms/call':>9s} {'ns/eval':>8s} {'x inverse_square':>17s}")
    for name, t in rows + peers:
        print(f"{name:32s} {t * 1e3:9.3f} {t / N * 1e9:8.2f} {t / base:17.2f}")
    t_stable = dict(rows)["yuksel"]
    print(f"\nstable yuksel / naive eq. 7: {t_stable / peers[0][1]:.2f}x")
    print(f"factored window / naive window: {peers[2][1] / peers[1][1]:.2f}x")


if __name__ == "__main__":
    main()
