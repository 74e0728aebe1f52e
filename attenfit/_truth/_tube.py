"""A Lambertian tube (a cylinder's side, optionally with its end disks) and its exact irradiance.

The tube of axis `a -> b` (length `l`, unit axis `e`) and radius `r` emits uniform radiance
`L` outward from its side (and from its two end disks when `caps`). A receiver `p` with
unit normal `n` is described in the frame of its foot on the axis: `z_p = (p - a).e`, the
radial unit vector `rho^ = (p - a)_perp / rho` towards it and `t^ = e x rho^`; a side point
is `x(psi, z) = a + z e + r (cos(psi) rho^ + sin(psi) t^)`.

**What the receiver sees.** The tube's side is part of the boundary of a convex solid, so a
side point is visible from `p` exactly when it faces `p`, `rho cos(psi) > r`: the strip
`|psi| <= beta = acos(r / rho)` between the two silhouette generators (none when `rho <= r`;
the end disks then face `p` or not as a whole). Over that strip the receiver's tangent
plane cuts `h(psi, z) = n.(x - p) = alpha + nu z + r (mu_c cos psi + mu_s sin psi) >= 0`,
linear in `z`.

**Near the tube: the contour form.** The irradiance of a uniform-radiance region is `L` times
the normal component of its vector irradiance, which Stokes' theorem turns into an integral
over the boundary of its solid angle, `E = (L / 2) |oint n.(omega x d omega)|` (Lambert 1760;
Arvo 1994, "The irradiance Jacobian for partially occluded polyhedral sources", eqs. 2-4;
the form `attenfit`'s disk uses, docs/ground-truth.md §3.6 after Sparrow 1963). The strip's
boundary is four pieces, each integrated in closed form:

* a silhouette generator `psi = s beta` (a straight segment, so an arc of a great circle:
  Lambert's edge term), `Theta n.g` with `g = s rho^(s beta)` the tangent plane's normal
  and `Theta` the angle the segment subtends, `atan2(|dz| h_s, h_s^2 + (z_1 - z_p)(z_2 - z_p))`,
  `h_s = sqrt(rho^2 - r^2)`;
* an end circle's arc `|psi| <= beta` at `z_end`, with `zeta = z_end - z_p`:
  `int (A0 + Ac cos psi + As sin psi) / (D0 - b cos psi) d psi`, `A0 = r^2 nu`,
  `Ac = -r (rho nu + zeta mu_c)`, `As = -r zeta mu_s`, `D0 = rho^2 + zeta^2 + r^2`,
  `b = 2 r rho`, by the standard integrals of `1 / (D0 - b cos)` (Gradshteyn & Ryzhik
  2.553.3) and `sin / (D0 - b cos)` (a logarithm), regrouped so that the terms that diverge
  at the rim cancel analytically; where `b / D0 < 0.1` (the closed form cancels) by
  `_ARC_NODES` Gauss-Legendre nodes (the integrand's poles sit at `cos psi >= 10`, so the rule
  is exact to rounding);
* the horizon: where the tangent plane cuts the strip the contour follows the plane's great
  circle, so each such piece adds the angle it sweeps there. All visible points lie in an
  open half-space through `p` (the solid is convex and `p` outside), so every angle on that
  circle is measured from one reference without wrapping, and the pieces add up to
  `sum(theta at entries) - sum(theta at exits)` whatever joins them.

Each arc is split at the extremum of `h` along it, so every piece crosses the horizon at
most once; a crossing is found by `acos` (arcs) or linearly (generators).

**Far from it: Gauss-Legendre over the strip.** Every contour piece is of order `size / d`
while the sum is of order `(size / d)^2`, so beyond `_FAR_RADII` half-diagonals from the
centre the strip's integral `L int int r (rho cos psi - r) h / R^4 d psi dz` is summed
directly: panels in `psi` split where the horizon meets an end circle (the only kinks),
`_PSI_NODES` nodes each, and `_Z_NODES` nodes in `z` between the exact horizon limits. The
integrand's singularities lie at least `_FAR_RADII - 1` half-diagonals away, so both rules
are exact to rounding there (tests/test_tube.py checks the two branches against each other
and against an independent quadrature). Lengths are scaled by `max(|p - c|, half-diagonal)`
so nothing overflows in float32 at 1e12 sizes.

The end disks are one-sided disks facing `-e` at `a` and `+e` at `b`, evaluated by the disk's
closed forms (`_irradiance._disk_unclipped`, `_disk_clipped`); the solid angles of side and
disks do not overlap, so their irradiances add. Receivers on or inside the solid cylinder
give NaN.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._curves import TUBE_INPUTS
from .._errors import BadTypeError, BadValueError
from ._emitter_checks import (
    _bcast,
    _check_positive,
    _check_radius,
    _check_real,
    _dot,
    _is_traced,
    _receivers,
    _safe_norm,
    array_module,
)
from ._emitters import AbstractSegmentEmitter
from ._irradiance import _disk_clipped, _disk_unclipped, _gauss_legendre, _safe_sqrt

__all__ = ["TubeEmitter", "tube_irradiance_one"]

_PI = math.pi
#: Beyond this many half-diagonals from the centre the strip is integrated by Gauss-Legendre.
_FAR_RADII = 8.0
#: Gauss-Legendre nodes per psi-panel and in z (far field), and on an arc with b / D0 small.
_PSI_NODES, _Z_NODES, _ARC_NODES = 16, 8, 32
#: Below this b / D0 an arc is integrated by Gauss-Legendre (the closed form cancels).
_ARC_B_MIN = 0.1


class TubeEmitter(AbstractSegmentEmitter):
    """A Lambertian tube: the side of the cylinder of radius `radius` (m) around the segment
    `a -> b` (m), and its two end disks when `caps`.

    Uniform radiance `L = I / (pi r^2)`, as for every emitter (docs/architecture.md,
    Conventions): `I` is the intensity of one end disk seen along the axis. Seen at angle
    `psi` to its axis the tube's lit side has projected area `2 r l sin(psi)` (and the caps
    add `pi r^2 |cos(psi)|`), so its intensity there is `I g`,
    `g = 2 l sin(psi) / (pi r) + caps |cos(psi)|`; `point_light` uses this `g` from the
    centre, so the point-light model tends to the truth far away. A UsdLux `CylinderLight`
    is a tube without caps (its docs: "does not emit light from the flat end-caps").
    """

    a: Float[Array, "3"]
    b: Float[Array, "3"]
    radius: Float[Array, ""]
    intensity: Float[Array, ""]
    caps: bool = eqx.field(static=True)
    kind: ClassVar[str] = "tube"
    frame_input_names: ClassVar[tuple[str, ...]] = TUBE_INPUTS

    def __init__(
        self,
        a: ArrayLike,
        b: ArrayLike,
        radius: ArrayLike,
        intensity: ArrayLike = 1.0,
        caps: bool = False,
    ):
        self.a = _check_real("a", a, (3,))
        self.b = _check_real("b", b, (3,))
        if not (_is_traced(self.a) or _is_traced(self.b)):
            if not float(np.max(np.abs(np.asarray(b, float) - np.asarray(a, float)))) > 0:
                raise BadValueError(
                    f"a tube needs a length: a and b are both {np.asarray(a).tolist()}"
                )
        self.radius = _check_radius("radius", radius)
        self.intensity = _check_positive("intensity", intensity)
        if not isinstance(caps, bool | np.bool_):
            raise BadTypeError(f"caps must be True or False, got {caps!r}")
        self.caps = bool(caps)

    @property
    def center(self) -> Array:
        return 0.5 * (self.a + self.b)

    def reference_point(self) -> Array:
        return self.center

    def exact_kernel(self, dtype: Any) -> Any:
        return tube_kernel(self, dtype)

    def point_light(self, points, normals):
        """Distance to the centre and `I g max(0, n.l)`, `g = 2 l sin(psi) / (pi r) +
        caps |cos(psi)|`, `psi` the angle between the axis and `l` (the class docstring)."""
        p, n = _receivers(points, normals)
        xp = array_module(p, self.a, self.b, self.radius, self.intensity)
        dv = _bcast(self.center, p) - p
        d = _safe_norm(dv)
        l = dv / xp.where(d > 0, d, 1)[..., None]
        ab = _bcast(self.b, p) - _bcast(self.a, p)
        sin_l = _safe_norm(xp.cross(l, ab))  # = l sin(psi)
        r = xp.asarray(self.radius).astype(p.dtype)
        g = 2 * sin_l / (_PI * r)
        if self.caps:
            g = g + xp.abs(_dot(l, ab)) / _safe_norm(ab)
        return d, xp.asarray(self.intensity).astype(p.dtype) * g * xp.maximum(_dot(n, l), 0)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "a": np.asarray(self.a, dtype=np.float64).tolist(),
            "b": np.asarray(self.b, dtype=np.float64).tolist(),
            "radius": float(self.radius),
            "intensity": float(self.intensity),
            "caps": self.caps,
        }

    def inside(self, pts, margin=1e-9):
        return self.surface_distance(pts) <= float(self.radius) * margin

    def surface_distance(self, pts):
        """Distance to the solid cylinder (its caps included), 0 inside."""
        p = np.asarray(pts, dtype=np.float64)
        a = np.asarray(self.a, dtype=np.float64)
        ab = np.asarray(self.b, dtype=np.float64) - a
        ell = float(np.linalg.norm(ab))
        z = (p - a) @ (ab / ell)
        rho = np.linalg.norm((p - a) - z[:, None] * (ab / ell), axis=1)
        dz = np.maximum(np.maximum(-z, z - ell), 0.0)
        return np.hypot(np.maximum(rho - float(np.asarray(self.radius)), 0.0), dz)

    def projected_factor(self, l, ab, sin_psi, r):
        """`2 |b - a| sin(psi) / (pi r) + caps |cos(psi)|`, as `point_light`'s."""
        cos_psi = array_module(l, ab).abs(_dot(l, ab)) / _safe_norm(ab)
        return 2 * sin_psi / (_PI * r) + (cos_psi if self.caps else 0 * cos_psi)

    def light_frame(self, dtype):
        """Its centre, x along `a -> b`, z any unit vector across it (its models are
        symmetric about the axis); sizes: half length, radius."""
        xp = array_module(self.a, self.b, self.radius)
        a, b = xp.asarray(self.a).astype(dtype), xp.asarray(self.b).astype(dtype)
        c, ab = (a + b) / 2, b - a
        ex = ab / _safe_norm(ab)
        eye = xp.eye(3, dtype=dtype)
        ez = xp.cross(ex, xp.where(xp.abs(ex[0]) < 0.9, eye[0], eye[1]))
        ez = ez / _safe_norm(ez)
        return c, ex, ez, (_safe_norm(ab) / 2, xp.asarray(self.radius).astype(dtype))


# ----------------------------------------------------------------------------- the frame
def _frame(a, e, l, r, p, n):
    """The receiver's frame and the horizon's coefficients, lengths scaled by `lam`."""
    dt = p.dtype
    w = p - a
    zp = _dot(w, e)
    perp = w - zp * e
    rho = _safe_norm(perp)
    lam = jnp.maximum(_safe_norm(w - (l / 2) * e), jnp.sqrt((l / 2) ** 2 + r * r))
    helper = jnp.where(
        jnp.abs(e[0]) < 0.9, jnp.asarray([1.0, 0, 0], dt), jnp.asarray([0, 1.0, 0], dt)
    )
    fallback = jnp.cross(e, helper)
    fallback = fallback / jnp.linalg.norm(fallback)
    has = rho > 0
    rh = jnp.where(has, perp / jnp.where(has, rho, 1), fallback)
    th = jnp.cross(e, rh)
    return dict(
        zp=zp / lam, rho=rho / lam, r=r / lam, l=l / lam, lam=lam,
        nu=_dot(n, e), mc=_dot(n, rh), ms=_dot(n, th), alpha=-_dot(n, w) / lam,
    )  # fmt: skip


def _h(g, psi, z):
    """`n.(x(psi, z) - p)` (scaled)."""
    return g["alpha"] + g["nu"] * z + g["r"] * (g["mc"] * jnp.cos(psi) + g["ms"] * jnp.sin(psi))


# ----------------------------------------------------------------------------- near: contour
def _arc(g, zeta, psi1, psi2):
    """`int_psi1^psi2 n.(a x da) / |a|^2` along the end circle at `z_p + zeta` (module)."""
    rho, r, nu, mc, ms = g["rho"], g["r"], g["nu"], g["mc"], g["ms"]
    gap2 = (rho - r) ** 2 + zeta * zeta  # D0 - b, without cancellation
    b = 2 * r * rho
    D0 = gap2 + b
    closed = b >= _ARC_B_MIN * D0
    # closed form: K dJ - (Ac / b) dpsi + (As / b) dln (module docstring)
    rs = jnp.where(closed, rho, 1.0)
    bs = jnp.where(closed, b, 1.0)
    gs = jnp.where(closed, gap2, 1.0)
    K = -(rs * nu * ((rs - r) * (rs + r) + zeta * zeta) + zeta * mc * (gs + bs)) / (2 * rs)
    S = jnp.sqrt(gs * (gs + 2 * bs))
    k = jnp.sqrt((gs + 2 * bs) / gs)

    def J(psi):
        return (2 / S) * jnp.arctan2(k * jnp.sin(psi / 2), jnp.cos(psi / 2))

    d1 = gs + 2 * bs * jnp.sin(psi1 / 2) ** 2
    d2 = gs + 2 * bs * jnp.sin(psi2 / 2) ** 2
    dd = 2 * bs * jnp.sin((psi1 + psi2) / 2) * jnp.sin((psi2 - psi1) / 2)  # d2 - d1
    dln = jnp.where(d2 < 0.5 * d1, jnp.log(d2 / d1), jnp.log1p(dd / d1))
    ac_b = -(rs * nu + zeta * mc) / (2 * rs)
    as_b = -zeta * ms / (2 * rs)
    closed_val = K * (J(psi2) - J(psi1)) - ac_b * (psi2 - psi1) + as_b * dln
    # Gauss-Legendre where b / D0 is small
    xg, wg = _gauss_legendre(_ARC_NODES, psi1.dtype)
    half = (psi2 - psi1) / 2
    ps = (psi1 + psi2) / 2 + half * xg
    num = r * (r * nu - (rho * nu + zeta * mc) * jnp.cos(ps) - zeta * ms * jnp.sin(ps))
    den = gap2 + 2 * b * jnp.sin(ps / 2) ** 2
    gl_val = half * jnp.sum(wg * num / jnp.where(closed, 1.0, den))
    return jnp.where(closed, closed_val, gl_val)


def _generator(g, s, hs, z1, z2):
    """Lambert's edge term of the silhouette generator `psi = s beta` from `z1` to `z2`."""
    zp = g["zp"]
    theta = jnp.arctan2(jnp.abs(z2 - z1) * hs, hs * hs + (z1 - zp) * (z2 - zp))
    cos_b, sin_b = g["r"] / g["rho"], hs / g["rho"]
    return jnp.sign(z2 - z1) * theta * (s * g["mc"] * cos_b + g["ms"] * sin_b)


def _acos(c: Array) -> Array:
    """acos(clip(c, -1, 1)) with a finite gradient (0) where `c` is clipped."""
    inner = jnp.abs(c) < 1
    return jnp.where(inner, jnp.arccos(jnp.where(inner, c, 0.0)), jnp.where(c > 0, 0.0, _PI))


def _mu_psin(g) -> tuple[Array, Array]:
    """`mu`, `psi_n` with `mc cos psi + ms sin psi = mu cos(psi - psi_n)` (0, 0 when n is the axis)."""
    mu = _safe_norm(jnp.stack([g["mc"], g["ms"]]))
    pos = mu > 0
    return mu, jnp.arctan2(jnp.where(pos, g["ms"], 0.0), jnp.where(pos, g["mc"], 1.0))


def _cross_psi(g, zs, pa, pb):
    """Where `h(psi, zs) = 0` on an arc from `pa` to `pb` along which `h` is monotone."""
    mu, psin = _mu_psin(g)
    base = g["alpha"] + g["nu"] * zs
    c = -base / jnp.where(mu > 0, g["r"] * mu, 1.0)
    xm = (pa + pb) / 2 - psin
    m = jnp.round(xm / (2 * _PI))
    sgn = jnp.where(xm - 2 * _PI * m >= 0, 1.0, -1.0)
    psi = psin + 2 * _PI * m + sgn * _acos(c)
    return jnp.clip(psi, jnp.minimum(pa, pb), jnp.maximum(pa, pb))


def _side_near(g):
    """The strip's contour sum (module docstring); `E_side = (L / 2) |sum|`."""
    rho, r, zp, l = g["rho"], g["r"], g["zp"], g["l"]
    hs = _safe_sqrt((rho - r) * (rho + r))
    beta = jnp.arctan2(hs, r)
    _, psin = _mu_psin(g)
    # the extremum of h along the arcs inside (-beta, beta), if any (else beta: an empty piece)
    ext = jnp.mod(psin + _PI / 2, _PI) - _PI / 2
    ext = jnp.where(jnp.abs(ext) < beta, ext, beta)
    zero = jnp.zeros_like(beta)
    # the chain: vertices (psi, z), pieces between consecutive ones
    vpsi = jnp.stack([-beta, ext, beta, beta, ext, -beta])
    vz = jnp.stack([zero, zero, zero, l, l, l])
    hv = _h(g, vpsi, vz)
    inside = hv >= 0
    total = zero
    crossings = []
    for i in range(6):
        j = (i + 1) % 6
        pa, pb, za, zb, ia, ib = vpsi[i], vpsi[j], vz[i], vz[j], inside[i], inside[j]
        is_arc = i in (0, 1, 3, 4)
        if is_arc:
            pc = _cross_psi(g, za, pa, pb)
            lo = jnp.where(ia, pa, pc)
            hi = jnp.where(ib, pb, pc)
            # a piece wholly below contributes exactly 0 (XLA's vector and scalar lanes may
            # round J(lo) and J(hi) of equal arguments differently)
            total = total + jnp.where(ia | ib, _arc(g, za - zp, lo, hi), 0.0)
            cpsi, cz = pc, za
        else:
            den = hv[i] - hv[j]
            zc = za + (zb - za) * hv[i] / jnp.where(den != 0, den, 1.0)
            zc = jnp.clip(zc, jnp.minimum(za, zb), jnp.maximum(za, zb))
            lo = jnp.where(ia, za, zc)
            hi = jnp.where(ib, zb, zc)
            s = 1.0 if i == 2 else -1.0
            total = total + jnp.where(ia | ib, _generator(g, s, hs, lo, hi), 0.0)
            cpsi, cz = pa, zc
        vec = (cz - zp) * jnp.asarray([0.0, 0.0, 1.0], beta.dtype)  # in (rho^, t^, e)
        vec = vec + jnp.stack([r * jnp.cos(cpsi) - rho, r * jnp.sin(cpsi), zero])
        sign = jnp.where(ia & ~ib, -1.0, jnp.where(ib & ~ia, 1.0, 0.0))
        crossings.append((vec, sign))
    # the horizon's pieces: angles on the receiver's plane, from one reference
    nvec = jnp.stack([g["mc"], g["ms"], g["nu"]])
    units = [v / jnp.where(_safe_norm(v) > 0, _safe_norm(v), 1.0) for v, _ in crossings]
    ref = sum(u * jnp.abs(s) for u, (_, s) in zip(units, crossings, strict=True))
    for v, s in crossings:
        ok = s != 0  # no crossing: no reference either (double where: finite gradients)
        y, x = _dot(nvec, jnp.cross(ref, v)), _dot(ref, v)
        theta = jnp.arctan2(jnp.where(ok, y, 0.0), jnp.where(ok, x, 1.0))
        total = total + jnp.where(ok, s * theta, 0.0)
    return total


# ----------------------------------------------------------------------------- far: quadrature
def _side_far(g):
    """The strip's integral `int int r (rho cos psi - r) h / R^4 d psi dz` (scaled, module)."""
    rho, r, zp, l, nu = g["rho"], g["r"], g["zp"], g["l"], g["nu"]
    dt = rho.dtype
    beta = jnp.arctan2(_safe_sqrt((rho - r) * (rho + r)), r)
    mu, psin = _mu_psin(g)
    cuts = []
    for zs in (0.0, 1.0):
        c = -(g["alpha"] + nu * l * zs) / jnp.where(mu > 0, r * mu, 1.0)
        ok = (mu > 0) & (jnp.abs(c) <= 1)
        ac = _acos(c)
        for sgn in (1.0, -1.0):
            x = jnp.mod(psin + sgn * ac + _PI, 2 * _PI) - _PI
            cuts.append(jnp.where(ok & (jnp.abs(x) < beta), x, beta))
    edges = jnp.sort(jnp.stack([-beta, *cuts, beta]))
    xg, wg = _gauss_legendre(_PSI_NODES, dt)
    lo_e, hi_e = edges[:-1], edges[1:]
    psi = (((lo_e + hi_e) / 2)[:, None] + ((hi_e - lo_e) / 2)[:, None] * xg[None, :]).reshape(-1)
    wpsi = (((hi_e - lo_e) / 2)[:, None] * wg[None, :]).reshape(-1)
    H = _h(g, psi, jnp.zeros_like(psi))  # h = H + nu z
    zc = -H / jnp.where(nu != 0, nu, 1.0)
    zlo = jnp.where(nu > 0, jnp.clip(zc, 0.0, l), 0.0)
    zhi = jnp.where(nu < 0, jnp.clip(zc, 0.0, l), l)
    zhi = jnp.where((nu == 0) & (H < 0), zlo, jnp.maximum(zhi, zlo))
    xz, wz = _gauss_legendre(_Z_NODES, dt)
    z = ((zlo + zhi) / 2)[:, None] + ((zhi - zlo) / 2)[:, None] * xz[None, :]
    wzz = ((zhi - zlo) / 2)[:, None] * wz[None, :]
    cos_x = (rho * jnp.cos(psi) - r)[:, None]  # rho^(psi).(p - x)
    h = jnp.maximum(H[:, None] + nu * z, 0.0)
    R2 = ((rho - r) ** 2 + 4 * rho * r * jnp.sin(psi / 2) ** 2)[:, None] + (z - zp) ** 2
    inner = jnp.sum(wzz * jnp.maximum(cos_x, 0.0) * h / (R2 * R2), axis=1)
    return r * jnp.sum(wpsi * inner)


# ----------------------------------------------------------------------------- the kernel
def _disk_one(c, m, r, I, p, n) -> Array:
    """One receiver lit by a one-sided disk (the closed forms of `_irradiance`)."""
    E_un, clipped, _ = _disk_unclipped(c, m, r, I, p, n)
    J_an, J_chord = _disk_clipped(c, m, r, I, p, n, False)
    J_gl, _ = _disk_clipped(c, m, r, I, p, n, True)
    E_clip = jnp.maximum(-(I / (_PI * r * r)) / 2 * (J_an + J_gl + J_chord), 0.0)
    return jnp.where(clipped, E_clip, E_un)


def tube_irradiance_one(a, b, r, I, caps: bool, p, n) -> Array:
    """Exact irradiance of the tube `a -> b`, radius `r`, intensity `I` (radiance
    `I / (pi r^2)`), at one receiver `p` with unit normal `n` (module docstring)."""
    ab = b - a
    l = _safe_norm(ab)
    e = ab / l
    g = _frame(a, e, l, r, p, n)
    visible = g["rho"] > g["r"]
    far = (g["lam"] * g["lam"]) > _FAR_RADII**2 * ((l / 2) ** 2 + r * r)
    safe = dict(g, rho=jnp.where(visible, g["rho"], 2 * g["r"]))
    near_far = jnp.where(far, _side_far(safe), jnp.abs(_side_near(safe)) / 2)
    L = I / (_PI * r * r)
    E = jnp.where(visible, L * near_far, 0.0)
    if caps:
        E = E + _disk_one(a, -e, r, I, p, n) + _disk_one(b, e, r, I, p, n)
    z = g["zp"] * g["lam"]
    inside = (g["rho"] <= g["r"]) & (z >= 0) & (z <= l)
    return jnp.where(inside, jnp.nan, E)


def tube_kernel(emitter: TubeEmitter, dtype: Any) -> Any:
    """`(p, n) -> E` for one receiver of `emitter`, in `dtype`."""

    def cast(x):
        return jnp.asarray(x).astype(dtype)

    a, b, r, I = (cast(x) for x in (emitter.a, emitter.b, emitter.radius, emitter.intensity))
    caps = emitter.caps
    return lambda p, n: tube_irradiance_one(a, b, r, I, caps, p, n)
