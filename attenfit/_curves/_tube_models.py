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

import jax.numpy as jnp

from .._ir import Expr, Lets, Ref
from ._area import TUBE_INPUTS, AreaModel, register_area_model
from ._forms import area_shader
from ._rect_models import FRAME_FORM_INPUTS, Ir, Jax, frame_dot, solid_angle_cosines

__all__ = ["FrostbiteTube", "KarisTube", "TubeModel"]


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


class TubeModel(AreaModel):
    """An area model of a tube (abstract): it reads `TUBE_INPUTS`, and its shader form the
    receiver in the tube's frame and the parameters `half_length`, `radius`. Subclasses
    write their form once for both back ends (`_rect_models.Jax`, `Ir`)."""

    input_names = TUBE_INPUTS
    inputs = len(TUBE_INPUTS)
    form_inputs = FRAME_FORM_INPUTS
    form_sizes: ClassVar[dict[str, str]] = {"half_length": "hl", "radius": "r"}
    light = "tube"


def _jax_inputs(x: tuple[Any, ...]) -> dict[str, Any]:
    return dict(zip(FRAME_FORM_INPUTS, x, strict=True))


@register_area_model
class KarisTube(TubeModel):
    """The tube as a line: Karis 2013's closed-form line integral of `n.L / |L|^3` (the
    module docstring)."""

    name = "karis_tube"
    default_free = ()
    formula = "4 hl max(0, (n.L0/|L0| + n.L1/|L1|) / (|L0| |L1| + L0.L1)) / (pi r)"
    source = "Karis 2013, Real Shading in Unreal Engine 4 (SIGGRAPH course notes), tube lights"
    exact = "nowhere (an isotropic line: the truth's side fades as sin psi toward the axis)"

    def irradiance(self, x, y, z, nx, ny, nz, hl, r):
        return _karis(Jax, _jax_inputs((x, y, z, nx, ny, nz)), hl, r)

    @area_shader("Karis 2013 (tube light irradiance, the line integral)", engine=False)
    def shader_form(self, let: Lets, x: dict[str, Ref], p: dict[str, Ref]) -> Expr:
        return _karis(Ir(let), x, p["half_length"], p["radius"])


@register_area_model
class FrostbiteTube(TubeModel):
    """Frostbite's tube: a rectangle facing the receiver plus a sphere at the segment's
    closest point (the module docstring)."""

    name = "frostbite_tube"
    default_free = ()
    formula = "(Omega_rect mean cos_5 + pi max(0, n.l_s) r^2 / d_s^2) / (pi r^2)"
    source = "Lagarde & de Rousiers 2014, Moving Frostbite to PBR, §4.7.4 (tube light)"
    exact = "nowhere"

    def irradiance(self, x, y, z, nx, ny, nz, hl, r):
        out = _frostbite(Jax, _jax_inputs((x, y, z, nx, ny, nz)), hl, r)
        return jnp.where(jnp.isfinite(out), out, jnp.zeros_like(out))

    @area_shader(
        "Lagarde & de Rousiers 2014 §4.7.4, the tube light's illuminance listing",
        engine=True,
        note="no guard on the axis (forward = normalize(0))",
    )
    def shader_form(self, let: Lets, x: dict[str, Ref], p: dict[str, Ref]) -> Expr:
        return _frostbite(Ir(let), x, p["half_length"], p["radius"])
