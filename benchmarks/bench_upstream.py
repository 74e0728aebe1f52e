"""The costs upstream of a fit: ground truth (error against time) and the fit itself.

1. Ground truth for a one-sided disk light (radius 0.1 m, unit intensity) at 64 receivers
   between 0.005 m and 2 m, with normals tilted by up to 80 degrees so that horizon
   clipping matters: the exact closed form (`attenfit.irradiance`, float64 and float32,
   jitted), the reference quadrature (`attenfit.quadrature`, if this version has it) at
   several node counts, and Mitsuba 3 Monte Carlo (`data_gen.estimate_irradiance`, MIS) at
   several sample counts (the second call of each size, after Mitsuba's kernel compilation). Error: max relative error against the float64 closed form (which
   the test suite checks against quadrature and Mitsuba); time: median wall time per call
   for all 64 receivers (after compilation for JAX).
2. Fitting: the `polynomial` family (3 parameters) fitted with the relative loss to
   Yuksel's sphere curve (256 distances, r = 1), with each solver in float64 and float32
   (float32 with JAX's x64 mode off, as users run it): steps, median time per fit after
   compilation, final loss, converged.

Run: `python -m benchmarks upstream` (about a minute; Mitsuba dominates).
"""

from __future__ import annotations

import sys
import time

import jax
import numpy as np

from .timing import median_seconds

jax.config.update("jax_enable_x64", True)

import attenfit as af  # noqa: E402

R = 0.1
N_RECEIVERS = 64


def _receivers() -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(7)
    dist = np.geomspace(0.005, 2.0, N_RECEIVERS)
    # receivers below the disk (which faces -z), normals tilted from +z by up to 80 degrees
    off = rng.uniform(-1, 1, (N_RECEIVERS, 2)) * dist[:, None] * 0.5
    points = np.stack([off[:, 0], off[:, 1], -dist], axis=1)
    tilt = np.radians(rng.uniform(0, 80, N_RECEIVERS))
    az = rng.uniform(0, 2 * np.pi, N_RECEIVERS)
    normals = np.stack([np.sin(tilt) * np.cos(az), np.sin(tilt) * np.sin(az), np.cos(tilt)], 1)
    return points, normals


def ground_truth() -> None:
    emitter = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], R)
    points, normals = _receivers()
    exact64 = jax.jit(lambda p, n: af.irradiance(emitter, p, n))
    ref = np.asarray(exact64(points, normals))
    ok = ref > 0
    rows = []

    def add(method: str, values, seconds: float) -> None:
        v = np.asarray(values, np.float64)
        err = np.max(np.abs(v[ok] - ref[ok]) / ref[ok])
        rows.append((method, seconds * 1e3, err))

    t = median_seconds(lambda: exact64(points, normals), repeats=7)
    add("closed form, float64", ref, t)
    p32, n32 = points.astype(np.float32), normals.astype(np.float32)
    out32 = exact64(p32, n32)
    t = median_seconds(lambda: exact64(p32, n32), repeats=7)
    add("closed form, float32", out32, t)

    quad = getattr(af.quadrature, "irradiance", None)
    if quad is not None:
        for nodes in (8, 32, 128):
            try:
                fn = jax.jit(lambda p, n, nodes=nodes: quad(emitter, p, n, nodes=nodes))
                vals = fn(points, normals)
                t = median_seconds(lambda fn=fn: fn(points, normals), repeats=3)
                add(f"quadrature, {nodes} nodes", vals, t)
            except TypeError as exc:  # a different signature in this version
                print(f"(quadrature skipped: {exc})")
                break
    else:
        print("(attenfit.quadrature.irradiance is not in this version: quadrature rows left out)")

    try:
        from data_gen.estimate import estimate_irradiance
        from data_gen.scenes import DiskLight
    except ImportError as exc:  # pragma: no cover - data_gen ships with attenfit
        print(f"(Mitsuba rows left out: {exc})")
    else:
        light = DiskLight(
            center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, -1.0), radius=R, radiance=1 / (np.pi * R * R)
        )
        for spp in (64, 1024, 8192):
            # the first call of a size loads Mitsuba and compiles its kernels: time the second
            estimate_irradiance([light], points, normals, spp=spp, seed=0)
            start = time.perf_counter()
            E, _ = estimate_irradiance([light], points, normals, spp=spp, seed=1)
            add(f"Mitsuba MIS, {spp} spp", E, time.perf_counter() - start)

    print(
        f"Ground truth: disk r = {R} m, {N_RECEIVERS} receivers (0.005-2 m, normals tilted <= 80 deg)"
    )
    print(
        f"{'method':28s} {'ms / 64 receivers':>18s} {'x closed form':>14s} {'max rel. error':>15s}"
    )
    base = rows[0][1]
    for method, ms, err in rows:
        print(f"{method:28s} {ms:18.3f} {ms / base:14.1f} {err:15.2e}")
    print("(Mitsuba has a fixed cost of about 0.1 s per call at small sample counts)")


def fitting() -> None:
    n = 256
    r = 1.0
    x = np.linspace(0.0, 1.0, n)
    d = r * (0.05 + 20 * x)
    s = np.sqrt(d * d + r * r)
    target = 2 / (s * (s + d))
    model = af.get_family("polynomial")(kc=r * r / 2, kl=0.1 * r, kq=1.0)
    print(f"\nFitting: polynomial (kc, kl, kq) to Yuksel's sphere curve, r = {r}, {n} samples")
    print(
        f"{'solver':20s} {'dtype':8s} {'steps':>6s} {'ms / fit':>9s} {'final loss':>11s}  converged"
    )
    for solver in ("levenberg_marquardt", "dogleg", "gauss_newton", "bfgs"):
        for dtype in (np.float64, np.float32):
            dd, tt = d.astype(dtype), target.astype(dtype)
            m = jax.tree.map(lambda v, dtype=dtype: np.asarray(v, dtype), model)

            def run(dd=dd, tt=tt, m=m, solver=solver, x64=dtype == np.float64):
                # float32 as users run it: default JAX (x64 off); `fit` runs a float32
                # solve with x64 off in either mode.
                with jax.enable_x64(x64):
                    return af.fit(m, dd, tt, solver=solver, free=("kc", "kl", "kq"))

            try:
                res = run()
                t = median_seconds(run, repeats=3)
            except Exception as exc:  # report, do not stop the table
                print(f"{solver:20s} {np.dtype(dtype).name:8s} failed: {type(exc).__name__}: {exc}")
                continue
            print(
                f"{solver:20s} {np.dtype(dtype).name:8s} {res.steps:6d} {t * 1e3:9.2f} "
                f"{float(res.loss):11.3e}  {res.converged}"
            )


def main() -> None:
    ground_truth()
    fitting()
    sys.stdout.flush()


if __name__ == "__main__":
    main()
