"""A one-sided Lambertian rectangle and its exact irradiance (Lambert's polygon formula).

The rectangle of centre `c`, unit normal `m`, unit tangent `u` (its width axis) and
`v = m x u` emits uniform radiance `L` into the half-space `m.(x - c) > 0`. At a receiver
`p` with unit normal `n`, the irradiance is Lambert's formula over the polygon clipped to
the receiver's upper hemisphere (Lambert 1760; Arvo 1994, "The irradiance Jacobian for
partially occluded polyhedral sources", eq. 2; Heitz et al. 2016, "Real-Time Polygonal-Light
Shading with Linearly Transformed Cosines", eq. 11):

    E = (L / 2) |sum_i Theta_i n.g_i|,  Theta_i = angle(a_i, a_{i+1}),
    g_i = (a_i x a_{i+1}) / |a_i x a_{i+1}|,  a_i = w_i - p (the polygon's vertices).

Stable form. Far away every edge term is of order w/d while the sum is of order (w/d)^2, so
the plain sum loses the ratio d/w of its digits. With `q = c - p` and the vertices' offsets
`e_i = w_i - c`, each term is split as `n.(a_i x a_j) (G_ij - 1/|q|^2) + n.(a_i x a_j)/|q|^2`,
`G = Theta / |a_i x a_j|`: the second part sums exactly to `n.(sum e_i x e_j)/|q|^2` (the
polygon's vector area, independent of `p`), and the first is small by construction, with
`a_i x a_j = q x (e_j - e_i) + e_i x e_j`, `|q|^2 - a_i.a_j = -(q.(e_i + e_j) + e_i.e_j)` and
`atan(x)/x - 1` by its series below 0.3. Within 4 half-diagonals of the centre the plain
sum is used: there the terms are of the order of the result, and the split's are not.
Clipping against the plane `n.(x - p) = 0` (Sutherland-Hodgman's cuts) keeps each edge's
part above it and adds the plane's own edge: five edges, no vertex list to compact.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from .._curves import RECT_INPUTS
from .._errors import BadValueError
from ._emitter_checks import (
    _check_positive,
    _check_real,
    _dot,
    _is_traced,
    _safe_norm,
    _unit,
    array_module,
)
from ._emitters import AbstractFlatEmitter
from ._irradiance import _one_minus_atan_ratio

__all__ = ["RectEmitter", "rect_irradiance_one"]

#: Beyond this many half-diagonals squared from the centre, the far-field split is summed.
_FAR = 16.0


class RectEmitter(AbstractFlatEmitter):
    """A one-sided Lambertian rectangle: centre `center` (m), unit `normal`, unit `tangent`
    along its `width` (m), and `height` (m) along `normal x tangent`.

    It emits into the half-space `(x - c).m > 0` with uniform radiance `L = I / (w h)`: the
    intensity is `I` along the normal and `I max(0, cos(theta_e))` off it, as a one-sided
    disk's. `radius` is the radius of the disk of the same area, `sqrt(w h / pi)`, so that
    `L = I / (pi r^2)` as for every emitter (docs/architecture.md, Conventions).
    """

    center: Float[Array, "3"]
    normal: Float[Array, "3"]
    tangent: Float[Array, "3"]
    width: Float[Array, ""]
    height: Float[Array, ""]
    radius: Float[Array, ""]
    intensity: Float[Array, ""]
    kind: ClassVar[str] = "rect"
    frame_input_names: ClassVar[tuple[str, ...]] = RECT_INPUTS
    two_sided: ClassVar[bool] = False

    def __init__(
        self,
        center: ArrayLike,
        normal: ArrayLike,
        tangent: ArrayLike,
        width: ArrayLike,
        height: ArrayLike,
        intensity: ArrayLike = 1.0,
    ):
        self.center = _check_real("center", center, (3,))
        self.normal = _unit("normal", normal)
        t = _unit("tangent", tangent)
        if not (_is_traced(t) or _is_traced(self.normal)):
            along = float(np.abs(_dot(t, self.normal)))
            if along > 1 - 1e-6:
                raise BadValueError(f"tangent {np.asarray(tangent).tolist()} is along the normal")
        t = t - _dot(t, self.normal) * self.normal  # the part in the rectangle's plane
        xp = array_module(t)
        self.tangent = t / xp.linalg.norm(t)
        self.width = _check_positive("width", width)
        self.height = _check_positive("height", height)
        xp = array_module(self.width, self.height)
        self.radius = xp.asarray(xp.sqrt(self.width * self.height / math.pi))
        self.intensity = _check_positive("intensity", intensity)

    @property
    def bitangent(self) -> Array:
        """`normal x tangent`, the rectangle's height axis."""
        return array_module(self.normal, self.tangent).cross(self.normal, self.tangent)

    def corners(self) -> Float[Array, "4 3"]:
        """The four corners, counter-clockwise seen from the lit side."""
        return self.center[None, :] + _offsets(
            self.tangent, self.bitangent, self.width / 2, self.height / 2
        )

    def exact_kernel(self, dtype: Any) -> Any:
        return rect_kernel(self, dtype)

    def surface_distance(self, pts):
        """Distance to the nearest point of the (closed) rectangle."""
        rel = np.asarray(pts, dtype=np.float64) - np.asarray(self.center, dtype=np.float64)
        z = rel @ np.asarray(self.normal, dtype=np.float64)
        s = np.abs(rel @ np.asarray(self.tangent, dtype=np.float64)) - float(self.width) / 2
        t = np.abs(rel @ np.asarray(self.bitangent, dtype=np.float64)) - float(self.height) / 2
        return np.hypot(z, np.hypot(np.maximum(s, 0.0), np.maximum(t, 0.0)))

    def extent(self):
        return float(np.abs(np.asarray(self.corners(), dtype=np.float64)).max())

    def light_frame(self, dtype):
        """Its centre, x its tangent (width), z its normal; sizes: half width, half height."""
        c, ex, ez = (v.astype(dtype) for v in (self.center, self.tangent, self.normal))
        return c, ex, ez, (self.width.astype(dtype) / 2, self.height.astype(dtype) / 2)

    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "center": np.asarray(self.center, dtype=np.float64).tolist(),
            "normal": np.asarray(self.normal, dtype=np.float64).tolist(),
            "tangent": np.asarray(self.tangent, dtype=np.float64).tolist(),
            "width": float(self.width),
            "height": float(self.height),
            "intensity": float(self.intensity),
        }


def _offsets(u: Array, v: Array, hw: Array, hh: Array) -> Float[Array, "4 3"]:
    xp = array_module(u, v, hw, hh)
    signs = xp.asarray([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]], u.dtype)
    return signs[:, :1] * (hw * u)[None, :] + signs[:, 1:] * (hh * v)[None, :]


def _clip(e: Array, h: Array) -> tuple[Array, Array, Array, Array]:
    """The edges of the polygon `e` (offsets, (4, 3)) clipped to `h >= 0` (heights above the
    receiver's plane): each edge's part above the plane, then the plane's own edge, from where
    the contour leaves the hemisphere to where it comes back (a convex polygon crosses a plane
    at most twice). (starts (5, 3), ends (5, 3), which edges there are, whether any is.)"""
    inside = h >= 0
    nxt = jnp.array([1, 2, 3, 0])
    cross = inside != inside[nxt]
    dh = h - h[nxt]
    t = h / jnp.where(cross, dh, jnp.ones_like(dh))
    cut = e + t[:, None] * (e[nxt] - e)
    leave, back = inside & ~inside[nxt], ~inside & inside[nxt]
    zero = jnp.zeros_like(cut)
    horizon = [jnp.sum(jnp.where(x[:, None], cut, zero), axis=0) for x in (leave, back)]
    starts = jnp.concatenate([jnp.where(inside[:, None], e, cut), horizon[0][None]])
    ends = jnp.concatenate([jnp.where(inside[nxt][:, None], e[nxt], cut), horizon[1][None]])
    there = jnp.concatenate([inside | inside[nxt], jnp.any(leave)[None]])
    return starts, ends, there, jnp.any(inside)


def rect_irradiance_one(
    c: Array, m: Array, u: Array, hw: Array, hh: Array, L: Array, p: Array, n: Array
) -> Array:
    """Exact irradiance of the rectangle (centre `c`, normal `m`, tangent `u`, half sizes
    `hw`, `hh`, radiance `L`) at one receiver `p` with unit normal `n` (module docstring)."""
    v = jnp.cross(m, u)
    e = _offsets(u, v, hw, hh)
    q = c - p
    front = -_dot(m, q) > 0
    h = _dot(n, q) + e @ n
    w, w2, edge, lit = _clip(e, h)
    # every edge's a_i x a_j and a_i . a_j from the offsets (module docstring)
    cr = jnp.cross(q[None, :], w2 - w) + jnp.cross(w, w2)
    s = _safe_norm(cr)
    q2 = _dot(q, q)
    dq = -(w @ q + w2 @ q + _dot(w, w2))  # |q|^2 - a_i . a_j
    dot_ab = q2 - dq
    pos = dot_ab > 0
    c_safe = jnp.where(pos, dot_ab, jnp.ones_like(dot_ab))
    x = s / c_safe
    # G - 1/|q|^2 where a_i . a_j > 0: (1/c - 1/|q|^2) + (atan(x)/x - 1)/c
    g_pos = (dq / c_safe) / q2 - _one_minus_atan_ratio(x) / c_safe  # no c q^2: float32 overflows
    s_safe = jnp.where(s > 0, s, jnp.ones_like(s))
    g_neg = jnp.where(s > 0, jnp.arctan2(s, dot_ab) / s_safe, jnp.zeros_like(s)) - 1 / q2
    dg = jnp.where(pos, g_pos, g_neg)
    area2 = jnp.cross(w, w2)  # sum: twice the clipped polygon's vector area
    far_terms = (cr @ n) * dg + (area2 @ n) / q2
    # near the light the split's two parts are large and cancel: the plain sum is exact there
    near_terms = (cr @ n) * jnp.where(s > 0, jnp.arctan2(s, dot_ab) / s_safe, 0 * s)
    far = q2 > _FAR * (hw * hw + hh * hh)
    terms = jnp.where(edge, jnp.where(far, far_terms, near_terms), jnp.zeros_like(s))
    E = L / 2 * jnp.maximum(-jnp.sum(terms), 0)
    return jnp.where(front & lit, E, jnp.zeros_like(E))


def rect_kernel(emitter: RectEmitter, dtype: Any) -> Any:
    """`(p, n) -> E` for one receiver of `emitter`, in `dtype`."""

    def cast(x):
        return jnp.asarray(x).astype(dtype)

    c, m, u = cast(emitter.center), cast(emitter.normal), cast(emitter.tangent)
    hw, hh = cast(emitter.width) / 2, cast(emitter.height) / 2
    L = cast(emitter.intensity) / (cast(emitter.width) * cast(emitter.height))
    return jax.tree_util.Partial(rect_irradiance_one, c, m, u, hw, hh, L)
