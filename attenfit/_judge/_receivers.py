"""The receiver space of a decision band: every receiver the report's three receiver sets
could hold there, as a box of coordinates a search can walk (docs/judging.md).

The report judges a model on three receiver sets (`attenfit._report._configs`): receivers
*facing* the light's centre, *floors* facing the light, and receivers of *any* orientation
(its random set). Here each set is continuous instead of sampled, and every band starts at
contact (the light's surface; for a disk, the plane just in front of it):

* **facing**: the normal toward the light's centre; for a disk on its axis (the report's
  sweep). One coordinate: the gap to the surface.
* **floor**: planes facing the light (normal -m, `m` the disk's normal; for a sphere any
  axis) at heights `h` from contact to 10 r in front of the centre, receivers out to 100 r
  from the axis (the report's floors, `FLOOR_HEIGHT`, `FLOOR_REACH`). Coordinates (h, rho).
* **any**: any position in the band and any normal. By symmetry a sphere's receiver is
  (gap, theta), theta the angle between the normal and `l`; a one-sided disk's is
  (gap, u, theta, phi): `u` in [0, 2] walks the stadium of points `gap` from the disk (the
  flat face for u <= 1, the quarter circle round the rim above it, stopping `Z_MIN` in front
  of the disk's plane), phi the normal's azimuth
  about `l` (0: toward the axis side, in the plane of `l` and the axis).

Lengths are in units of the light's radius r, in the light's frame: its centre at the origin,
its front along +z (a disk's normal `m`; a sphere's floors lie on +z), receivers in the xz
half-plane x >= 0. `geometry` maps a set's physical coordinates to (points, normals) there;
`Piece` maps the unit box [0, 1]^k onto the coordinates (a set may need two boxes: the
band's floors under a disk), with theta warped so that half the box lies where the light
straddles the horizon (|cos theta| < sin a, sin a = min(1, r / d)).
"""

from __future__ import annotations

import dataclasses
import functools
import math

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, Float

from .._errors import BadValueError

__all__ = [
    "CONTACT",
    "FAR_LIMIT",
    "FLOOR_HEIGHT",
    "FLOOR_REACH",
    "GAP_BANDS",
    "GAP_BAND_LABELS",
    "SETS",
    "SET_LABELS",
    "Z_MIN",
    "Piece",
    "geometry",
    "local_receivers",
    "pieces",
    "sample",
]

#: The decision table's bands on the gap from the light's surface, in units of r (the
#: report's `_metrics.GAP_BANDS` are these): contact to r, r to 10 r, beyond 10 r (to
#: `FAR_LIMIT`).
GAP_BANDS: dict[str, tuple[float, float]] = {
    "contact": (0.0, 1.0),
    "near": (1.0, 10.0),
    "far": (10.0, math.inf),
}
GAP_BAND_LABELS: dict[str, str] = {
    "contact": "contact to r",
    "near": "r to 10 r",
    "far": "beyond 10 r",
}
#: Where "beyond 10 r" stops: the report's facing sweep and random receivers reach 1000 r.
FAR_LIMIT = 1000.0
#: The gap read as contact (in r): a receiver on a sphere is invalid, one in a disk's plane
#: unlit; the report's sphere sweep starts at the same r (1 + 1e-9).
CONTACT = 1e-9
#: The report's floors: heights from contact to this (in r) in front of the light's centre,
FLOOR_HEIGHT = 10.0
#: and receivers out to this distance (in r) from the axis.
FLOOR_REACH = 100.0
#: The receiver sets, as the report names them (its "random" set is `any` here).
SETS: tuple[str, ...] = ("facing", "floor", "any")
SET_LABELS: dict[str, str] = {
    "facing": "facing receivers",
    "floor": "floor",
    "any": "receivers of any orientation",
}
#: How close (in r) a receiver comes to a disk's plane past its rim: in the plane both the
#: truth and its reference (the facing truth) are 0, and within 1e-13 r of it the truth's
#: rounding (about 1e-16 of the light's radiance) reaches 1e-3 of the reference; from
#: 1e-9 r on it stays under 1e-7.
Z_MIN = 1e-9
#: Fraction of the theta box on each side of the horizon-straddling range.
_WARP = (0.25, 0.75)


def band_gaps(band: str) -> tuple[float, float]:
    """The band's gaps (lo, hi) in r, contact read as `CONTACT`, beyond 10 r up to `FAR_LIMIT`."""
    if band not in GAP_BANDS:
        raise BadValueError(f"band must be one of {list(GAP_BANDS)}, got {band!r}")
    lo, hi = GAP_BANDS[band]
    return max(lo, CONTACT), min(hi, FAR_LIMIT)


# ============================================================================ geometry
def _safe_sqrt(x: Array) -> Array:
    pos = x > 0
    return jnp.where(pos, jnp.sqrt(jnp.where(pos, x, 1.0)), 0.0)


def _stadium(gap: Array, u: Array) -> tuple[Array, Array]:
    """(rho, z) of the point at `u` in [0, 2] on the stadium `gap` from a disk of radius 1."""
    c = Z_MIN / gap
    ok = c < 1.0
    psi_max = jnp.where(ok, jnp.arccos(jnp.where(ok, c, 0.5)), 0.0)
    psi = jnp.clip(u - 1.0, 0.0, 1.0) * psi_max
    flat = u <= 1.0
    rho = jnp.where(flat, u, 1.0 + gap * jnp.sin(psi))
    z = jnp.where(flat, gap, gap * jnp.cos(psi))
    return rho, z


def _normal_about(l: Array, theta: Array, phi: Array) -> Array:
    """The unit normal at angle `theta` from `l` (in the xz plane), azimuth `phi` about it."""
    e2 = jnp.stack([jnp.zeros_like(theta), jnp.ones_like(theta), jnp.zeros_like(theta)], -1)
    e1 = jnp.stack([l[..., 2], jnp.zeros_like(theta), -l[..., 0]], -1)  # e2 x l
    st, ct = jnp.sin(theta), jnp.cos(theta)
    return (
        ct[..., None] * l
        + (st * jnp.cos(phi))[..., None] * e1
        + (st * jnp.sin(phi))[..., None] * e2
    )


def geometry(light: str, rset: str, q: Float[Array, "*b k"]) -> tuple[Array, Array]:
    """(points, normals), each (..., 3), in the light's frame (units of r) from a set's
    physical coordinates `q` (see the module docstring): facing (gap,), floor (h, rho),
    any (gap, theta) for a sphere and (gap, u, theta, phi) for a disk."""
    zero = jnp.zeros_like(q[..., 0])
    down = jnp.stack([zero, zero, zero - 1.0], -1)
    if rset == "facing":
        z = q[..., 0] + (1.0 if light == "sphere" else 0.0)
        return jnp.stack([zero, zero, z], -1), down
    if rset == "floor":
        return jnp.stack([q[..., 1], zero, q[..., 0]], -1), down
    if light == "sphere":
        gap, theta = q[..., 0], q[..., 1]
        p = jnp.stack([zero, zero, 1.0 + gap], -1)
        return p, _normal_about(down, theta, zero)
    rho, z = _stadium(q[..., 0], q[..., 1])
    p = jnp.stack([rho, zero, z], -1)
    d = jnp.sqrt(rho * rho + z * z)
    l = -p / d[..., None]
    return p, _normal_about(l, q[..., 2], q[..., 3])


def horizon_sin(light: str, rset: str, q: Float[Array, "*b k"]) -> Array:
    """sin a = min(1, r / d): the light lies within angle a of `l` (d in r)."""
    p, _ = geometry(light, rset, q)
    d = jnp.sqrt(jnp.sum(p * p, axis=-1))
    return jnp.minimum(1.0, 1.0 / d)


# ============================================================================ boxes
def _lerp(a, b, t):
    return a + (b - a) * t


def _gap_of(t: Array, lo: float, hi: float) -> Array:
    """The gap at box coordinate t: linear from contact, log-spaced from r on."""
    if lo <= CONTACT:
        return _lerp(lo, hi, t)
    return lo * (hi / lo) ** t


def _gap_inverse(gap: np.ndarray, lo: float, hi: float) -> np.ndarray:
    if lo <= CONTACT:
        return (gap - lo) / (hi - lo)
    return np.log(gap / lo) / np.log(hi / lo)


def _theta_of(t: Array, sin_a: Array) -> Array:
    """theta from its box coordinate: [0, w0] -> [0, pi/2 - a], [w0, w1] -> pi/2 -+ a,
    [w1, 1] -> [pi/2 + a, pi]."""
    a = jnp.arcsin(sin_a)
    w0, w1 = _WARP
    lo = jnp.pi / 2 - a
    return jnp.where(
        t < w0,
        lo * t / w0,
        jnp.where(
            t < w1,
            lo + 2.0 * a * (t - w0) / (w1 - w0),
            jnp.pi / 2 + a + lo * (t - w1) / (1.0 - w1),
        ),
    )


def _theta_inverse(theta: np.ndarray, sin_a: np.ndarray) -> np.ndarray:
    a = np.arcsin(sin_a)
    w0, w1 = _WARP
    lo = np.pi / 2 - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = np.where(lo > 0, theta / np.where(lo > 0, lo, 1.0) * w0, 0.0)
        t1 = w0 + (theta - lo) / np.where(a > 0, 2.0 * a, 1.0) * (w1 - w0)
        t2 = w1 + (theta - np.pi / 2 - a) / np.where(lo > 0, lo, 1.0) * (1.0 - w1)
    return np.clip(np.where(theta < lo, t0, np.where(theta <= np.pi / 2 + a, t1, t2)), 0, 1)


@dataclasses.dataclass(frozen=True)
class Piece:
    """One box of a receiver set: `coords(x)` maps x in [0, 1]^k onto its coordinates.

    `kind` says which map: "gap" (facing), "floor" (h in [h0, h1], rho between the band's
    limits at that h), "any". Hashable: it is a static argument of the compiled search."""

    light: str
    rset: str
    band: str
    kind: str
    h0: float = 0.0
    h1: float = 0.0
    #: For a disk's floors: rho starts at 0 (h >= the band's lo) or past the rim.
    inner: bool = False

    @property
    def ndim(self) -> int:
        return {"gap": 1, "floor": 2}.get(self.kind, 2 if self.light == "sphere" else 4)

    @property
    def names(self) -> tuple[str, ...]:
        if self.kind == "gap":
            return ("gap",)
        if self.kind == "floor":
            return ("h", "rho")
        return ("gap", "theta") if self.light == "sphere" else ("gap", "u", "theta", "phi")

    def rho_limits(self, h: Array) -> tuple[Array, Array]:
        """The floor's rho at height h (in r) that lies in the band."""
        lo, hi = band_gaps(self.band)
        if self.light == "sphere":
            r_lo = _safe_sqrt((1.0 + lo) ** 2 - h * h)
            r_hi = _safe_sqrt((1.0 + hi) ** 2 - h * h)
        else:
            r_lo = jnp.zeros_like(h) if self.inner else 1.0 + _safe_sqrt(lo * lo - h * h)
            r_hi = 1.0 + _safe_sqrt(hi * hi - h * h)
        return r_lo, jnp.minimum(r_hi, FLOOR_REACH)

    def coords(self, x: Float[Array, "*b k"]) -> Float[Array, "*b k"]:
        """The set's physical coordinates (for `geometry`) at box coordinates x."""
        lo, hi = band_gaps(self.band)
        if self.kind == "gap":
            return _gap_of(x, lo, hi)
        if self.kind == "floor":
            h = _lerp(self.h0, self.h1, x[..., 0])
            r_lo, r_hi = self.rho_limits(h)
            return jnp.stack([h, _lerp(r_lo, r_hi, x[..., 1])], -1)
        gap = _gap_of(x[..., 0], lo, hi)
        if self.light == "sphere":
            s = jnp.minimum(1.0, 1.0 / (1.0 + gap))
            return jnp.stack([gap, _theta_of(x[..., 1], s)], -1)
        u = 2.0 * x[..., 1]
        rho, z = _stadium(gap, u)
        s = jnp.minimum(1.0, 1.0 / jnp.sqrt(rho * rho + z * z))
        return jnp.stack([gap, u, _theta_of(x[..., 2], s), jnp.pi * x[..., 3]], -1)

    def box_of(self, q: np.ndarray) -> np.ndarray:
        """The inverse of `coords` (host, NumPy), for receivers drawn in physical terms."""
        lo, hi = band_gaps(self.band)
        if self.kind == "gap":
            return _gap_inverse(q, lo, hi)
        if self.kind == "floor":
            h = q[..., 0]
            r_lo, r_hi = (np.asarray(v) for v in _rho_limits(self, jnp.asarray(h)))
            th = (h - self.h0) / (self.h1 - self.h0) if self.h1 > self.h0 else np.zeros_like(h)
            with np.errstate(divide="ignore", invalid="ignore"):
                tr = np.where(r_hi > r_lo, (q[..., 1] - r_lo) / (r_hi - r_lo), 0.0)
            return np.clip(np.stack([th, tr], -1), 0, 1)
        s = np.asarray(_horizon_sin(self.light, self.rset, jnp.asarray(q)))
        tg = _gap_inverse(q[..., 0], lo, hi)
        if self.light == "sphere":
            return np.clip(np.stack([tg, _theta_inverse(q[..., 1], s)], -1), 0, 1)
        t = np.stack([tg, q[..., 1] / 2, _theta_inverse(q[..., 2], s), q[..., 3] / np.pi], -1)
        return np.clip(t, 0, 1)


_horizon_sin = jax.jit(horizon_sin, static_argnums=(0, 1))
_rho_limits = jax.jit(Piece.rho_limits, static_argnums=0)


@functools.partial(jax.jit, static_argnums=0)
def local_receivers(piece: Piece, x: Float[Array, "*b k"]) -> tuple[Array, Array, Array]:
    """(coordinates, points, normals) of `piece`'s receivers at box coordinates x, in the
    light's frame (units of r), compiled once per piece."""
    q = piece.coords(x)
    p, n = geometry(piece.light, piece.rset, q)
    return q, p, n


def pieces(light: str, rset: str, band: str) -> tuple[Piece, ...]:
    """The boxes of receiver set `rset` ("facing", "floor", "any") of a `light` ("sphere",
    "disk") in `band`; none where the set has no receiver in the band."""
    if light not in ("sphere", "disk"):
        raise BadValueError(f"light must be 'sphere' or 'disk', got {light!r}")
    if rset not in SETS:
        raise BadValueError(f"receivers must be one of {list(SETS)}, got {rset!r}")
    lo, hi = band_gaps(band)
    if rset == "facing":
        return (Piece(light, rset, band, "gap"),)
    if rset == "any":
        return (Piece(light, rset, band, "any"),)
    if light == "sphere":  # the floor touches the sphere at h = 1 + CONTACT
        h0, h1 = 1.0 + CONTACT, min(FLOOR_HEIGHT, 1.0 + hi)
        return (Piece(light, rset, band, "floor", h0, h1),) if h1 > h0 else ()
    out = []
    if min(FLOOR_HEIGHT, hi) > lo:  # floors at h >= lo: every rho out to the band's edge
        out.append(Piece(light, rset, band, "floor", lo, min(FLOOR_HEIGHT, hi), inner=True))
    if min(lo, FLOOR_HEIGHT) > CONTACT and lo > CONTACT:  # lower floors: past the rim only
        out.append(Piece(light, rset, band, "floor", CONTACT, min(lo, FLOOR_HEIGHT)))
    return tuple(out)


def sample(piece: Piece, n: int, rng: np.random.Generator) -> np.ndarray:
    """`n` box coordinates of `piece`'s receivers drawn at random in physical terms: the gap
    uniform from contact (log-uniform from r on), floors uniform in h and rho, normals
    uniform on the sphere (the report's random set's normals), u uniform."""
    lo, hi = band_gaps(piece.band)
    if piece.kind == "gap":
        return rng.uniform(0, 1, (n, 1))
    if piece.kind == "floor":
        return rng.uniform(0, 1, (n, 2))  # h uniform; rho uniform at that h
    tg = rng.uniform(0, 1, n)
    gap = _gap_of(tg, lo, hi)  # NumPy arithmetic
    theta = np.arccos(rng.uniform(-1, 1, n))
    if piece.light == "sphere":
        q = np.stack([gap, theta], -1)
    else:
        q = np.stack([gap, rng.uniform(0, 2, n), theta, rng.uniform(0, np.pi, n)], -1)
    return piece.box_of(q)
