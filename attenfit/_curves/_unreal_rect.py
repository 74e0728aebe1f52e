"""Unreal Engine 4's Rect Light diffuse term as an area model (`unreal_rect`).

Unreal 4.2x `Engine/Shaders/Private/RectLight.ush`, `RectIrradianceLambert` (the
"Optimized Lambert" path; read in the copies stored at folgerwang/UnrealEngine
@480e23424155 and chenyong2github/UnrealEngine, Epic's Copyright 1998-2019 header):

* the corners of the rectangle seen from the receiver, normalised, `L0..L3`, and the cosines
  `c_ij = L_i.L_j` of its four edges;
* each edge's weight `w_ij = (1.5708 - 0.175 c_ij) rsqrt(c_ij + 1)`, a fit of
  `theta / sin(theta)` (`acos(x) ~ sqrt(1 - x) (1.5708 - 0.175 x)`), so that
  `F = sum w_ij (L_i x L_j) ~ sum theta_ij g_ij`: twice the unclipped rectangle's vector
  irradiance per unit radiance (Lambert's edges, Heitz et al. 2016 eq. 11);
* `BaseIrradiance = |F| / 2`, the mean light direction `F / |F|`, and the horizon handled
  as the sphere of the same solid angle (`SinAlphaSqr = BaseIrradiance / pi`) through
  `SphereHorizonCosWrap(dot(N, F / |F|), SinAlphaSqr)` (`Engine/Shaders/Private/
  CapsuleLight.ush`: below `sin(alpha)` the cosine becomes the Hermite spline
  `(sin(alpha) + max(cos, -sin(alpha)))^2 / (4 sin(alpha))`);
* the diffuse irradiance per unit radiance `BaseIrradiance * NoL`
  (`CapsuleLightIntegrate.ush` / `ShadingModels.ush` `IntegrateBxDF`: `Falloff * NoL`);
* receivers behind the rectangle's plane get nothing (`DeferredLightingCommon.ush`
  `GetLocalLightAttenuation`: "Rect normal points away from point").

The model is `E / I` with `I = 4 hw hh L` (`_rect_models`' convention); Unreal's own
scaling of a Rect Light's intensity to its radiance (`FRectLightSceneProxy::
GetLightShaderParameters`: `Color / (0.5 SourceWidth SourceHeight)`) is the engine
witness's (`attenfit._judge._area_shading`), not the model's.

Unreal takes the corners in its light's axes (`Axis[0] = Tangent x Direction`), so that
`F` points toward the light; here the corners go clockwise seen from the lit side, which
does the same.
"""

from __future__ import annotations

import math
from typing import Any

from ._area import register_area_model
from ._rect_models import RectModel, corners, frame_cross, frame_dot

__all__ = ["UnrealRect", "sphere_horizon_cos_wrap"]

#: Clockwise seen from the lit side (the corners' order in `_rect_models`' exact form).
_ORDER = ((-1, -1), (-1, 1), (1, 1), (1, -1))


def sphere_horizon_cos_wrap(bk: Any, cos_b: Any, sin_a: Any) -> Any:
    """Unreal's `SphereHorizonCosWrap(NoL, SinAlphaSqr)` with `sin_a = sqrt(SinAlphaSqr)`
    (CapsuleLight.ush): `NoL` where `NoL >= sin_a`, else the Hermite spline
    `(sin_a + max(NoL, -sin_a))^2 / (4 sin_a)`."""
    s = bk.let("wrap_s", sin_a + bk.max(cos_b, -sin_a))
    return bk.select(cos_b < sin_a, s * s / (4.0 * bk.nonzero(sin_a)), cos_b)


def _unit(bk: Any, v: Any, tag: str) -> tuple[Any, Any, Any]:
    inv = bk.let(f"{tag}_inv", 1.0 / bk.nonzero(bk.sqrt(frame_dot(v, v))))
    return tuple(bk.let(f"{tag}_{c}", e * inv) for c, e in zip("xyz", v, strict=True))  # type: ignore[return-value]


def _unreal_rect(bk: Any, x: dict[str, Any], hw: Any, hh: Any) -> Any:
    p = (x["x"], x["y"], x["z"])
    n = (x["nx"], x["ny"], x["nz"])
    L = [_unit(bk, c, f"l{i}") for i, c in enumerate(corners(hw, hh, p, _ORDER))]
    f: Any = (0.0, 0.0, 0.0)
    for i in range(4):
        a, b = L[i], L[(i + 1) % 4]
        c = bk.let(f"c{i}", frame_dot(a, b))
        w = bk.let(f"w{i}", (1.5708 - 0.175 * c) / bk.nonzero(bk.sqrt(c + 1.0)))
        f = tuple(s + w * t for s, t in zip(f, frame_cross(a, b), strict=True))
    f = tuple(bk.let(f"f_{c}", e) for c, e in zip("xyz", f, strict=True))
    length = bk.let("f_len", bk.sqrt(frame_dot(f, f)))
    base = bk.let("base", 0.5 * length)  # BaseIrradiance
    sin_a = bk.let("sin_a", bk.sqrt(base * (1.0 / math.pi)))
    cos_b = bk.let("cos_b", frame_dot(n, f) / bk.nonzero(length))
    e = base * sphere_horizon_cos_wrap(bk, cos_b, sin_a)
    return bk.select(x["z"] > 0.0, e, 0.0) / (4.0 * hw * hh)


@register_area_model
class UnrealRect(RectModel):
    """Unreal 4's Rect Light diffuse: the unclipped rectangle's vector form factor by the
    `(1.5708 - 0.175 c) rsqrt(c + 1)` fit of `theta / sin(theta)`, its horizon through
    `SphereHorizonCosWrap` (the module docstring)."""

    name = "unreal_rect"
    default_free = ()
    formula = (
        "|F|/2 SphereHorizonCosWrap(n.F/|F|, |F|/(2 pi)) / (4 hw hh), F = sum of "
        "(1.5708 - 0.175 c) rsqrt(c + 1) L_i x L_j over the corners"
    )
    source = (
        "Unreal 4 Engine/Shaders/Private/RectLight.ush RectIrradianceLambert; CapsuleLight.ush "
        "SphereHorizonCosWrap; DeferredLightingCommon.ush GetLocalLightAttenuation (one-sided)"
    )
    exact = "nowhere (its acos fit is 1.3% low on a short edge; the horizon is a sphere's)"
    build = staticmethod(_unreal_rect)
    form_source = "Unreal 4 RectLight.ush RectIrradianceLambert (the Optimized Lambert path)"
    form_engine = True
    form_note = "the receiver's frame is the light's (Unreal takes LocalPosition in its axes)"
