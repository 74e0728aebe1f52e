"""Batch fitting speed for every parameterised family, against scipy's loop (`bench_fit`).

Problems: 1,000 per family, half of each of two real lights that no family represents
exactly, their attenuation `E / weight` from attenfit's exact irradiance at 256 receivers
on a floor (z = 0, normals up), distances log-spaced up to `D_FAR` (5 m):

- "disk floor": a one-sided disk of radius r facing down at height H = r x (0.5..4,
  log-uniform) above the floor (a ceiling light); d from H to `D_FAR`;
- "sphere floor": a sphere of radius r sunk into the floor, its centre at h = r x (0.3..0.9)
  (the floor clips it: the attenuation tends to c / d^2 with c > 1); d from 1.01 r.

r is log-uniform in [0.02, 0.5] m. Each family fits its `default_free` parameters with the
relative loss; windowed families keep a fixed range (their default, 10 m) beyond every
sample. Starts are the family's defaults moved by a random factor in [1/2, 2] (a free range:
in [1, 2], so that every sample starts inside it; spline knot values, logs of f: f moved by
a factor in [1/2, 2]), the same on both sides.

scipy's peer is `scipy.optimize.least_squares(method="lm")` per problem, on the same
unconstrained coordinates as attenfit (`exp` for positive parameters, `|u|` for
nonnegative ones, a sigmoid for unit ones), the same tolerances (ftol = xtol = gtol =
rtol = atol = 1e-8), with the exact Jacobian of the family's own float64 program in numpy
(`benchmarks.dual`; checked against `jax.jacfwd` in tests/test_bench_dual.py). Both sides'
final losses are evaluated by that one numpy program; a fit *fails* when its final loss is
above the better side's by more than `MARGIN` (relative), or is not finite.
"""

from __future__ import annotations

import os
import statistics
import time
from collections.abc import Callable
from typing import Any

import numpy as np

import attenfit as af

from .dual import DualProgram

N = 256
BATCH = 1000
TOL = 1e-8
D_FAR = 5.0
RADII = (0.02, 0.5)
#: relative margin of the failure test: loss > (1 + MARGIN) x the better side's loss
MARGIN = 1e-6


# ----------------------------------------------------------------------------- the problems
def _floor_receivers(emitter, d: np.ndarray, height: float) -> np.ndarray:
    """The attenuation at floor receivers (z = 0, normal +z) at centre distances `d`."""
    x = np.sqrt(np.maximum(d * d - height * height, 0.0))
    points = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    normals = np.broadcast_to([0.0, 0.0, 1.0], points.shape)
    E = np.asarray(af.irradiance(emitter, points, normals))
    dist, weight = emitter.point_light(points, normals)
    return np.asarray(dist), E / np.asarray(weight)


def problems(batch: int = BATCH, seed: int = 0) -> dict[str, np.ndarray]:
    """Distances `d` (batch, N), targets `t` (batch, N), radii, and each problem's light."""
    rng = np.random.default_rng(seed)
    radii = np.exp(rng.uniform(*np.log(RADII), batch))
    d = np.empty((batch, N))
    t = np.empty((batch, N))
    kinds = np.empty(batch, dtype=object)
    for i, r in enumerate(radii):
        if i % 2 == 0:
            height = r * np.exp(rng.uniform(np.log(0.5), np.log(4.0)))
            light = af.DiskEmitter(center=[0, 0, height], normal=[0, 0, -1], radius=r)
            near, kinds[i] = height, "disk floor"
        else:
            height = r * rng.uniform(0.3, 0.9)
            light = af.SphereEmitter(center=[0, 0, height], radius=r)
            near, kinds[i] = 1.01 * r, "sphere floor"
        d[i], t[i] = _floor_receivers(light, np.geomspace(near, D_FAR, N), height)
    assert np.all(np.isfinite(t) & (t > 0))
    return {"d": d, "t": t, "radii": radii, "kinds": kinds}


def starts(cls: type, batch: int, seed: int = 1) -> dict[str, np.ndarray]:
    """The free parameters' starts: defaults moved by a random factor (module docstring)."""
    rng = np.random.default_rng(seed)
    out = {}
    for name in cls.default_free:
        value = np.asarray(cls.defaults()[name], float)
        lo = 1.0 if name == cls.range_param else 0.5
        log_factor = rng.uniform(np.log(lo), np.log(2.0), (batch, *value.shape))
        if cls.constraint(name) == "real":  # a log (spline knot values): its exp moves
            out[name] = value + log_factor
        else:
            out[name] = value * np.exp(log_factor)
    return out


# ----------------------------------------------------------------------------- scipy's side
_TO_PARAM = {
    "positive": np.exp,
    "nonnegative": np.abs,
    "unit": lambda u: 1 / (1 + np.exp(-u)),
    "real": lambda u: u,
}
_SLOPE = {
    "positive": np.exp,
    "nonnegative": lambda u: np.where(u >= 0, 1.0, -1.0),
    "unit": lambda u: np.exp(-u) / (1 + np.exp(-u)) ** 2,
    "real": np.ones_like,
}
_TO_INTERNAL = {
    "positive": np.log,
    "nonnegative": np.abs,
    "unit": lambda p: np.log(p) - np.log1p(-p),
    "real": lambda p: p,
}


class ScipySide:
    """scipy's least_squares(method="lm") loop over a batch, on attenfit's coordinates."""

    def __init__(self, cls: type, d: np.ndarray, t: np.ndarray, fixed: dict[str, Any]):
        family = cls()
        self.free = cls.default_free
        self.kinds = [cls.constraint(p) for p in self.free for _ in np.ravel(family.params()[p])]
        self.dual = DualProgram(family, self.free)
        self.bound = [self.dual.bind(d[i], fixed) for i in range(len(d))]
        self.t = t
        self.inv_t = 1 / t
        uniform = set(self.kinds)
        kind = self.kinds[0] if len(uniform) == 1 else None
        if kind is not None:
            self.to_param, self.slope = _TO_PARAM[kind], _SLOPE[kind]
        else:
            masks = {k: np.array([x == k for x in self.kinds]) for k in uniform}

            def to_param(u):
                return sum(np.where(m, _TO_PARAM[k](u), 0.0) for k, m in masks.items())

            def slope(u):
                return sum(np.where(m, _SLOPE[k](u), 0.0) for k, m in masks.items())

            self.to_param, self.slope = to_param, slope

    def to_internal(self, p: np.ndarray) -> np.ndarray:
        return np.array([_TO_INTERNAL[k](x) for k, x in zip(self.kinds, p, strict=True)])

    def fit(self, i: int, p0: np.ndarray):
        from scipy.optimize import least_squares

        bound, t, inv_t = self.bound[i], self.t[i], self.inv_t[i]
        to_param, slope = self.to_param, self.slope

        def res(u):
            return (bound.value(to_param(u)) - t) * inv_t

        def jac(u):
            _, jp = bound.value_and_jacobian(to_param(u))
            return (jp * (slope(u)[:, None] * inv_t[None, :])).T

        return least_squares(
            res, self.to_internal(p0), jac=jac, method="lm", ftol=TOL, xtol=TOL, gtol=TOL
        )

    def loop(self, p0: np.ndarray) -> list:
        with np.errstate(all="ignore"):
            return [self.fit(i, p0[i]) for i in range(len(p0))]

    def params(self, sols: list) -> np.ndarray:
        return np.array([self.to_param(s.x) for s in sols])

    def losses(self, p: np.ndarray) -> np.ndarray:
        """0.5 |r|^2 of each problem at parameters `p` (batch, k), by the numpy program."""
        out = np.empty(len(p))
        with np.errstate(all="ignore"):
            for i, (b, t, w) in enumerate(zip(self.bound, self.t, self.inv_t, strict=True)):
                r = (b.value(p[i]) - t) * w
                out[i] = 0.5 * float(r @ r)
        return np.where(np.isfinite(out), out, np.inf)


# ----------------------------------------------------------------------------- timing
def _in_turns(fns: list[Callable], rounds: int) -> tuple[list, list[float], list[float]]:
    """Each callable `rounds` times in turns; the last outputs, median wall and CPU seconds."""
    outs: list = [None] * len(fns)
    wall: list[list[float]] = [[] for _ in fns]
    cpu: list[list[float]] = [[] for _ in fns]
    for _ in range(rounds):
        for i, fn in enumerate(fns):
            t0, c0 = time.perf_counter(), time.process_time()
            outs[i] = fn()
            wall[i].append(time.perf_counter() - t0)
            cpu[i].append(time.process_time() - c0)
    return outs, [statistics.median(w) for w in wall], [statistics.median(c) for c in cpu]


#: Steps of the batch's first round (`attenfit._fit._compiled._FIRST_ROUND`): a fit capped
#: there is the first round alone, so the full fit's extra time is its straggler rounds.
FIRST_ROUND = 16


def bench_family(
    name: str, data: dict[str, np.ndarray], rounds: int = 3, split: bool = True
) -> dict[str, Any]:
    """One family's row: times, ratios, steps, failures and final losses of both sides.

    `split`: also time, in the same turns, what the batch's time is made of: the start
    scan (a one-step fit with the data-derived starts, less one without them: `guess`), the
    first round (a fit capped at `FIRST_ROUND` steps, less the scan) and the straggler
    rounds (the full fit less the capped one).
    """
    cls = af.get_family(name)
    d, t = data["d"], data["t"]
    batch = len(d)
    p0 = starts(cls, batch)
    fixed = {k: v for k, v in cls.defaults().items() if k not in cls.default_free}
    model = cls(**fixed, **p0)
    sp = ScipySide(cls, d, t, fixed)
    flat0 = np.concatenate([p0[p].reshape(batch, -1) for p in cls.default_free], axis=1)

    def run_af(max_steps=256, guess=True):
        return af.fit_many(model, d, t, rtol=TOL, atol=TOL, max_steps=max_steps, guess=guess)

    t0 = time.perf_counter()
    run_af()
    first = time.perf_counter() - t0
    fns = [run_af, lambda: sp.loop(flat0)]
    if split:
        fns += [
            lambda: run_af(1, True),
            lambda: run_af(1, False),
            lambda: run_af(FIRST_ROUND),
        ]
        for fn in fns[2:]:
            fn()  # compiled outside the timing
    load = os.getloadavg()[0]
    outs, wall, cpu = _in_turns(fns, rounds)
    res, sols = outs[0], outs[1]
    load = (load + os.getloadavg()[0]) / 2
    p_af = np.concatenate([res.params[p].reshape(batch, -1) for p in cls.default_free], axis=1)
    loss_af, loss_sp = sp.losses(p_af), sp.losses(sp.params(sols))
    best = np.minimum(loss_af, loss_sp)
    worse = (loss_af - loss_sp) / np.where(loss_sp > 0, loss_sp, 1)
    row = {
        "family": name,
        "k": flat0.shape[1],
        "af_ms": wall[0] * 1e3,
        "sp_ms": wall[1] * 1e3,
        "ratio": wall[1] / wall[0],
        "ratio_cpu": cpu[1] / cpu[0],
        "first_s": first,
        "load": load,
        "af_steps": (float(np.median(res.steps)), int(res.steps.max())),
        "stragglers": int(np.sum(res.steps > FIRST_ROUND)),
        "sp_nfev": (float(np.median([s.nfev for s in sols])), max(s.nfev for s in sols)),
        "af_fail": int(np.sum(~(loss_af <= best * (1 + MARGIN)))),
        "sp_fail": int(np.sum(~(loss_sp <= best * (1 + MARGIN)))),
        "af_converged": int(res.converged.sum()),
        "loss_rel": (float(np.median(worse)), float(np.max(worse)), float(np.min(worse))),
    }
    if split:
        scan = wall[2] - wall[3]
        row["split_ms"] = (scan * 1e3, (wall[4] - scan) * 1e3, (wall[0] - wall[4]) * 1e3)
    return row


def print_row(row: dict[str, Any]) -> None:
    lo, hi = row["loss_rel"][2], row["loss_rel"][1]
    print(
        f"  {row['family']:17s} {row['k']:2d} {row['af_ms']:8.1f} {row['sp_ms']:9.1f} "
        f"{row['ratio']:6.1f} {row['ratio_cpu']:6.1f}  "
        f"{row['af_steps'][0]:4.0f}/{row['af_steps'][1]:<4d} {row['sp_nfev'][0]:4.0f}/{row['sp_nfev'][1]:<4d} "
        f"{row['af_fail']:4d} {row['sp_fail']:4d}  {lo:+.1e}..{hi:+.1e}  {row['load']:4.1f}",
        flush=True,
    )


def print_split(row: dict[str, Any]) -> None:
    scan, solve, rest = row["split_ms"]
    print(
        f"  {row['family']:17s} {row['af_ms']:8.1f} {scan:8.1f} {solve:9.1f} {rest:9.1f} "
        f"{row['stragglers']:6d}  {row['sp_ms']:9.1f}",
        flush=True,
    )


def parse_options(options: list[str]) -> dict[str, Any]:
    """`--families a,b`, `--rounds N` and `--no-split` (see `main`)."""
    out: dict[str, Any] = {"families": None, "rounds": 3, "split": True}
    it = iter(options)
    for opt in it:
        if opt == "--families":
            out["families"] = [n for n in next(it, "").split(",") if n]
        elif opt == "--rounds":
            out["rounds"] = int(next(it, "3"))
        elif opt == "--no-split":
            out["split"] = False
        else:
            raise SystemExit(f"fit_families: unknown option {opt!r}")
    return out


def main(
    families: list[str] | None = None, rounds: int = 3, split: bool = True
) -> list[dict[str, Any]]:
    """Every parameterised family's row (or those of `families`), `rounds` rounds in turns;
    `split`: and where each batch's time goes (`bench_family`)."""
    data = problems()
    names = families or [n for n in af.list_families() if af.get_family(n).default_free]
    print(
        f"\n{BATCH} fits per family (half a disk over a floor, half a sphere sunk into it; "
        f"{N} samples, relative loss, tol {TOL:g}), one fit_many call against a scipy "
        f"least_squares(lm) loop, {rounds} rounds in turns (medians). Steps: attenfit's solver "
        f"steps, scipy's nfev (median/max). Failures: final loss > (1 + {MARGIN:g}) x the "
        "better side's. Final loss: (attenfit - scipy) / scipy, min..max. Load: the 1-minute "
        f"load average ({os.cpu_count()} cores)."
    )
    print(
        "  family             k   af ms  scipy ms  ratio    cpu  af steps  sp nfev  "
        "af-fail sp-fail  final loss          load"
    )
    rows = []
    for name in names:
        rows.append(bench_family(name, data, rounds, split))
        print_row(rows[-1])
    if split:
        print(
            f"\nwhere the batch's time goes (wall medians, ms): the start scan (guess on less "
            f"off, one step), the first round ({FIRST_ROUND} steps at most, less the scan) and the "
            f"straggler rounds (the rest), with the problems that took more than {FIRST_ROUND} "
            "steps"
        )
        print("  family              total     scan     solve  stragglers  (count)  scipy")
        for row in rows:
            print_split(row)
    return rows


if __name__ == "__main__":
    import sys

    import jax

    jax.config.update("jax_enable_x64", True)
    main(**parse_options(sys.argv[1:]))
