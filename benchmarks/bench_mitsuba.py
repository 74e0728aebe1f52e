"""Mitsuba ground truth: standard error and wall time against samples per receiver, per variant.

For a sphere and a disk light (16 random receivers each: unclipped, horizon-clipped and
below-the-horizon normals, distances 1.05 r..20 r and 0.05 r..20 r), renders with
`data_gen.render_dataset` at increasing spp with `scalar_rgb` and, when a working libLLVM is
found, `llvm_ad_rgb`; prints the median relative standard error over receivers with E > 0,
the wall and CPU time per receiver (median of repeats, after a warm-up that compiles the
LLVM kernels; CPU time counts every thread, so it is the fairer figure on a busy machine),
and the wall-time ratio to the peer measured in the same run: `attenfit.irradiance`, the
closed form, on the same receivers (jitted, median of 50 calls).

Relative error scales as 1/sqrt(spp); read the spp for a target accuracy off the table.
`python -m benchmarks mitsuba`; about a minute.
"""

from __future__ import annotations

import sys

import numpy as np

from .timing import median_seconds, median_wall_and_cpu


def main() -> None:
    from data_gen.variants import select_variant  # before anything imports Dr.Jit

    llvm = select_variant("auto")
    import jax

    jax.config.update("jax_enable_x64", True)
    from attenfit import DiskEmitter, SphereEmitter, irradiance, random_receivers
    from data_gen.render import render_dataset

    n = 16
    cases = {
        "sphere": random_receivers(SphereEmitter([0.0, 0.0, 0.0], 0.5), n, 0.525, 10.0, seed=1),
        "disk": random_receivers(
            DiskEmitter([0.0, 0.0, 0.0], [0, 0, -1.0], 0.5), n, 0.025, 10.0, seed=2
        ),
    }
    peers = {}
    for name, ds in cases.items():
        p, nn = jax.numpy.asarray(ds.points), jax.numpy.asarray(ds.normals)
        peers[name] = (
            median_seconds(lambda ds=ds, p=p, nn=nn: irradiance(ds.emitter, p, nn), repeats=50) / n
        )
        print(f"closed form ({name}): {peers[name] * 1e6:.2f} us per receiver", flush=True)
    variants = ["scalar_rgb"] + (["llvm_ad_rgb"] if llvm.name == "llvm_ad_rgb" else [])
    if len(variants) == 1:
        print(f"llvm_ad_rgb not available here ({llvm.reason}); scalar only", flush=True)
    plans = {"scalar_rgb": [256, 1024, 4096, 16384], "llvm_ad_rgb": [1024, 16384, 262144, 1 << 20]}
    print(
        f"\n{'variant':<12} {'light':<7} {'spp':>8} {'median rel. stderr':>19} "
        f"{'ms / receiver':>14} {'CPU ms / rec.':>14} {'x closed form':>14}"
    )
    for variant in variants:
        for name, ds in cases.items():
            render_dataset(ds, spp=64, seed=0, variant=variant)  # warm-up (LLVM compiles here)
            for spp in plans[variant]:
                out = {}

                def run(ds=ds, spp=spp, out=out, variant=variant):
                    out["d"] = render_dataset(ds, spp=spp, seed=1, variant=variant)

                dt, cpu = median_wall_and_cpu(run, 3 if spp <= 4096 else 1)
                dt, cpu = dt / n, cpu / n
                d = out["d"]
                rel = float(np.median(d.stderr[d.E > 0] / d.E[d.E > 0]))
                print(
                    f"{variant:<12} {name:<7} {spp:>8} {rel:>19.2e} {dt * 1e3:>14.3f} "
                    f"{cpu * 1e3:>14.3f} "
                    f"{dt / peers[name]:>14.0f}",
                    flush=True,
                )


if __name__ == "__main__":
    main()
    sys.exit(0)
