"""What exactness costs: exact irradiance throughput, and the reference quadrature's error vs nodes.

1. `attenfit.irradiance`, jitted, on 65,536 random receivers (random normals, so a mix of
   unclipped, horizon-clipped and fully-below receivers), float32 and float64, per emitter:
   evaluations per second (median over repeats). Peers measured in the same run: the
   point-light model `I max(0, n.l) / d^2` in JAX (the cheapest stand-in), and numpy float64
   ports: the sphere's clipped closed form in its published acos form (Frostbite 2014
   `illuminanceSphereOrDisk`), and the disk's closed forms as attenfit writes them (the same
   arc quadrature where the arc's closed form cancels), each branch evaluated only on the
   receivers that take it, and the rectangle's Lambert polygon formula after clipping to the
   receiver's hemisphere. The capsule and the tube (quadratures) have no numpy peer.
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
N_CAPSULE = 4_096  # the capsule's and the tube's quadratures cost ~300x the sphere's closed form
REPEATS = 5


def _receivers(em, n, seed, dmin=1.05, dmax=50.0):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v /= np.linalg.norm(v, axis=1, keepdims=True)
    d = np.exp(rng.uniform(math.log(dmin), math.log(dmax), n))
    r = float(em.radius)
    p = np.asarray(em.reference_point()) + (d * r)[:, None] * v
    if em.kind in ("capsule", "tube"):
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


def _numpy_disk(c, m, r, p, n, I=1.0):
    """Peer: the disk's closed forms (unclipped vector irradiance; clipped, the arc + chord
    contour with the same Gauss-Legendre fallback for small rho) ported to numpy float64,
    each branch evaluated only on the receivers that take it (boolean masks)."""
    m = m / np.linalg.norm(m)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    dv = c - p
    z = -dv @ m
    nm, nd = n @ m, np.sum(n * dv, axis=1)
    dperp = dv + z[:, None] * m
    s2 = np.sum(dperp * dperp, axis=1)
    w = np.sqrt(np.maximum(1 - nm * nm, 0.0))
    behind = z <= 0
    unclipped = ~behind & (nd >= r * w)
    clipped = ~behind & ~(nd <= -r * w) & ~(nd >= r * w)
    E = np.zeros(len(p))

    def scaled(k):
        lam = np.sqrt(z[k] ** 2 + s2[k] + r * r)
        zt, rt, st2 = z[k] / lam, r / lam, s2[k] / lam**2
        return lam, zt, rt, st2, np.sqrt(st2)

    k = unclipped
    lam, zt, rt, st2, st = scaled(k)
    A1, A2 = zt * zt + (st - rt) ** 2, zt * zt + (st + rt) ** 2
    S = np.sqrt(A1) * np.sqrt(A2)
    q0 = zt * zt + rt * rt - st2
    with np.errstate(divide="ignore", invalid="ignore"):
        Q = np.where(q0 < 0, 4 * st2 * zt * zt / (S - q0), S + q0)
    ndp = np.sum(n[k] * dperp[k], axis=1) / lam
    E[k] = np.maximum((I / lam) / lam * (Q * (-nm[k]) + 2 * zt * ndp) / (S * (S + 1)), 0.0)

    k = clipped
    lam, zt, rt, st2, st = scaled(k)
    sign = 1.0 if m[2] >= 0 else -1.0  # Duff et al.'s frame, as attenfit's
    a = -1 / (sign + m[2])
    b = m[0] * m[1] * a
    u = np.array([1 + sign * m[0] * m[0] * a, sign * b, -sign * m[0]])
    v = np.array([b, sign + m[1] * m[1] * a, -m[1]])
    nk, dtl = n[k], dv[k] / lam[:, None]
    beta = np.arccos(-nd[k] / (r * w[k]))
    phin = np.arctan2(nk @ v, nk @ u)
    A0 = rt * rt * nm[k]
    Ac = rt * np.sum(nk * np.cross(dtl, v), axis=1)
    As = -rt * np.sum(nk * np.cross(dtl, u), axis=1)
    b1, b2 = 2 * rt * (dtl @ u), 2 * rt * (dtl @ v)
    rho = 2 * rt * st
    am = zt * zt + (st - rt) ** 2
    J = np.zeros(len(rt))
    an = rho >= 0.1  # attenfit's _ARC_RHO_MIN
    rh, amn, bet = rho[an], am[an], beta[an]
    Sarc, kk = np.sqrt(amn * (1 + rh)), np.sqrt(amn / (1 + rh))
    cphi0, sphi0 = b1[an] / rh, b2[an] / rh
    P = Ac[an] * cphi0 + As[an] * sphi0
    Qs = As[an] * cphi0 - Ac[an] * sphi0
    psim = np.mod(phin[an] - np.arctan2(b2[an], b1[an]) + np.pi, 2 * np.pi) - np.pi
    psi1, psi2 = psim - bet, psim + bet
    dI0 = (2 / Sarc) * (
        np.arctan2(kk * np.sin(psi2 / 2), np.cos(psi2 / 2))
        - np.arctan2(kk * np.sin(psi1 / 2), np.cos(psi1 / 2))
    )
    dIc = (2 * bet - dI0) / rh
    d1 = amn + 2 * rh * np.cos(psi1 / 2) ** 2
    d2 = amn + 2 * rh * np.cos(psi2 / 2) ** 2
    with np.errstate(divide="ignore", invalid="ignore"):
        lr = np.where(
            d2 < 0.5 * d1, np.log(d2 / d1), np.log1p(rh * (-2 * np.sin(psim) * np.sin(bet)) / d1)
        )
    J[an] = A0[an] * dI0 + P * dIc + Qs * (-lr / rh)
    gl = ~an
    xg, wg = np.polynomial.legendre.leggauss(32)  # attenfit's _ARC_NODES
    phis = phin[gl, None] + beta[gl, None] * xg
    cp, sp = np.cos(phis), np.sin(phis)
    num = A0[gl, None] + Ac[gl, None] * cp + As[gl, None] * sp
    J[gl] = beta[gl] * np.sum(wg * num / (1 + b1[gl, None] * cp + b2[gl, None] * sp), axis=1)
    ca, sa = np.cos(phin + beta), np.sin(phin + beta)
    cb, sb = np.cos(phin - beta), np.sin(phin - beta)
    xA = dtl + rt[:, None] * (ca[:, None] * u + sa[:, None] * v)
    xB = dtl + rt[:, None] * (cb[:, None] * u + sb[:, None] * v)
    chord = np.arctan2(np.sum(nk * np.cross(xA, xB), axis=1), np.sum(xA * xB, axis=1))
    E[k] = np.maximum(-(I / (np.pi * r * r)) / 2 * (J + chord), 0.0)
    return E


def _edge_term(a, b, n):
    """Lambert's term of the edge a -> b (rows of vectors from the receiver): its angle times
    n . unit(a x b), 0 where the edge has no length."""
    cr = np.cross(a, b)
    sn = np.linalg.norm(cr, axis=1)
    theta = np.arctan2(sn, np.sum(a * b, axis=1))
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(sn > 0, theta * np.sum(n * cr, axis=1) / sn, 0.0)


def _numpy_rect(c, m, t, w, h, p, n, I=1.0):
    """Peer: the one-sided rectangle's irradiance by Lambert's polygon formula (Arvo 1994,
    eq. 2) after clipping the rectangle to the receiver's upper hemisphere, written here in
    numpy float64: each edge cut where it crosses the horizon, and the horizon's own edge from
    where the contour leaves the hemisphere to where it comes back (a convex polygon crosses a
    plane at most twice)."""
    m, t = m / np.linalg.norm(m), t / np.linalg.norm(t)
    s = np.cross(m, t)
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    corners = [c + 0.5 * (i * w * t + j * h * s) for i, j in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
    V = np.stack([q - p for q in corners], axis=1)  # (receivers, 4, 3)
    up = np.einsum("rkj,rj->rk", V, n)
    total = np.zeros(len(p))
    leave, enter = np.zeros_like(p), np.zeros_like(p)
    crosses = np.zeros(len(p), bool)
    for k in range(4):
        a, b, ha, hb = V[:, k], V[:, (k + 1) % 4], up[:, k], up[:, (k + 1) % 4]
        above_a, above_b = ha > 0, hb > 0
        with np.errstate(divide="ignore", invalid="ignore"):
            x = a + (ha / (ha - hb))[:, None] * (b - a)  # where the edge meets the horizon
        s0 = np.where(above_a[:, None], a, x)
        s1 = np.where(above_b[:, None], b, x)
        total += np.where(above_a | above_b, _edge_term(s0, s1, n), 0.0)
        out, back = above_a & ~above_b, ~above_a & above_b
        leave = np.where(out[:, None], x, leave)
        enter = np.where(back[:, None], x, enter)
        crosses |= out
    total += np.where(crosses, _edge_term(leave, enter, n), 0.0)
    front = (p - c) @ m > 0
    return np.where(front, I / (w * h) * 0.5 * np.abs(total), 0.0)


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
        af.RectEmitter([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], [1.0, 0.0, 0.0], 2.0, 1.0),
        af.TubeEmitter([-1.0, 0.0, 0.0], [1.0, 0.0, 0.0], 0.1),
    ]
    print(
        f"1. exact irradiance, jitted, {N} receivers per call ({N_CAPSULE} capsule), median of {REPEATS}"
    )
    print(f"   {'emitter':<9}{'dtype':<9}{'evals/s':>12}{'vs point light':>16}")
    point = jax.jit(lambda em, p, n: (lambda d, w: w / (d * d))(*em.point_light(p, n)))
    exact = jax.jit(af.irradiance)
    for em in ems:
        p64, n64 = _receivers(em, N_CAPSULE if em.kind in ("capsule", "tube") else N, 0)
        for dt in (jnp.float32, jnp.float64):
            p, n = jnp.asarray(p64, dt), jnp.asarray(n64, dt)
            t = median_seconds(exact, em, p, n, repeats=REPEATS)
            tp = median_seconds(point, em, p, n, repeats=REPEATS)
            print(
                f"   {em.kind:<9}{jnp.dtype(dt).name:<9}{len(p) / t:>12.3g}{t / tp:>15.1f}x slower"
            )
    peers = {
        "sphere": ("Frostbite acos form", _numpy_sphere_frostbite),
        "disk": ("the same closed forms, branches by masks", _numpy_disk),
        "rect": ("Lambert's polygon formula after clipping", _numpy_rect),
    }
    print(f"\n   peers: numpy float64 on the same {N} receivers, median of {REPEATS}, same run")
    print(f"   {'emitter':<9}{'numpy evals/s':>15}{'attenfit evals/s':>18}{'attenfit/numpy':>16}"
          f"{'max |diff| x d^2':>18}")  # fmt: skip
    for em in ems:
        if em.kind not in peers:
            continue
        kind, (form, port) = em.kind, peers[em.kind]
        p64, n64 = _receivers(em, N, 0)
        c, r = np.asarray(em.reference_point(), np.float64), float(em.radius)
        if kind == "disk":
            args = (c, np.asarray(em.normal, np.float64), r)
        elif kind == "rect":
            args = (c, *(np.asarray(v, np.float64) for v in (em.normal, em.tangent)),
                    float(em.width), float(em.height))  # fmt: skip
        else:
            args = (c, r)
        t_np = median_seconds(port, *args, p64, n64, repeats=REPEATS)
        t_ax = median_seconds(exact, em, jnp.asarray(p64), jnp.asarray(n64), repeats=REPEATS)
        ref = np.asarray(exact(em, jnp.asarray(p64), jnp.asarray(n64)))
        d2 = np.sum((p64 - c) ** 2, axis=1)
        diff = np.max(np.abs(port(*args, p64, n64) - ref) * d2)
        print(
            f"   {kind:<9}{N / t_np:>15.3g}{N / t_ax:>18.3g}{t_np / t_ax:>15.2f}x{diff:>18.1e}"
            f"   ({form})"
        )
    print(
        "   capsule, tube: no numpy port (their outer integrals are quadratures: docs/ground-truth.md)"
    )

    print(
        "\n2. reference quadrature (attenfit.quadrature) vs closed form (capsule: vs attenfit.irradiance)"
    )
    print(f"   {'emitter':<9}{'nodes':>6}{'max err (x 1/d^2)':>20}{'us/receiver':>14}")
    for em in ems[:3]:
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
