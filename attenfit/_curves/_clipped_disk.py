"""The exact irradiance of a one-sided disk, horizon clipping included: a closed form a
shader can evaluate.

Lambert's formula (Lambert 1760; Arvo 1994, "The irradiance Jacobian for partially occluded
polyhedral sources", eq. 2; Heitz et al. 2016, "Real-Time Polygonal-Light Shading with
Linearly Transformed Cosines", eq. 11) gives the irradiance of a uniform emitter as a
contour integral over the boundary of its part above the receiver's horizon (Stokes'
theorem; Sparrow 1963, "A new and simpler formulation for radiative angle factors"):
`E = -(L/2) oint n.(a x da) / |a|^2`, `a` the vector from the receiver to the boundary.
Where the horizon cuts a disk the boundary is the visible rim arc and the chord along the
horizon (docs/ground-truth.md §3.6, the same contour `attenfit._truth` integrates); where
it does not, the whole rim.

In the disk's frame (centre at the origin, normal `m = +z`), the receiver at `(s, 0, z)`,
`z = d cos_e`, `s = d sin_e`, with normal `n = (nx, ny, nz)`: `nz = -cos_n`,
`nx = (z cos_n - d cos_r) / s` (from `n.l = cos_r`), `ny = sqrt(1 - nx^2 - nz^2)` (the
irradiance is even in `ny`). Lengths are over `lam = sqrt(d^2 + r^2)` (so `~` below). The
rim point at angle `phi` is above the horizon where `cos(phi - phi_n) >= x_c`,
`x_c = -d cos_r / (r w)`, `w = sqrt(nx^2 + ny^2)`, `phi_n = atan2(ny, nx)`: the arc
`phi_n -+ beta`, `beta = acos(x_c)` (`beta = pi`: the whole rim). On it

    oint_arc = int [A0 + Ac cos phi + As sin phi] / (1 - rho cos phi) dphi,
    A0 = nz r~^2,  Ac = r~ (z~ nx - s~ nz),  As = r~ z~ ny,  rho = 2 r~ s~,

whose three integrals are elementary: `I0 = (2/S) atan2(K sin(phi/2), cos(phi/2))`,
`Ic = (I0 - phi) / rho` and `Is = log(1 - rho cos phi) / rho` (`S = sqrt(1 - rho^2)`,
`K = (1 + rho) / S`), written without their cancellation at small `rho`:
`Ic = 2 c1 Y atanc(rho c1 Y) + 2 A rho / (S (1 + S))` (`A` the atan2 above,
`Y = sin h cos h / (cos^2 h + K sin^2 h)`, `h = phi/2`, `c1 = (K - 1)/rho`), and the
difference of `Is` as `log1p`. The chord adds `atan2(n.(a_A x a_B), a_A.a_B)`, its cross
product formed from the rim offsets (`q x (e_B - e_A) + e_A x e_B`, `q` to the centre):
products of nearly parallel vectors lose `d/r` of their digits otherwise.

The sum of the arc's and the chord's terms, each of order `r/d`, is of order `(r/d)^2`
where the horizon cuts the disk: float32 keeps `eps d / r` of the facing value there
(1e-4 at 1000 r). Beyond 1000 r in float32 the JAX form takes the sphere cap of
`VectorDisk` there (within 1e-4 of the facing value at 1000 r, less beyond).
"""

import math

import jax.numpy as jnp

from .._ir import Expr, Lets, Ref, fn
from ._area import AreaModel, register_area_model, safe_sqrt
from ._area_models import VectorDisk
from ._forms import area_shader

__all__ = ["ClippedDisk"]

#: Below this r / sqrt(d^2 + r^2), float32 takes the cap where the horizon cuts the disk.
_FAR_RT_F32 = 1e-3
#: Below this |y|, atan(y)/y and log1p(y)/y by two terms of their series.
_SERIES = 1e-4


def _atanc(y):
    """atan(y) / y (1 at 0)."""
    small = jnp.abs(y) < _SERIES
    ys = jnp.where(small, jnp.ones_like(y), y)
    return jnp.where(small, 1 - y * y / 3, jnp.arctan(ys) / ys)


def _log1pc(y):
    """log1p(y) / y (1 at 0)."""
    small = jnp.abs(y) < _SERIES
    ys = jnp.where(small, jnp.ones_like(y), y)
    return jnp.where(small, 1 - y / 2 + y * y / 3, jnp.log1p(ys) / ys)


def _nonzero(x):
    return jnp.where(x > 0, x, jnp.ones_like(x))


def _tilt(d, cos_r, cos_e, cos_n):
    """`(w, nx)`: the sine of the normal's tilt from the disk's axis and its component toward
    the receiver's foot (module docstring). `w` is at least `|nx|`: below a tilt of 1e-8 rad
    `cos_n` rounds to 1 and carries no tilt, while `cos_r` still does (a receiver just in
    front of the disk whose horizon cuts it)."""
    st = d * safe_sqrt((1 - cos_e) * (1 + cos_e))
    nx = jnp.where(st > 0, jnp.clip((d * cos_e * cos_n - d * cos_r) / _nonzero(st), -1, 1), 0 * st)
    return jnp.maximum(safe_sqrt((1 - cos_n) * (1 + cos_n)), jnp.abs(nx)), nx


def _contour(d, cos_r, cos_e, r, cos_n):
    """`E / I` of the one-sided disk by the contour of its visible part (module docstring),
    for receivers in front of it."""
    lam = jnp.sqrt(d * d + r * r)
    dt, rt = d / lam, r / lam
    zt = dt * cos_e
    st = dt * safe_sqrt((1 - cos_e) * (1 + cos_e))
    nz = -cos_n
    w, nx = _tilt(d, cos_r, cos_e, cos_n)
    ny = safe_sqrt((w - nx) * (w + nx))
    rho = 2 * rt * st
    a1 = zt * zt + (st - rt) ** 2  # 1 - rho, without the cancellation
    big_s = jnp.sqrt(a1 * (1 + rho))
    k = (1 + rho) / big_s
    c1 = (1 + rho / (1 + big_s)) / big_s
    xc = jnp.clip(-d * cos_r / (r * _nonzero(w)), -1, 1)
    xc = jnp.where(w > 0, xc, jnp.where(cos_r >= 0, -1.0, 1.0))
    sin_b = safe_sqrt((1 - xc) * (1 + xc))
    beta = jnp.arctan2(sin_b, xc)
    phi_n = jnp.arctan2(ny, jnp.where(w > 0, nx, jnp.ones_like(nx)))
    h1, h2 = (phi_n - beta) / 2, (phi_n + beta) / 2

    def arc_terms(h):  # the antiderivatives of I0 and Ic at phi = 2 h
        sh, ch = jnp.sin(h), jnp.cos(h)
        angle = jnp.arctan2(k * sh, ch)
        y = sh * ch / (ch * ch + k * sh * sh)
        return angle * (2 / big_s), 2 * c1 * y * _atanc(rho * c1 * y) + 2 * angle * rho / (
            big_s * (1 + big_s)
        )

    (i0_1, ic_1), (i0_2, ic_2) = arc_terms(h1), arc_terms(h2)
    d1 = a1 + 2 * rho * jnp.sin(h1) ** 2  # 1 - rho cos(phi_1)
    spread = 2 * jnp.sin(phi_n) * sin_b / d1  # (cos phi_1 - cos phi_2) / (1 - rho cos phi_1)
    i_s = spread * _log1pc(rho * spread)
    arc = nz * rt * rt * (i0_2 - i0_1) + rt * (zt * nx - st * nz) * (ic_2 - ic_1)
    arc = arc + rt * zt * ny * i_s
    # the chord from phi_n + beta to phi_n - beta (module docstring)
    ux, uy = 2 * rt * jnp.sin(phi_n) * sin_b, -2 * rt * jnp.cos(phi_n) * sin_b
    n_cross = nx * zt * uy - ny * zt * ux + nz * (-st * uy - rt * rt * 2 * sin_b * xc)
    dot = st * st + zt * zt - 2 * rt * st * jnp.cos(phi_n) * xc + rt * rt * (2 * xc * xc - 1)
    chord = jnp.arctan2(n_cross, dot)
    return jnp.maximum(-(arc + chord), 0) / (2 * math.pi * r * r)


@register_area_model
class ClippedDisk(AreaModel):
    """The exact irradiance of a one-sided disk at every receiver in front of it, the horizon
    clipping included: Lambert's contour integral over the visible rim arc and the chord
    along the horizon, in closed form (see the module docstring). Zero behind the disk.
    No parameters. Float32 keeps `eps d / r` of the facing value where the horizon cuts the
    disk (beyond 1000 r it takes `VectorDisk`'s cap there).
    """

    name = "clipped_disk"
    formula = (
        "-(1 / (2 pi r^2)) [A0 I0 + Ac Ic + As Is + chord]: Lambert's contour over the "
        "visible rim arc phi_n -+ acos(-d cos_r / (r w)) and the horizon chord"
    )
    source = (
        "Lambert 1760 via Arvo 1994 eq. 2 and Heitz et al. 2016 eq. 11 (the contour form); "
        "Sparrow 1963 (Stokes' theorem); docs/ground-truth.md §3.6"
    )
    default_free = ()
    light = "disk"
    exact = "a one-sided disk, every receiver in front of it"

    def irradiance(self, d, cos_r, cos_e, r, cos_n, g):
        # wholly above the horizon: the vector irradiance (exact, and free of the contour's
        # cancellation in front of the disk's plane, where E is small)
        above = VectorDisk(clip="clamp").irradiance(d, cos_r, cos_e, r, cos_n, g)
        w, _ = _tilt(d, cos_r, cos_e, cos_n)
        cut = (jnp.abs(d * cos_r) < r * w) & (cos_e > 0) & (d > 0)
        zero = jnp.zeros_like(d)
        e = _contour(d, jnp.where(cut, cos_r, zero), jnp.where(cut, cos_e, zero + 1), r,
                     jnp.where(cut, cos_n, zero))  # fmt: skip
        e = jnp.where(cut, e, above)
        if d.dtype == jnp.float32:  # where float32 loses the contour's digits: the cap
            far = r < _FAR_RT_F32 * jnp.sqrt(d * d + r * r)
            cap = VectorDisk().irradiance(d, cos_r, cos_e, r, cos_n, g)
            e = jnp.where(cut & far, cap, e)
        return e

    @area_shader(
        "Lambert 1760 via Arvo 1994 eq. 2 and Heitz et al. 2016 eq. 11 (the contour form); "
        "Sparrow 1963 (Stokes' theorem); the vector form of Howell B-12/B-14 above the horizon",
        engine=False,
        note="float32 keeps eps d/r of the facing value where the horizon cuts the disk (no "
        "cap beyond 1000 r, unlike the float32 JAX form)",
    )
    def shader_form(self, let: Lets, x: dict[str, Ref], p: dict[str, Ref]) -> Expr:
        """The contour in the expression language of `attenfit._ir` (no guards: the shader
        reads receivers in front of the disk, `cos_e > 0`, and off its rim)."""
        return _contour_form(let, x, p["radius"])


def _sign(s: Expr, tie: Expr) -> Expr:
    """The sign of `s`, `-1` where it is 0 and `tie` holds."""
    return fn("select", s > 0.0, 1.0, fn("select", s < 0.0, -1.0, fn("select", tie, -1.0, 1.0)))


def _half(c: Expr, s: Expr, sign: Expr, low: bool) -> tuple[Expr, Expr]:
    """(cos, sin) of half the angle `phi` of (cos phi, sin phi) = (c, s): the unit vector along
    (1 + c, s) where c >= 0 and (s, 1 - c) elsewhere (each exact where it is used, with no
    trigonometric call), `sign` its orientation (which half-turn)."""
    near = fn("ge", c, 0.0)
    root = fn("sqrt", 2.0 * fn("select", near, 1.0 + c, 1.0 - c))
    if low:  # phi in [-pi, pi]: cos(phi/2) >= 0
        return (fn("select", near, (1.0 + c) / root, sign * s / root),
                fn("select", near, s / root, sign * (1.0 - c) / root))  # fmt: skip
    # phi in [0, 2 pi]: sin(phi/2) >= 0
    return (fn("select", near, sign * (1.0 + c) / root, s / root),
            fn("select", near, sign * s / root, (1.0 - c) / root))  # fmt: skip


def _half_low(let: Lets, cn: Expr, sn: Expr, xc: Expr, sb: Expr) -> tuple[Expr, Expr]:
    """(cos, sin) of (phi_n - beta) / 2, from the cosines and sines of phi_n and beta."""
    c = let("cos_phi1", cn * xc + sn * sb)
    s = let("sin_phi1", sn * xc - cn * sb)
    return _half(c, s, _sign(s, xc < cn), low=True)  # phi_1 = -pi where beta > phi_n


def _half_high(let: Lets, cn: Expr, sn: Expr, xc: Expr, sb: Expr) -> tuple[Expr, Expr]:
    """(cos, sin) of (phi_n + beta) / 2."""
    c = let("cos_phi2", cn * xc - sn * sb)
    s = let("sin_phi2", sn * xc + cn * sb)
    return _half(c, s, _sign(s, xc < -cn), low=False)  # phi_2 = 2 pi where beta > pi - phi_n


def _contour_form(let: Lets, x: dict[str, Ref], r: Ref) -> Expr:
    """`_contour` as a shader form (the same steps, unguarded)."""
    d, cos_r, cos_e, cos_n = x["d"], x["cos_r"], x["cos_e"], x["cos_n"]
    inv = let("inv_lam", 1.0 / fn("sqrt", d * d + r * r))
    rt, zt = let("rt", r * inv), let("zt", d * inv * cos_e)
    st = let("st", d * inv * fn("sqrt", fn("max", (1.0 - cos_e) * (1.0 + cos_e), 0.0)))
    nx = let("nx", fn("clamp", (zt * cos_n - d * inv * cos_r) / fn("max", st, 1e-30), -1.0, 1.0))
    tilt = fn("sqrt", fn("max", (1.0 - cos_n) * (1.0 + cos_n), 1e-30))
    w = let("w", fn("max", tilt, fn("abs", nx)))  # `_tilt`: at least |nx|
    ny = let("ny", fn("sqrt", fn("max", (w - nx) * (w + nx), 0.0)))
    rho = let("rho", 2.0 * rt * st)
    a1 = let("a1", zt * zt + (st - rt) * (st - rt))
    big_s = let("big_s", fn("sqrt", a1 * (1.0 + rho)))
    k = let("k", (1.0 + rho) / big_s)
    c1 = let("c1", (1.0 + rho / (1.0 + big_s)) / big_s)
    xc = let("xc", fn("clamp", -d * cos_r / (r * w), -1.0, 1.0))
    sin_b = let("sin_b", fn("sqrt", fn("max", (1.0 - xc) * (1.0 + xc), 0.0)))
    sin_n = let("sin_phi_n", ny / w)
    cos_n_ = let("cos_phi_n", nx / w)
    ends = []
    for tag, (cos_h, sin_h) in (("1", _half_low(let, cos_n_, sin_n, xc, sin_b)),
                                ("2", _half_high(let, cos_n_, sin_n, xc, sin_b))):  # fmt: skip
        sh, ch = let(f"sin_h{tag}", sin_h), let(f"cos_h{tag}", cos_h)
        angle = let(f"angle{tag}", fn("atan2", k * sh, ch))
        y = let(f"y{tag}", rho * c1 * sh * ch / (ch * ch + k * sh * sh))
        atanc = fn("select", fn("abs", y) < _SERIES, 1.0 - y * y / 3.0,
                   fn("atan", y) / fn("select", fn("abs", y) < _SERIES, 1.0, y))  # fmt: skip
        ic = let(f"ic{tag}", 2.0 * c1 * sh * ch / (ch * ch + k * sh * sh) * atanc)
        ends.append((angle, ic, sh))
    (a_1, ic_1, sh_1), (a_2, ic_2, _) = ends
    spread = let("spread", 2.0 * sin_n * sin_b / (a1 + 2.0 * rho * sh_1 * sh_1))
    u = let("u", 1.0 + rho * spread)  # log1p(rho spread) / (rho spread), by Kahan's trick
    um1 = u - 1.0
    log1pc = fn("select", fn("abs", um1) > 0.0,
                fn("log", u) / fn("select", fn("abs", um1) > 0.0, um1, 1.0), 1.0)  # fmt: skip
    tail = 2.0 * rho / (big_s * (1.0 + big_s))
    arc = let(
        "arc",
        -cos_n * rt * rt * (2.0 / big_s) * (a_2 - a_1)
        + rt * (zt * nx + st * cos_n) * (ic_2 - ic_1 + tail * (a_2 - a_1))
        + rt * zt * ny * spread * log1pc,
    )
    ux, uy = 2.0 * rt * sin_n * sin_b, -2.0 * rt * cos_n_ * sin_b
    n_cross = nx * zt * uy - ny * zt * ux - cos_n * (-st * uy - 2.0 * rt * rt * sin_b * xc)
    dot = st * st + zt * zt - 2.0 * rt * st * cos_n_ * xc + rt * rt * (2.0 * xc * xc - 1.0)
    chord = let("chord", fn("atan2", n_cross, dot))
    e_cut = fn("max", -(arc + chord), 0.0) / (2.0 * math.pi * r * r)
    # wholly above the horizon: the vector irradiance (`VectorDisk`), S shared
    q0 = let("q0", zt * zt + rt * rt - st * st)
    q = fn("select", q0 < 0.0, 4.0 * st * st * zt * zt / (big_s - q0), big_s + q0)
    num = q * cos_n + 2.0 * zt * d * inv * (cos_r - cos_e * cos_n)
    e_vec = fn("max", num / (big_s * (big_s + 1.0)), 0.0) * inv * inv
    lit = fn("select", fn("ge", d * cos_r, r * w), e_vec, e_cut)
    return fn("select", cos_e > 0.0, lit, 0.0)
