"""What exactness costs: exact irradiance throughput, and the reference quadrature's error vs nodes.

1. `attenfit.irradiance`, jitted, on 65,536 random receivers (random normals, so a mix of
   unclipped, horizon-clipped and fully-below receivers), float32 and float64, per emitter:
   evaluations per second (median over repeats). Peers measured in the same run: the
   point-light model `I max(0, n.l) / d^2` in JAX (the cheapest stand-in), and a numpy
   vectorised evaluation of the sphere's clipped closed form in its published acos form
   (Frostbite 2014 `illuminanceSphereOrDisk`), float64.
2. `attenfit.quadrature.irradiance` (surface Gauss-Legendre) against the closed forms: max
   error over 256 receivers, in units of the facing value 1/d^2, and time per receiver, per
   node count; and the capsule's own outer quadrature (`CAPSULE_NODES` per panel) against a
   160-node reference. The machine is shared: read the ratios more than the absolute rates.
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .timing import median_seconds

N = 65_536
N_CAPSULE = 4_096  # the capsule's quadrature costs ~300x the sphere's closed form
REPEATS = 5


def _receivers(em, n, seed, dmin=1.05, dmax=50.0):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    d = np.exp(rng.uniform(math.log(dmin), math.log(dmax), n))
    r = float(em.radius)
    p = np.asarray(em.reference_point()) + (d * r)[:, None] * v
    if em.kind == "capsule":
        p = p + 0.5 * (np.asarray(em.b) - np.asarray(em.a)) * rng.uniform(-1, 1, (n, 1))
        dist, _ = em.point_light(p, np.ones_like(p))
        p = p[np.asarray(dist) > 1.05 * r]
    normals = rng.normal(size=p.shape)
    return p, normals


def _numpy_sphere_frostbite(c, r, p, n):
    """Peer: the sphere's clipped closed form in Frostbite's acos form, numpy float64."""
    dv = c - p
    D = np.linalg.norm(dv, axis=1)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    cos_t = np.sum(n * dv, axis=1) / D
    sin2 = (r / D) ** 2
    sin_t = np.sqrt(np.maximum(1 - cos_t**2, 0))
    x = np.sqrt(1 / sin2 - 1)
    y = -x * cos_t / np.where(sin_t > 0, sin_t, 1)
    sy = np.sqrt(np.maximum(1 - y * y, 0))
    clipped = (cos_t * cos_t < sin2) & (sin_t > 0)
    with np.errstate(invalid="ignore"):
        K = np.where(
            clipped,
            (cos_t * np.arccos(np.clip(y, -1, 1)) - x * sin_t * sy) * sin2
            + np.arctan(sin_t * sy / x),
            np.pi * sin2 * np.maximum(cos_t, 0),
        )
    return K / (np.pi * r * r)


def main() -> None:
    import attenfit as af
    from attenfit._truth import _irradiance

    x64_before = jax.config.jax_enable_x64
    jax.config.update("jax_enable_x64", True)
    try:
        _run(af, _irradiance)
    finally:
        jax.config.update("jax_enable_x64", x64_before)


def _run(af, _irradiance) -> None:
    ems = [
        af.SphereEmitter([0.0, 0.0, 0.0], 1.0),
        af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 1.0),
        af.CapsuleEmitter([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 1.0),
    ]
    print(
        f"1. exact irradiance, jitted, {N} receivers per call ({N_CAPSULE} capsule), median of {REPEATS}"
    )
    print(f"   {'emitter':<9}{'dtype':<9}{'evals/s':>12}{'vs point light':>16}")
    point = jax.jit(lambda em, p, n: (lambda d, w: w / (d * d))(*em.point_light(p, n)))
    exact = jax.jit(af.irradiance)
    for em in ems:
        p64, n64 = _receivers(em, N_CAPSULE if em.kind == "capsule" else N, 0)
        for dt in (jnp.float32, jnp.float64):
            p, n = jnp.asarray(p64, dt), jnp.asarray(n64, dt)
            t = median_seconds(exact, em, p, n, repeats=REPEATS)
            tp = median_seconds(point, em, p, n, repeats=REPEATS)
            print(
                f"   {em.kind:<9}{jnp.dtype(dt).name:<9}{len(p) / t:>12.3g}{t / tp:>15.1f}x slower"
            )
    sphere = ems[0]
    p64, n64 = _receivers(sphere, N, 0)
    t_np = median_seconds(
        lambda: _numpy_sphere_frostbite(np.zeros(3), 1.0, p64, n64), repeats=REPEATS
    )
    t_ax = median_seconds(exact, sphere, jnp.asarray(p64), jnp.asarray(n64), repeats=REPEATS)
    ref = np.asarray(exact(sphere, jnp.asarray(p64), jnp.asarray(n64)))
    diff = np.max(
        np.abs(_numpy_sphere_frostbite(np.zeros(3), 1.0, p64, n64) - ref) * np.sum(p64**2, 1)
    )
    print(
        f"   peer: numpy sphere (Frostbite acos form, float64) {N / t_np:.3g} evals/s; "
        f"attenfit is {t_np / t_ax:.1f}x faster (max |diff| {diff:.1e} of 1/d^2)"
    )

    print(
        "\n2. reference quadrature (attenfit.quadrature) vs closed form (capsule: vs attenfit.irradiance)"
    )
    print(f"   {'emitter':<9}{'nodes':>6}{'max err (x 1/d^2)':>20}{'us/receiver':>14}")
    for em in ems:
        p, n = _receivers(em, 16 if em.kind == "capsule" else 256, 1)
        p, n = jnp.asarray(p), jnp.asarray(n)
        ref = np.asarray(af.irradiance(em, p, n))
        scale = np.asarray(em.point_light(p, n)[0]) ** 2
        for nodes in (8, 16, 32, 64):

            def q(p, n, nodes=nodes, em=em):
                return af.quadrature.irradiance(em, p, n, nodes=nodes)

            t = median_seconds(q, p, n, repeats=REPEATS)
            err = np.max(np.abs(np.asarray(q(p, n)) - ref) * scale)
            print(f"   {em.kind:<9}{nodes:>6}{err:>20.2e}{t / len(p) * 1e6:>14.1f}")

    print(
        "\n   capsule closed-form-inner quadrature (attenfit.irradiance), 5 panels x nodes, vs 160"
    )
    cap = ems[2]
    p, n = _receivers(cap, 256, 2)
    p, n = jnp.asarray(p), jnp.asarray(n)
    fn = eqx.filter_jit(_irradiance._evaluate)
    ref = np.asarray(fn(cap, p, n, 160))
    scale = np.asarray(cap.point_light(p, n)[0]) ** 2
    for nodes in (8, 16, 32, 64):
        t = median_seconds(fn, cap, p, n, nodes, repeats=REPEATS)
        err = np.max(np.abs(np.asarray(fn(cap, p, n, nodes)) - ref) * scale)
        mark = "  (default)" if nodes == _irradiance.CAPSULE_NODES else ""
        print(f"   {'capsule':<9}{nodes:>6}{err:>20.2e}{t / len(p) * 1e6:>14.1f}{mark}")


if __name__ == "__main__":
    main()
