"""Area-light models of a Lambertian tube (a cylinder's side): the forms the engines ship.

Each reads the receiver in the tube's frame (`TUBE_INPUTS`: its centre the origin, x along
its axis; point x, y, z, unit normal nx, ny, nz, the half length `hl` and the radius `r`) and
returns `E / I`, `I = pi r^2 L` (`attenfit.TubeEmitter`: the intensity of an end disk seen
along the axis; broadside the side's intensity is `I 2 l / (pi r)`, `l = 2 hl`).

* `KarisTube`: the tube as a line (Karis 2013, "Real Shading in Unreal Engine 4", SIGGRAPH
  course notes, the tube light's irradiance): `int_0^1 n.L(t) / |L(t)|^3 dt =
  (n.L0/|L0| + n.L1/|L1|) / (|L0| |L1| + L0.L1)`, `L0`, `L1` from the receiver to the
  segment's ends, clamped at 0; the line's intensity per unit length is the side's broadside
  one, `2 r L` (an isotropic line: it does not fade toward the axis as the side does).
* `FrostbiteTube`: Frostbite's tube (Lagarde & de Rousiers 2014, "Moving Frostbite to PBR",
  §4.7.4, the tube light's illuminance listing): a rectangle `2 hl` by `2 r` through the
  axis, turned to face the receiver, shaded as Frostbite's rectangle (`solid_angle_cosines`:
  solid angle times the mean clamped cosine of its corners and centre), plus a sphere of
  radius `r` at the segment's closest point (its two end caps together),
  `pi saturate(n.l) r^2 / d^2`.

The point-light model of a tube is `PointLight(family)` with `AREA_INPUTS` (`g` the side's
projected-area factor, `attenfit.area_inputs`).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from ._area import TUBE_INPUTS, register_area_model
from ._rect_models import FrameModel, frame_dot, solid_angle_cosines

__all__ = ["FrostbiteTube", "KarisTube", "LambertLine", "TubeModel"]


def _frame(x: dict[str, Any]) -> tuple[tuple[Any, Any, Any], tuple[Any, Any, Any]]:
    return (x["x"], x["y"], x["z"]), (x["nx"], x["ny"], x["nz"])


def _karis(bk: Any, x: dict[str, Any], hl: Any, r: Any) -> Any:
    p, n = _frame(x)
    l0 = (-hl - p[0], -p[1], -p[2])
    l1 = (hl - p[0], -p[1], -p[2])
    d0 = bk.let("len0", bk.sqrt(frame_dot(l0, l0)))
    d1 = bk.let("len1", bk.sqrt(frame_dot(l1, l1)))
    num = frame_dot(n, l0) / bk.nonzero(d0) + frame_dot(n, l1) / bk.nonzero(d1)
    den = d0 * d1 + frame_dot(l0, l1)
    k = bk.max(num / bk.select(den > 0.0, den, 1.0), 0.0)
    # E = (2 r L) (2 hl) k; over I = pi r^2 L
    return bk.select(den > 0.0, 4.0 * hl * k / (math.pi * r), 0.0)


def _frostbite(bk: Any, x: dict[str, Any], hl: Any, r: Any) -> Any:
    p, n = _frame(x)
    rho = bk.let("rho", bk.sqrt(p[1] * p[1] + p[2] * p[2]))
    inv = 1.0 / bk.nonzero(rho)
    fy, fz = bk.let("fwd_y", -p[1] * inv), bk.let("fwd_z", -p[2] * inv)  # to the axis
    uy, uz = -fz, fy  # up = cross(left, forward), left = +x
    q = [
        (sx * hl - p[0], su * r * uy - p[1], su * r * uz - p[2])
        for sx, su in ((-1, 1), (-1, -1), (1, -1), (1, 1))
    ]
    rect = solid_angle_cosines(bk, q, (-p[0], -p[1], -p[2]), n)
    cx = bk.min(bk.max(p[0], -hl), hl)  # closestPointOnSegment
    s = (cx - p[0], -p[1], -p[2])
    d2 = bk.let("sphere_d2", frame_dot(s, s))
    cos_s = frame_dot(s, n) / bk.nonzero(bk.sqrt(d2))
    sphere = math.pi * bk.min(bk.max(cos_s, 0.0), 1.0) * (r * r / bk.nonzero(d2))
    return (rect + sphere) / (math.pi * r * r)


def _lambert_line(bk: Any, x: dict[str, Any], hl: Any, r: Any) -> Any:
    p, n = _frame(x)
    rho2 = p[1] * p[1] + p[2] * p[2]
    rho = bk.let("rho", bk.max(bk.sqrt(rho2), r))  # a receiver nearer the axis: at contact
    a = bk.let("a", -(n[1] * p[1] + n[2] * p[2]))  # n.L = a + b u, u = s - x along the axis
    b = n[0]
    u0, u1 = -hl - p[0], hl - p[0]
    bs = bk.select(b > 0.0, b, bk.select(b < 0.0, b, 1.0))
    root = bk.let("u_h", -a / bs)  # where the line crosses the receiver's horizon
    lo = bk.let("u_lo", bk.select(b > 0.0, bk.max(u0, root), u0))
    hi = bk.let("u_hi", bk.select(b < 0.0, bk.min(u1, root), u1))
    lit = bk.select(b > 0.0, 1.0, bk.select(b < 0.0, 1.0, bk.select(a > 0.0, 1.0, 0.0)))
    hi = bk.let("u_hi2", bk.max(hi, lo))

    def prim(u: Any, tag: str) -> Any:  # rho^3 int (a + b u) / (rho^2 + u^2)^2 du
        q = bk.let(f"{tag}q", 1.0 / (rho * rho + u * u))
        return a * (bk.atan2(u, rho) + u * rho * q) * 0.5 - b * rho * rho * rho * q * 0.5

    j = prim(hi, "hi_") - prim(lo, "lo_")
    # E = 2 r L rho int (a + b u) / |L|^4 du; over I = pi r^2 L
    return bk.max(lit * 2.0 * j / (math.pi * r * rho * rho), 0.0)


class TubeModel(FrameModel):
    """An area model of a tube (abstract): it reads `TUBE_INPUTS`, and its shader form the
    receiver in the tube's frame and the parameters `half_length`, `radius`."""

    input_names = TUBE_INPUTS
    inputs = len(TUBE_INPUTS)
    form_sizes: ClassVar[dict[str, str]] = {"half_length": "hl", "radius": "r"}
    output_text: ClassVar[str] = (
        "E / I in 1/length^2 (I: the tube's point-equivalent intensity, an end disk's along "
        "its axis, I = pi r^2 L, r the tube's radius; attenfit.TubeEmitter)"
    )
    light = "tube"


@register_area_model
class KarisTube(TubeModel):
    """The tube as a line: Karis 2013's closed-form line integral of `n.L / |L|^3` (the
    module docstring)."""

    name = "karis_tube"
    default_free = ()
    formula = "4 hl max(0, (n.L0/|L0| + n.L1/|L1|) / (|L0| |L1| + L0.L1)) / (pi r)"
    source = "Karis 2013, Real Shading in Unreal Engine 4 (SIGGRAPH course notes), tube lights"
    exact = "nowhere (an isotropic line: the truth's side fades as sin psi toward the axis)"
    build = staticmethod(_karis)
    form_source = "Karis 2013 (tube light irradiance, the line integral)"
    form_engine = False


@register_area_model
class FrostbiteTube(TubeModel):
    """Frostbite's tube: a rectangle facing the receiver plus a sphere at the segment's
    closest point (the module docstring)."""

    name = "frostbite_tube"
    default_free = ()
    formula = "(Omega_rect mean cos_5 + pi max(0, n.l_s) r^2 / d_s^2) / (pi r^2)"
    source = "Lagarde & de Rousiers 2014, Moving Frostbite to PBR, §4.7.4 (tube light)"
    exact = "nowhere"
    build = staticmethod(_frostbite)
    form_source = "Lagarde & de Rousiers 2014 §4.7.4, the tube light's illuminance listing"
    form_engine = True
    form_note = "no guard on the axis (forward = normalize(0))"


@register_area_model
class LambertLine(TubeModel):
    """The tube's side as a Lambertian line: each length element `ds` of the side has the
    intensity `2 r L sin(psi)` (its projected area; `TubeEmitter`'s `g` per unit length), so
    `E = 2 r L rho int max(0, n.L) / |L|^4 ds` (`rho` the receiver's distance from the axis),
    elementary with the horizon clipped (`u = rho tan(theta)`: `rho^3 int (a + b u) /
    (rho^2 + u^2)^2 du = a (theta + sin theta cos theta) / 2 - b rho cos^2 theta / 2`).
    Exact in the tube's far field and wherever its radius is small against the distance
    (it omits the side's self-occlusion across its width and the caps)."""

    name = "lambert_line"
    default_free = ()
    formula = "2 rho / (pi r) int max(0, n.L) / |L|^4 du over the axis, in closed form"
    source = (
        "Lambert's cosine law for the side's elements (TubeEmitter's projected area per unit "
        "length); the integral derived here (elementary), tested against quadrature"
    )
    exact = "as the tube's radius over the distance tends to 0 (a thin tube)"
    build = staticmethod(_lambert_line)
    form_source = "the Lambertian line's closed form (LambertLine's docstring)"
    form_engine = False
