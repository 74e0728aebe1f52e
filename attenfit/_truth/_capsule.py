"""The capsule seen from a receiver, for its exact irradiance (`_irradiance._capsule_one`):
the pencil of planes through the receiver parallel to the axis, where the horizon crosses
the end spheres' silhouettes, and the interval of directions under which each plane sees
the capsule's stadium (docs/ground-truth.md, the capsule)."""

from __future__ import annotations

import math
from typing import NamedTuple

import jax.numpy as jnp
from jaxtyping import Array

from ._emitter_checks import _dot

__all__ = ["CapsuleFrame", "capsule_frame", "horizon_crossings", "stadium_interval"]

_PI = math.pi


def _safe_sqrt(x: Array) -> Array:
    """sqrt(max(x, 0)) with gradient 0 (not inf/NaN) at and below 0."""
    pos = x > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, x, 1)), 0)


class CapsuleFrame(NamedTuple):
    """The axis `e` (length `ell`), `p` at `alpha_a` along it from `a` and `rho` off it, the
    unit vectors `f1` (from `p` towards the axis) and `f2`, and `kappa = min(1, r/rho)`."""

    e: Array
    ell: Array
    alpha_a: Array
    rho2: Array
    rho: Array
    f1: Array
    f2: Array
    kappa: Array


def capsule_frame(a, b, r, p) -> tuple[CapsuleFrame, Array]:
    """The frame of the pencil of planes through `p`, and whether `p` is outside the capsule."""
    dt = p.dtype
    ab = b - a
    ell2 = _dot(ab, ab)
    has_len = ell2 > 0
    ell = _safe_sqrt(ell2)
    e = jnp.where(has_len, ab / jnp.where(has_len, ell, 1.0), jnp.asarray([0.0, 0.0, 1.0], dt))
    ap = a - p
    alpha_a = _dot(ap, e)
    qv = ap - alpha_a * e
    rho2 = _dot(qv, qv)
    # inside test: distance from p to the segment
    tcl = jnp.clip(-alpha_a, 0.0, ell)
    dist2 = rho2 + (alpha_a + tcl) ** 2
    valid = dist2 > r * r
    # frame
    has_rho = rho2 > (1e-12 * r) ** 2
    rho = _safe_sqrt(rho2)
    # any unit vector perpendicular to e, for receivers on the axis
    helper = jnp.where(
        jnp.abs(e[0]) < 0.9, jnp.asarray([1.0, 0, 0], dt), jnp.asarray([0, 1.0, 0], dt)
    )
    fallback = jnp.cross(e, helper)
    fallback = fallback / jnp.linalg.norm(fallback)
    f1 = jnp.where(has_rho, qv / jnp.where(has_rho, rho, 1.0), fallback)
    f2 = jnp.cross(e, f1)
    kappa = jnp.minimum(r / jnp.where(has_rho, rho, r), 1.0)
    return CapsuleFrame(e, ell, alpha_a, rho2, rho, f1, f2, kappa), valid


def horizon_crossings(fr: CapsuleFrame, cc, r, p, n) -> tuple[Array, Array]:
    """The two tau where the horizon of `n` crosses the silhouette circle of the end sphere
    at `cc` (-pi/2 where it does not)."""

    def tau_of(omega):  # tau of the plane through p holding the direction omega
        x, y = _dot(omega, fr.f1), _dot(omega, fr.f2)
        eta = jnp.arctan(y / jnp.where(x == 0, 1e-30, x))
        x = jnp.sin(eta) / fr.kappa
        inner = jnp.abs(x) < 1
        return jnp.where(inner, jnp.arcsin(jnp.where(inner, x, 0.0)), jnp.sign(x) * (_PI / 2))

    vv = cc - p
    Dv2 = _dot(vv, vv)
    Dv = jnp.sqrt(jnp.where(Dv2 > r * r, Dv2, (2 * r) ** 2))
    uu = vv / Dv
    cos_al = jnp.sqrt((1 - r / Dv) * (1 + r / Dv))
    uh = uu - _dot(uu, n) * n
    mh = _safe_sqrt(_dot(uh, uh))
    ok = (mh > 0) & (cos_al < mh)
    h1 = uh / jnp.where(ok, mh, 1.0)
    h2 = jnp.cross(n, h1)
    cphi = jnp.where(ok, cos_al / jnp.where(ok, mh, 1.0), 0.0)
    sphi = _safe_sqrt((1 - cphi) * (1 + cphi))
    t1 = tau_of(cphi * h1 + sphi * h2)
    t2 = tau_of(cphi * h1 - sphi * h2)
    return jnp.where(ok, t1, -_PI / 2), jnp.where(ok, t2, -_PI / 2)


def stadium_interval(fr: CapsuleFrame, r, sin_eta, cos_eta, tau):
    """`(th0, rel1, rel2)`: `p` sees the stadium at eta under chi in th0 + [rel1, rel2]."""
    ell, alpha_a = fr.ell, fr.alpha_a
    # r'^2 = r^2 - rho^2 sin^2 eta; with kappa < 1 that is r^2 cos^2 tau exactly
    rp2 = jnp.where(fr.kappa < 1, (r * jnp.cos(tau)) ** 2, r * r - fr.rho2 * sin_eta**2)
    rp = _safe_sqrt(rp2)
    beta0 = fr.rho * cos_eta
    alpha_m = alpha_a + ell / 2
    dA = jnp.sqrt(alpha_a**2 + beta0**2)
    dB = jnp.sqrt((alpha_a + ell) ** 2 + beta0**2)
    dM = jnp.sqrt(alpha_m**2 + beta0**2)
    hA = jnp.arcsin(jnp.clip(rp / dA, 0.0, 1.0))
    hB = jnp.arcsin(jnp.clip(rp / dB, 0.0, 1.0))
    # The end directions thA, thB relative to the midpoint's th0, from cross and dot products
    # (no cancellation): far away thA - thB ~ l/d is tiny next to th0 ~ pi/2, and taking the
    # difference of the absolute angles lost it (float32: 4e-4 relative error at 1e4 r).
    th0 = jnp.arctan2(beta0, alpha_m)
    iA, iB, iM = (1 / jnp.where(x > 0, x, 1.0) for x in (dA, dB, dM))
    half_l = ell / 2 * iM
    dthA = jnp.arctan2(beta0 * iA * half_l, alpha_a * iA * alpha_m * iM + beta0 * iA * beta0 * iM)
    dthB = jnp.arctan2(
        -beta0 * iB * half_l, (alpha_a + ell) * iB * alpha_m * iM + beta0 * iB * beta0 * iM
    )
    rel1 = jnp.minimum(dthA - hA, dthB - hB)
    rel2 = jnp.maximum(dthA + hA, dthB + hB)
    return th0, rel1, rel2
