"""The comparison report's cost: every family fitted in one solve against one solve per family.

The default report fits 20 families on 2 configurations. `attenfit.fit_many` batches the
problems of one family, so the plain way compiles one Levenberg-Marquardt solve per family
(~3 s of CPU each on the reference machine); the report packs every (family, configuration)
problem into one `fit_many` call with a `lax.switch` over families
(`attenfit._report._fit_all.fit_all`), compiling once. This benchmark times both, in fresh
processes (so that no compilation is cached), on `FAMILIES` and the two default emitters,
and checks that they reach the same fitted parameters. It also times `build_report` on
those families stage by stage, and the figures.

Run: `python -m benchmarks report` (about a minute on 2 cores). Wall and CPU seconds; the
CPU time is what a quiet 2-core machine would take as wall time.
"""

from __future__ import annotations

import json
import subprocess
import sys
import tempfile
import time

FAMILIES = ["yuksel", "yuksel_adhoc", "unreal_window", "madams_tan", "polynomial", "threejs"]

_CHILD = r"""
import json, sys, time
import numpy as np
import jax
from attenfit import get_family, fit_many
from attenfit._report._configs import emitter_config as _emitter_config
from attenfit._report._published import range_of as _range_of
from attenfit.report import default_emitters, published_params
from attenfit._report._fit_all import fit_all

mode, names = sys.argv[1], sys.argv[2].split(",")
with jax.enable_x64(True):
    cfgs = [_emitter_config(n, e, 160, 8) for n, e in default_emitters().items()]
    probs = []
    for name in names:
        cls = get_family(name)
        for c in cfgs:
            at = lambda d, sw=c.sweep: float(np.exp(np.interp(np.log(d), np.log(sw.d), np.log(sw.truth))))
            p, _ = published_params(cls, c.radius, at)
            rg = _range_of(cls(**p))
            w = (c.sweep.d < rg).astype(float) if rg else np.ones_like(c.sweep.d)
            probs.append((cls, p, c.sweep.d, c.sweep.truth, w))
    t0, c0 = time.perf_counter(), time.process_time()
    out = {}
    if mode == "one":
        for (cls, p, *_), (fp, info) in zip(probs, fit_all(probs)):
            out.setdefault(cls.name, []).append(fp)
    else:
        for name in names:
            mine = [q for q in probs if q[0].name == name]
            cls = mine[0][0]
            start = cls(**{k: np.stack([np.asarray(q[1][k], float) for q in mine]) for k in mine[0][1]})
            res = fit_many(start, np.stack([q[2] for q in mine]), np.stack([q[3] for q in mine]),
                           weights=np.stack([q[4] for q in mine]), guess=False)
            out[name] = [res[i].params if res[i].converged else None for i in range(len(mine))]
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
def plain(p):
    return None if p is None else {k: np.asarray(v, float).tolist() for k, v in p.items()}
print(json.dumps({"wall": wall, "cpu": cpu, "params": {k: [plain(p) for p in v] for k, v in out.items()}}))
"""


def _child(mode: str) -> dict:
    proc = subprocess.run(
        [sys.executable, "-c", _CHILD, mode, ",".join(FAMILIES)],
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _max_rel_diff(a: dict, b: dict) -> float:
    import numpy as np

    worst = 0.0
    for fam in a:
        for pa, pb in zip(a[fam], b[fam], strict=True):
            if pa is None or pb is None:
                continue
            for k in pa:
                x, y = np.asarray(pa[k]), np.asarray(pb[k])
                # values below 1e-9 count as 0 (the per-family fit snaps a nonnegative
                # parameter to its bound 0; the one solve leaves it at ~1e-14)
                worst = max(worst, float(np.max(np.abs(x - y) / np.maximum(np.abs(y), 1e-9))))
    return worst


def main() -> None:
    import attenfit
    from attenfit.report import build_report

    print(f"{len(FAMILIES)} families x 2 emitters, 160 distances, fresh processes")
    one = _child("one")
    per = _child("per")
    print(f"{'fit':<36}{'wall s':>8}{'cpu s':>8}")
    print(f"{'one solve for all (report)':<36}{one['wall']:8.1f}{one['cpu']:8.1f}")
    print(f"{'one fit_many per family (peer)':<36}{per['wall']:8.1f}{per['cpu']:8.1f}")
    print(f"ratio peer / report (CPU): {per['cpu'] / one['cpu']:.2f}")
    print(
        f"largest relative difference of the fitted parameters: {_max_rel_diff(one['params'], per['params']):.1e}"
    )

    t0, c0 = time.perf_counter(), time.process_time()
    rep = build_report(families=FAMILIES)
    build_wall, build_cpu = time.perf_counter() - t0, time.process_time() - c0
    print(
        f"\nbuild_report({len(FAMILIES)} families): {build_wall:.1f} s wall, {build_cpu:.1f} s CPU"
    )
    for stage, seconds in rep.meta["timings"].items():
        print(f"  {stage:<10}{seconds:6.1f} s wall")
    with tempfile.TemporaryDirectory() as tmp:
        t0, c0 = time.perf_counter(), time.process_time()
        figs = rep.write_figures(tmp)
        print(
            f"  figures   {time.perf_counter() - t0:6.1f} s wall, {time.process_time() - c0:.1f} s CPU ({len(figs)} figures, PNG + SVG)"
        )
    del attenfit


if __name__ == "__main__":
    main()
