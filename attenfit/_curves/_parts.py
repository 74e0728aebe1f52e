"""Composable parts of attenuation curves: base falloffs, range windows and distance warps.

Every named family in `attenfit.families` is a product of these pure functions, so a user
can build a combination nobody published (see "Write and register your own family" in docs/families.md)::

    f(d) = base(warp(d)) * window(d)

All parts take arrays that already share one floating dtype (use `promote`) and return that
dtype. Each is written in a numerically stable form and follows the double-`where` idiom:
every branch that could produce NaN or inf in the value *or the gradient* is fed a safe
input first and selected afterwards, so values and gradients are finite wherever the true
ones are (the two honestly singular bases return +inf, never NaN).

Distances are in the caller's length unit (metres for the engine defaults); a base falloff
returns 1/length^2, a window or a spot factor is dimensionless.
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

Real = Float[Array, "*shape"]


# ----------------------------------------------------------------------------- dtypes
def _is_weak(x: Any) -> bool:
    """Python scalars and weakly typed JAX values (e.g. `jnp.asarray(0.1)`) follow the others."""
    if isinstance(x, (bool, int, float)):
        return True
    return bool(getattr(x, "weak_type", False))


def promote(d: ArrayLike, *params: ArrayLike) -> tuple[Array, ...]:
    """Cast `d` and `params` to one floating dtype, the dtype the curve is computed in.

    That is `d`'s dtype when `d` is a (non-weakly typed) float array: any float dtype in, the
    same dtype out, whatever the parameters' dtypes (a float64 parameter is rounded for a
    float32 `d`). Otherwise (a Python number, an integer array) the widest float dtype among
    the non-weak parameters, else JAX's default float. Explicit casts, so it works under
    ``jax_numpy_dtype_promotion="strict"``.
    """
    best = _float_dtype(d)
    if best is None:
        for x in params:
            dt = _float_dtype(x)
            if dt is not None and (best is None or dt.itemsize > best.itemsize):
                best = dt
    if best is None:
        best = jnp.zeros((), dtype=float).dtype  # float64 under x64, else float32
    best = jax.dtypes.canonicalize_dtype(best)  # float64 -> float32 when x64 is off
    return tuple(jnp.asarray(x, dtype=best) for x in (d, *params))


def _float_dtype(x: Any) -> np.dtype | None:
    """The dtype of `x` if it is a non-weak floating array, else None."""
    if _is_weak(x):
        return None
    dt = np.dtype(x.dtype) if hasattr(x, "dtype") else np.dtype(jnp.asarray(x).dtype)
    return dt if jnp.issubdtype(dt, jnp.floating) else None


def distance(d: Real) -> Real:
    """The distance with negative values treated as 0 (NaN stays NaN; +inf stays +inf).

    A `where` rather than `max`, so the gradient at d = 0 is the one-sided derivative of the
    curve, not half of it.
    """
    return jnp.where(d < 0, jnp.zeros_like(d), d)


def keep_nan(d: Real, f: Real) -> Real:
    """f, with NaN wherever d is NaN (clamps written with `where` would otherwise hide it)."""
    return jnp.where(jnp.isnan(d), jnp.full_like(f, jnp.nan), f)


def stable_hypot(a: Real, b: Real) -> Real:
    """sqrt(a^2 + b^2) for a, b >= 0 without overflow or underflow of the squares.

    Computed as m sqrt(1 + (n/m)^2) with m = max(a, b), n = min(a, b); gradients are finite
    everywhere except at a = b = 0 (never reached by the families: one argument is a
    positive length).
    """
    m = jnp.maximum(a, b)
    n = jnp.minimum(a, b)
    m_safe = jnp.where(m > 0, m, jnp.ones_like(m))
    ratio = jnp.where(jnp.isinf(m_safe), jnp.zeros_like(n), n / m_safe)
    return jnp.where(m > 0, m_safe * jnp.sqrt(1 + ratio * ratio), jnp.zeros_like(m))


# ----------------------------------------------------------------------------- base falloffs
def inverse_square(d: Real) -> Real:
    """1/d^2 (RTR4 eq. 5.11), computed as (1/d)^2.

    Honestly singular: +inf at d = 0 and wherever 1/d^2 overflows the dtype, never NaN
    (its gradient there is -inf, not NaN). No overflow of d^2 for large d.
    """
    inv = 1 / d
    return inv * inv


def softened_inverse_square(d: Real, a: Real) -> Real:
    """1/(d^2 + a^2), computed as (1/hypot(d, a))^2 so neither square overflows.

    With a^2 = eps this is Unreal's 1/(d^2 + eps) (RTR4 eq. 5.12); with a = r it is the
    exact irradiance on the axis of a facing disk of radius r and radiance 1/(pi r^2);
    with a = r/sqrt(2) it is Yuksel's ad hoc eq. 8.
    """
    inv = 1 / stable_hypot(d, a)
    return inv * inv


def clamped_inverse_square(d: Real, r_min: Real) -> Real:
    """1/max(d, r_min)^2 (RTR4 eq. 5.13; CryEngine, Frostbite). r_min > 0."""
    m = jnp.where(d > r_min, d, r_min)
    inv = 1 / m
    return inv * inv


def yuksel(d: Real, r: Real) -> Real:
    """Yuksel 2020 eq. 7, 2/r^2 (1 - d/sqrt(d^2 + r^2)), in the cancellation-free form.

    Evaluated as (2/s) / (s + d) with s = hypot(d, r): algebraically identical to eq. 7 and
    to the project page's 2/(d^2 + r^2 + d sqrt(d^2 + r^2)), but with no subtraction and no
    overflow of d^2 (the product s (s + d) is never formed).
    """
    s = stable_hypot(d, r)
    return (2 / s) / (s + d)


def polynomial(d: Real, kc: Real, kl: Real, kq: Real) -> Real:
    """1/(kc + kl d + kq d^2), OpenGL's fixed-function attenuation (`glLight`).

    Two branches so nothing overflows: for d <= 1 the polynomial directly, for d > 1
    u^2 / (kc u^2 + kl u + kq) with u = 1/d; one division for both (a fit evaluates this
    at every step, and divisions dominate its cost). Coefficients are non-negative; the
    value is +inf only where the denominator is 0 (kc = 0 at d = 0).
    """
    near = d <= 1
    dn = jnp.where(near, d, jnp.zeros_like(d))
    u = 1 / jnp.where(near, jnp.ones_like(d), d)
    numerator = jnp.where(near, jnp.ones_like(u), u * u)
    denominator = jnp.where(near, kc + dn * (kl + kq * dn), kq + u * (kl + kc * u))
    return numerator / denominator


def power_clamped_value(d: Real, p: Real, floor: float) -> Real:
    """1/max(d^p, floor) (three.js `getDistanceAttenuation`), stable for any p > 0.

    d^p is formed as exp(p log d) only where it exceeds `floor`, so d = 0 gives 1/floor with
    a finite gradient with respect to p.
    """
    positive = d > 0
    logd = jnp.log(jnp.where(positive, d, jnp.ones_like(d)))
    big = positive & (p * logd > math.log(floor))
    logd_big = jnp.where(big, logd, jnp.zeros_like(logd))
    return jnp.where(big, jnp.exp(-p * logd_big), jnp.full_like(d, 1 / floor))


def power_min_distance(d: Real, a: Real, d_min: float) -> Real:
    """max(d, d_min)^(-a) (Godot 4 `get_omni_attenuation`), with d_min > 0 so a can be any real."""
    m = jnp.where(d > d_min, d, jnp.full_like(d, d_min))
    return jnp.exp(-a * jnp.log(m))


def surface_distance(d: Real, r: Real) -> Real:
    """Distance from a sphere's surface, max(d - r, 0) (Madams 2011's `d`)."""
    return jnp.where(d > r, d - r, jnp.zeros_like(d))


def surface_sphere(d_s: Real, r: Real) -> Real:
    """1/(d_s + r)^2 for a surface distance d_s: Madams 2011's 1/(d_s/r + 1)^2 divided by r^2.

    Normalised like the rest (-> 1/d^2 far away): equal to 1/max(d, r)^2 in centre distance.
    Stays finite and smooth for d_s up to the dtype's maximum (a warped d_s may be huge).
    """
    inv = 1 / (d_s + r)
    return inv * inv


def cutoff_bias(d: Real, r: Real, cutoff: Real) -> Real:
    """Madams 2011's scale and bias, max(0, (a - c)/(1 - c)) with a = r^2/max(d, r)^2.

    Reaches 0 (with a non-zero slope) at d = R = r/sqrt(c), the centre-distance form of the
    post's d_max = r (sqrt(Li/Ic) - 1) for Li = 1. Evaluated as a - c = c q (q + 2) with
    q = (R - m)/m, m = max(d, r), so the zero crossing does not cancel (beyond the rounding
    of R itself).
    """
    m = jnp.where(d > r, d, r)
    big_r = r / jnp.sqrt(cutoff)
    inside = m < big_r
    m_in = jnp.where(inside, m, jnp.zeros_like(m) + r)
    q = (big_r - m_in) / m_in  # (R - m)/m, exact-ish near the range
    val = cutoff * q * (q + 2) / (1 - cutoff)  # c ((R/m)^2 - 1) / (1 - c)
    return jnp.where(inside, val, jnp.zeros_like(val))


# ----------------------------------------------------------------------------- windows
def smooth_window(d: Real, r_max: Real, m: int = 4, k: Real | float = 2) -> Real:
    """The range window (1 - (d/r_max)^m)+^k (RTR4 eq. 5.14 for m = 4, k = 2).

    (m, k) = (4, 2): Unreal, Frostbite, Filament, Bevy, Godot, three.js; (4, 1): glTF
    (not squared, only C0 at the range); (2, 2): Just Cause 2; (2, p): Unreal's exponent mode.
    `m` is a static positive integer, `k` may be a traced parameter (k > 1 gives zero slope at
    the range). Stable scaled form: 1 - x^m = ((r_max - d)/r_max) (1 + x + ... + x^(m-1)),
    so there is no cancellation near the range and no overflow of d^m.
    """
    if not (isinstance(m, int) and m >= 1):
        raise ValueError(f"window exponent m must be a positive int, got {m!r}")
    inside = d < r_max
    d_in = jnp.where(inside, d, jnp.zeros_like(d))
    x = d_in / r_max
    poly = jnp.ones_like(x)
    xp = jnp.ones_like(x)
    for _ in range(m - 1):
        xp = xp * x
        poly = poly + xp
    base = ((r_max - d_in) / r_max) * poly
    base_safe = jnp.where(inside, base, jnp.ones_like(base))
    if isinstance(k, int):
        val = base_safe**k
    elif isinstance(k, float) and k.is_integer():
        val = base_safe ** int(k)
    else:
        val = jnp.exp(k * jnp.log(base_safe))
    return jnp.where(inside, val, jnp.zeros_like(val))


def linear_tail_window(d: Real, r_max: Real, fraction: float = 0.2, power: int = 2) -> Real:
    """CryEngine's fade, clamp((r_max - d)/(fraction r_max), 0, 1)^power.

    CRYENGINE `shadeLib.cfi::GetPhysicalLightAttenuation` uses fraction 0.2 ("fadeout last 20%
    of radius") and squares the ramp (power 2: zero slope at r_max, a kink at 0.8 r_max); RTR4
    section 5.2.2 describes the plain linear ramp (power 1: only C0 at r_max).
    """
    t = (r_max - d) / (fraction * r_max)
    t = jnp.where(t > 1, jnp.ones_like(t), jnp.where(t > 0, t, jnp.zeros_like(t)))
    return t**power


# ----------------------------------------------------------------------------- distance warps
def _warp_fraction(d: Real, d_max: Real, gap: Real | None) -> tuple[Real, Real, Real]:
    """inside = gap > 0, u = d/d_max and v = gap/d_max (gap = d_max - d), made safe."""
    if gap is None:
        gap = d_max - d
    inside = gap > 0
    d_in = jnp.where(inside, d, jnp.zeros_like(d))
    gap_in = jnp.where(inside, gap, d_max)
    return inside, d_in / d_max, gap_in / d_max


def tan_warp(d: Real, d_max: Real, gap: Real | None = None) -> tuple[Real, Real]:
    """Madams 2011b's tan warp d' = (2 d_max/pi) tan(pi d/(2 d_max)) -> inf at d = d_max.

    The post writes 2.1 tan(...) for its own d_max; 2 d_max/pi keeps d' = d + O(d^3) near 0.
    Returns (d', inside): d' is finite everywhere (arbitrary but safe where not `inside`,
    i.e. d >= d_max, where the caller selects 0). Near d_max it uses
    tan(pi/2 u) = 1/tan(pi/2 (1 - u)) with 1 - u = gap/d_max, so no argument is close to a
    pole. `gap` = d_max - d, if the caller can compute it more accurately than that (e.g.
    (d_max - D) + r for a surface distance d = D - r); by default d_max - d.
    """
    inside, u, v = _warp_fraction(d, d_max, gap)
    scale = 2 * d_max / math.pi
    low = u <= 0.5
    # One tan of an argument in [0, pi/4]: tan(pi/2 u) itself, or its reciprocal form.
    t = jnp.tan((math.pi / 2) * jnp.where(low, u, jnp.where(inside, v, jnp.full_like(v, 0.5))))
    t_safe = jnp.where(low, jnp.ones_like(t), t)
    warped = jnp.where(low, scale * t, scale / t_safe)
    return jnp.where(inside, warped, jnp.zeros_like(warped)), inside


def rational_warp(d: Real, d_max: Real, gap: Real | None = None) -> tuple[Real, Real]:
    """Madams 2011b's rational warp d' = d/(1 - (d/d_max)^2) -> inf at d = d_max.

    Computed as d/(v (1 + u)) with v = gap/d_max = (d_max - d)/d_max, u = d/d_max (no
    cancellation). Returns (d', inside) like `tan_warp`; `gap` as there.
    """
    inside, u, v = _warp_fraction(d, d_max, gap)
    warped = (u * d_max) / (v * (1 + u))
    return jnp.where(inside, warped, jnp.zeros_like(warped)), inside


def surface_gap(d: Real, r: Real, d_max: Real) -> Real:
    """d_max - max(d - r, 0) for a surface-distance warp, as (d_max - d) + r when d > r.

    Near the range d ~ d_max + r, so d_max - d is exact (Sterbenz) when r <= d_max and the
    only rounding is the final one: the warp keeps full relative accuracy up to its pole.
    """
    return jnp.where(d > r, (d_max - d) + r, d_max)


# ----------------------------------------------------------------------------- splines
def monotone_cubic(
    x: Float[Array, "*batch"], xk: Float[Array, " k"], yk: Float[Array, "*batch k"]
) -> Float[Array, "*batch"]:
    """Fritsch-Carlson monotone cubic Hermite interpolation (PCHIP) of (xk, yk) at x.

    Fritsch and Carlson 1980, "Monotone piecewise cubic interpolation" (SIAM J. Numer. Anal.
    17(2)), with the endpoint slopes and harmonic-mean interior slopes of Fritsch and Butland
    (as in scipy's `PchipInterpolator`). Monotone whenever the data are. `xk` (k >= 2) must be
    strictly increasing; `yk` carries the same batch shape as `x` (broadcast them first); `x`
    is clipped to [xk[0], xk[-1]] (extrapolate in the caller). Differentiable in `yk` and `x`
    (double-`where` around every division). `yk` may also be a single (k,) row shared by all x.
    """
    shape = x.shape
    k = xk.shape[0]
    x = x.reshape(-1)
    yk = yk.reshape(-1, k)  # (1, k) for shared knot values: slopes computed once
    h = (xk[1:] - xk[:-1])[None, :]
    delta = (yk[:, 1:] - yk[:, :-1]) / h
    if k == 2:
        m = jnp.concatenate([delta, delta], axis=-1)
    else:
        w1 = 2 * h[:, 1:] + h[:, :-1]
        w2 = h[:, 1:] + 2 * h[:, :-1]
        d0, d1 = delta[:, :-1], delta[:, 1:]
        same = (d0 * d1) > 0
        d0s = jnp.where(same, d0, jnp.ones_like(d0))
        d1s = jnp.where(same, d1, jnp.ones_like(d1))
        interior = jnp.where(same, (w1 + w2) / (w1 / d0s + w2 / d1s), jnp.zeros_like(d0))
        m0 = _pchip_end(h[:, 0], h[:, 1], delta[:, 0], delta[:, 1])
        mn = _pchip_end(h[:, -1], h[:, -2], delta[:, -1], delta[:, -2])
        m = jnp.concatenate([m0[:, None], interior, mn[:, None]], axis=-1)
    xc = jnp.clip(x, xk[0], xk[-1])

    # Interval index and per-interval coefficients by a chain of selects over the k - 1
    # intervals (k is small): no gathers and no reductions over a short axis, which are slow
    # on CPU and costly to differentiate under vmap.
    def interval(j: int):
        return (yk[:, j], yk[:, j + 1], m[:, j], m[:, j + 1], h[:, j] + jnp.zeros_like(x), xk[j])

    y0, y1, m0_, m1_, hi, x0 = interval(0)
    for j in range(1, k - 1):
        here = xc >= xk[j]
        yj0, yj1, mj0, mj1, hj, xj = interval(j)
        y0 = jnp.where(here, yj0, y0)
        y1 = jnp.where(here, yj1, y1)
        m0_ = jnp.where(here, mj0, m0_)
        m1_ = jnp.where(here, mj1, m1_)
        hi = jnp.where(here, hj, hi)
        x0 = jnp.where(here, xj, x0)
    t = (xc - x0) / hi
    t2 = t * t
    t3 = t2 * t
    out = (
        (2 * t3 - 3 * t2 + 1) * y0
        + (t3 - 2 * t2 + t) * hi * m0_
        + (-2 * t3 + 3 * t2) * y1
        + (t3 - t2) * hi * m1_
    )
    return out.reshape(shape)


def _pchip_end(h0: Array, h1: Array, d0: Array, d1: Array) -> Array:
    """The shape-preserving three-point endpoint slope of PCHIP (scipy's `_edge_case`)."""
    m = ((2 * h0 + h1) * d0 - h0 * d1) / (h0 + h1)
    m = jnp.where(jnp.sign(m) != jnp.sign(d0), jnp.zeros_like(m), m)
    return jnp.where((jnp.sign(d0) != jnp.sign(d1)) & (jnp.abs(m) > jnp.abs(3 * d0)), 3 * d0, m)
