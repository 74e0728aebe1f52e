"""Reference irradiance by numerical integration over the emitter's surface (checks the closed forms).

`irradiance(emitter, points, normals, nodes=64)` evaluates

    E(p, n) = L * integral over the visible emitter surface of
              max(0, cos theta_r) max(0, cos theta_e) / |x - p|^2 dA(x)

(the radiometric definition; Lambertian emitter of uniform radiance `L = I / (pi r^2)`) by
tensor-product Gauss-Legendre rules, with horizon clipping made explicit: the integration
domain is cut to the part above the receiver's tangent plane wherever that cut is a simple
curve, so the integrand is smooth and the rule converges fast. `nodes` (per dimension, per
panel) is the accuracy knob; the benchmark prints the error against `nodes` and time.

* Disk: the visible circular segment `xi >= xi0` (xi along the in-plane projection of `n`),
  parametrised as `xi = r cos t`, `zeta = s r sin t`, `t in [0, acos(xi0 / r)]`,
  `s in [-1, 1]`, `dA = r^2 sin^2 t dt ds`. Spectral convergence away from the rim.
* Sphere: a sphere seen from `p` is a uniform-radiance cone; so is the disk spanned by its
  silhouette circle (centre at `(D^2 - r^2)/D` from `p`, radius `r cos(alpha)`, facing `p`),
  which is integrated as above (the emitter's visible surface, projected).
* Capsule: the cylinder's front-facing strip (the `phi`-range where `cos theta_e > 0` is
  exact) with the horizon cut done per `phi` in closed form (the cut is linear in the axial
  coordinate), plus the two hemispherical ends integrated with the `max(0, .)` factors in
  the integrand (kinks, so algebraic convergence: use more nodes).

These are independent of `attenfit.irradiance`'s closed forms (no formula is shared) and
slower; they are for checking, not for datasets.

Notes: the integrand has a near-singularity `1/|x - p|^4` when the receiver is close to the
emitter's surface, so convergence slows there: at 96 nodes a receiver 0.01 r above a disk
can be off by tens of percent, while receivers beyond ~r/2 from the surface converge to
~1e-15 by 64 nodes (see `benchmarks/bench_irradiance.py`). The capsule's ends keep kinks in
the integrand and converge algebraically (~1e-6 of 1/d^2 at 64 nodes).
"""

from __future__ import annotations

import math

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._errors import BadTypeError, BadValueError
from ._emitter_checks import _receivers
from ._emitters import AbstractEmitter, CapsuleEmitter, DiskEmitter, SphereEmitter

_PI = math.pi


def _gl(n: int, lo, hi, dtype):
    x, w = np.polynomial.legendre.leggauss(n)
    x = jnp.asarray(x, dtype)
    w = jnp.asarray(w, dtype)
    return (lo + hi) / 2 + (hi - lo) / 2 * x, (hi - lo) / 2 * w


def _dot(a, b):
    return jnp.sum(a * b, axis=-1)


def _perp(v: Array) -> Array:
    helper = jnp.where(
        jnp.abs(v[0]) < 0.9,
        jnp.asarray([1.0, 0.0, 0.0], v.dtype),
        jnp.asarray([0.0, 1.0, 0.0], v.dtype),
    )
    w = jnp.cross(v, helper)
    return w / jnp.linalg.norm(w)


def _disk_segment(c, m, r, L, p, n, nodes):
    """L * integral over the part of the one-sided disk (c, m, r) above p's horizon."""
    dt = p.dtype
    z = _dot(p - c, m)
    n_in = n - _dot(n, m) * m
    w = jnp.linalg.norm(n_in)
    has_w = w > 1e-300
    wdir = jnp.where(has_w, n_in / jnp.where(has_w, w, 1.0), _perp(m))
    wperp = jnp.cross(m, wdir)
    nd = _dot(n, c - p)
    # visible iff nd + xi * w >= 0
    xi0 = jnp.where(has_w, -nd / jnp.where(has_w, w, 1.0), jnp.where(nd > 0, -jnp.inf, jnp.inf))
    cos_tmax = jnp.clip(xi0 / r, -1.0, 1.0)
    tmax = jnp.arccos(cos_tmax)
    t, wt = _gl(nodes, jnp.zeros((), dt), tmax, dt)
    s, ws = _gl(nodes, jnp.asarray(-1.0, dt), jnp.asarray(1.0, dt), dt)
    T, S = t[:, None], s[None, :]
    xi = r * jnp.cos(T)
    zeta = S * r * jnp.sin(T)
    v = (
        (c - p)[None, None, :]
        + xi[..., None] * wdir[None, None, :]
        + zeta[..., None] * wperp[None, None, :]
    )  # x - p
    v2 = _dot(v, v)
    integrand = jnp.maximum(_dot(v, n[None, None, :]), 0) * z / (v2 * v2) * (r * jnp.sin(T)) ** 2
    E = L * jnp.sum(wt[:, None] * ws[None, :] * integrand)
    return jnp.where(z > 0, E, 0.0)


def _sphere(c, r, L, p, n, nodes):
    dv = c - p
    D = jnp.linalg.norm(dv)
    u = dv / D
    sin_a = r / D
    cos_a = jnp.sqrt((1 - sin_a) * (1 + sin_a))
    cc = p + u * (D * cos_a * cos_a)
    E = _disk_segment(cc, -u, r * cos_a, L, p, n, nodes)
    return jnp.where(D > r, E, jnp.nan)


def _capsule(a, b, r, L, p, n, nodes):
    dt = p.dtype
    ab = b - a
    ell = jnp.linalg.norm(ab)
    e = jnp.where(ell > 0, ab / jnp.where(ell > 0, ell, 1.0), jnp.asarray([0.0, 0.0, 1.0], dt))
    # --- cylinder side: x = a + t e + r (cos phi f1 + sin phi f2)
    ap = p - a
    qv = ap - _dot(ap, e) * e  # from the axis to p
    rho = jnp.linalg.norm(qv)
    f1 = jnp.where(rho > 0, qv / jnp.where(rho > 0, rho, 1.0), _perp(e))
    f2 = jnp.cross(e, f1)
    front = rho > r
    gamma = jnp.arccos(jnp.clip(r / jnp.where(front, rho, 2 * r), -1.0, 1.0))
    phi, wphi = _gl(nodes, -gamma, gamma, dt)
    radial = jnp.cos(phi)[:, None] * f1[None, :] + jnp.sin(phi)[:, None] * f2[None, :]  # (nodes, 3)
    # horizon per phi: n.(x - p) = c0 + t ne >= 0, c0 = n.(a + r radial - p)
    c0 = _dot(n, a - p) + r * _dot(radial, n[None, :])
    ne = _dot(n, e)
    tz = -c0 / jnp.where(ne == 0, 1.0, ne)
    lo = jnp.where(ne > 0, jnp.clip(tz, 0.0, ell), 0.0)
    hi = jnp.where(ne < 0, jnp.clip(tz, 0.0, ell), ell)
    hi = jnp.where((ne == 0) & (c0 <= 0), 0.0, hi)
    hi = jnp.maximum(hi, lo)
    xg, wg = np.polynomial.legendre.leggauss(nodes)
    xg, wg = jnp.asarray(xg, dt), jnp.asarray(wg, dt)
    t = (lo + hi)[:, None] / 2 + (hi - lo)[:, None] / 2 * xg[None, :]
    wt = (hi - lo)[:, None] / 2 * wg[None, :]
    v = (a - p)[None, None, :] + t[..., None] * e[None, None, :] + r * radial[:, None, :]  # x - p
    v2 = _dot(v, v)
    cos_e_num = -_dot(v, radial[:, None, :])  # radial . (p - x)
    integrand = jnp.maximum(_dot(v, n[None, None, :]), 0) * jnp.maximum(cos_e_num, 0) / (v2 * v2)
    E_cyl = jnp.where(front, jnp.sum(wphi[:, None] * wt * integrand) * r, 0.0)

    # --- hemispherical ends: x = cen + r omega, omega.axis >= 0 (kinks left in the integrand)
    def cap(cen, axis):
        g1 = _perp(axis)
        g2 = jnp.cross(axis, g1)
        th, wth = _gl(2 * nodes, jnp.zeros((), dt), jnp.asarray(_PI / 2, dt), dt)
        ph = (jnp.arange(4 * nodes, dtype=dt) + 0.5) * (2 * _PI / (4 * nodes))
        Th, Ph = th[:, None], ph[None, :]
        om = (
            jnp.cos(Th)[..., None] * axis[None, None, :]
            + (jnp.sin(Th) * jnp.cos(Ph))[..., None] * g1[None, None, :]
            + (jnp.sin(Th) * jnp.sin(Ph))[..., None] * g2[None, None, :]
        )
        v = (cen - p)[None, None, :] + r * om
        v2 = _dot(v, v)
        integ = jnp.maximum(_dot(v, n[None, None, :]), 0) * jnp.maximum(-_dot(v, om), 0) / (v2 * v2)
        return jnp.sum(wth[:, None] * integ * jnp.sin(Th)) * (2 * _PI / (4 * nodes)) * r * r

    E = L * (E_cyl + cap(a, -e) + cap(b, e))
    tcl = jnp.clip(_dot(ap, e), 0.0, ell)
    inside = jnp.linalg.norm(ap - tcl * e) <= r
    return jnp.where(inside, jnp.nan, E)


def irradiance(
    emitter: AbstractEmitter,
    points: Float[ArrayLike, "*b 3"],
    normals: Float[ArrayLike, "*b 3"],
    *,
    nodes: int = 64,
) -> Float[Array, "*b"]:
    """Irradiance by Gauss-Legendre quadrature over the emitter's visible surface (see the module).

    `nodes` Gauss-Legendre nodes per dimension (the capsule's ends use 2 `nodes` x 4 `nodes`).
    Same conventions as `attenfit.irradiance`: normals are normalised, NaN inside a sphere or
    capsule, the dtype of `points`. Cost grows as `nodes^2` per receiver.
    """
    if isinstance(nodes, bool) or not isinstance(nodes, int | np.integer) or nodes < 1:
        raise BadValueError(f"nodes must be a positive integer, got {nodes!r}")
    if not isinstance(emitter, AbstractEmitter):
        raise BadTypeError(
            f"emitter must be a SphereEmitter, DiskEmitter or CapsuleEmitter, got {type(emitter).__name__}"
        )
    p, n = _receivers(points, normals)
    return _quadrature_jit(emitter, p, n, int(nodes))


@eqx.filter_jit
def _quadrature_jit(emitter: AbstractEmitter, p: Array, n: Array, nodes: int) -> Array:
    dt = p.dtype

    def cast(x):
        return jnp.asarray(x).astype(dt)

    if isinstance(emitter, SphereEmitter):
        c, r = cast(emitter.center), cast(emitter.radius)
        L = cast(emitter.radiance)

        def kern(pp, nn):
            return _sphere(c, r, L, pp, nn, nodes)
    elif isinstance(emitter, DiskEmitter):
        c, m, r = cast(emitter.center), cast(emitter.normal), cast(emitter.radius)
        m = m / jnp.linalg.norm(m)
        L = cast(emitter.radiance)
        two = emitter.two_sided

        def kern(pp, nn):
            E = _disk_segment(c, m, r, L, pp, nn, nodes)
            return E + _disk_segment(c, -m, r, L, pp, nn, nodes) if two else E
    elif isinstance(emitter, CapsuleEmitter):
        a, b, r = cast(emitter.a), cast(emitter.b), cast(emitter.radius)
        L = cast(emitter.radiance)

        def kern(pp, nn):
            return _capsule(a, b, r, L, pp, nn, nodes)
    else:
        raise BadTypeError(
            f"emitter must be a SphereEmitter, DiskEmitter or CapsuleEmitter, got {type(emitter).__name__}"
        )
    shape = p.shape[:-1]
    E = jax.vmap(kern)(p.reshape(-1, 3), n.reshape(-1, 3))
    return E.reshape(shape)
