"""UsdLux rectangle and cylinder lights as attenfit's rectangle and tube emitters.

UsdLux (https://openusd.org/release/api/usd_lux_page_front.html):

* `RectLight`: "Light emitted from one side of a rectangle. The rectangle is centered in the
  XY plane and emits light along the -Z axis. The rectangle is 1 unit in length in the X and
  Y axis" before `inputs:width` (X) and `inputs:height` (Y) scale it: attenfit's one-sided
  `RectEmitter` (kind "rect"), normal the light's -Z, width along its X. Blender writes its
  square and rectangle area lights so (`source/blender/io/usd/intern/usd_writer_light.cc`,
  `USDLightWriter::do_write`: `LA_AREA_SQUARE`, `LA_AREA_RECT` -> `UsdLuxRectLight` of width
  `area_size` and height `area_size` or `area_sizey`).
* `CylinderLight`: "Light emitted outward from a cylinder. The cylinder is centered at the
  origin and has its major axis on the X axis. The cylinder does not emit light from the flat
  end-caps": attenfit's `TubeEmitter` without caps (kind "tube"), of `inputs:length` and
  `inputs:radius`.

Intensity as for sphere and disk lights (`_usd`): the radiance is `inputs:intensity x
2^inputs:exposure x inputs:diffuse`, divided by the emitting area with `inputs:normalize`
(the rectangle's `w h`; the cylinder's side, `2 pi r l`, UsdLux: "the light's surface
area"), and the point-equivalent intensity the emitters take is the radiance times `w h`
(rectangle: its intensity along the normal) or `pi r^2` (tube: attenfit's convention
`L = I / (pi r^2)`).

Refused with a reason (skipped with a notice unless `--strict`, like the light types
attenfit does not model): a `ShapingAPI` cone narrower than the hemisphere or a
`shaping:focus` (a rectangle whose emission is not Lambertian), a transform that shears the
rectangle or makes the cylinder's cross-section an ellipse.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from .._errors import AttenfitError, BadValueError
from ._types import SceneLight
from ._usd_attrs import shaped

__all__ = ["AREA_TYPES", "area_light"]

#: The UsdLux types read here.
AREA_TYPES = ("RectLight", "CylinderLight")


class NotModelled(BadValueError):
    """A light of a type attenfit reads whose settings it does not model (skipped unless strict)."""


def _axes(m: np.ndarray, mpu: float, where: str) -> tuple[np.ndarray, np.ndarray, float]:
    """The world transform's translation (m), its three axes (rows) and their lengths (m)."""
    if not np.all(np.isfinite(m)) or not all(math.isfinite(float(x) * mpu) for x in m[3, :3]):
        raise BadValueError(f"{where}: its world transform is not finite")
    raw = np.linalg.norm(m[:3, :3], axis=1)
    if not np.all(raw > 0):
        raise BadValueError(f"{where}: its world transform is singular")
    return m[3, :3] * mpu, m[:3, :3] / raw[:, None], raw * mpu


def _intensity(prim, UsdLux, readers, where: str, area: float, lit: float) -> float:
    """The point-equivalent intensity: radiance x `lit` (the radiance over `area` if
    normalised), times `inputs:diffuse`."""
    number, flag, diffuse = readers
    lux = UsdLux.LightAPI(prim)
    intensity = number(lux.GetIntensityAttr(), 1.0, where)
    exposure = number(lux.GetExposureAttr(), 0.0, where)
    if not intensity > 0:
        raise BadValueError(f"{where}: intensity {intensity:g} is not positive (a dark light)")
    log2 = math.log2(intensity) + exposure + math.log2(lit * diffuse(where))
    log2 -= math.log2(area) if flag(lux.GetNormalizeAttr(), where) else 0.0
    if not -1000 < log2 < 1000:
        raise BadValueError(
            f"{where}: inputs:intensity {intensity:g} x 2^inputs:exposure ({exposure:g}) gives "
            f"a point-equivalent intensity of 2^{log2:.5g}, outside the float range"
        )
    return 2.0**log2


def _check_sizes(where: str, sizes: dict[str, float]) -> None:
    """Refuse sizes (m, after the transform's scale) that are not positive or whose products
    (areas, squares) are not normal floats."""
    a, b = sizes.values()
    if not (a > 0 and b > 0 and math.isfinite(a * b) and min(a * b, b * b) >= sys.float_info.min):
        shown = ", ".join(f"{k} {v:g} m" for k, v in sizes.items())
        names = ", ".join(f"inputs:{k}" for k in sizes)
        raise BadValueError(
            f"{where}: {shown} ({names} x scale): must be positive, with an area and squares "
            "that are normal floats"
        )


def _check_shaping(prim, UsdLux, number: Callable, where: str) -> None:
    if not shaped(prim):  # the API applied, or a shaping input authored without it
        return
    shaping = UsdLux.ShapingAPI(prim)
    angle = number(shaping.GetShapingConeAngleAttr(), 90.0, where)
    focus = number(shaping.GetShapingFocusAttr(), 0.0, where)
    if angle < 90 or focus != 0:
        raise NotModelled(
            f"{where}: shaping (cone angle {angle:g} deg, focus {focus:g}) makes its emission "
            "other than Lambertian; attenfit models a rectangle or tube light as Lambertian "
            "(a cone of 90 deg or more and no focus)"
        )


def _rect(prim, m, mpu, where, UsdLux, readers) -> tuple[dict[str, Any], str]:
    number = readers[0]
    api = UsdLux.RectLight(prim)
    w_local = number(api.GetWidthAttr(), 1.0, where)
    h_local = number(api.GetHeightAttr(), 1.0, where)
    centre, axes, s = _axes(m, mpu, where)
    if abs(float(axes[0] @ axes[1])) > 1e-6:
        raise NotModelled(f"{where}: its transform shears it (not a rectangle)")
    w, h = w_local * float(s[0]), h_local * float(s[1])
    _check_sizes(where, {"width": w, "height": h})
    _check_shaping(prim, UsdLux, number, where)
    normal = -np.cross(axes[0], axes[1])  # -Z, as the X and Y axes see it (mirrors included)
    kw = dict(
        kind="rect",
        radius=math.sqrt(w * h / math.pi),
        size=(w, h),
        normal=tuple(float(x) for x in normal / np.linalg.norm(normal)),
        tangent=tuple(float(x) for x in axes[0]),
        intensity=_intensity(prim, UsdLux, readers, where, w * h, w * h),
        position=tuple(float(x) for x in centre),
    )
    return kw, "RectLight"


def _cylinder(prim, m, mpu, where, UsdLux, readers) -> tuple[dict[str, Any], str]:
    number = readers[0]
    api = UsdLux.CylinderLight(prim)
    l_local = number(api.GetLengthAttr(), 1.0, where)
    r_local = number(api.GetRadiusAttr(), 0.5, where)
    centre, axes, s = _axes(m, mpu, where)
    if abs(float(s[1] - s[2])) > 1e-6 * float(s[1]) or abs(float(axes[1] @ axes[2])) > 1e-6:
        raise NotModelled(
            f"{where}: its transform scales Y and Z differently ({s[1]:g}, {s[2]:g} m): an "
            "elliptic cylinder, not a tube"
        )
    if abs(float(axes[0] @ axes[1])) > 1e-6 or abs(float(axes[0] @ axes[2])) > 1e-6:
        raise NotModelled(f"{where}: its transform shears it (not a right cylinder)")
    length, radius = l_local * float(s[0]), r_local * float(s[1])
    _check_sizes(where, {"length": length, "radius": radius})
    side = 2 * math.pi * radius * length
    kw = dict(
        kind="tube",
        radius=radius,
        length=length,
        axis=tuple(float(x) for x in axes[0]),
        intensity=_intensity(prim, UsdLux, readers, where, side, math.pi * radius**2),
        position=tuple(float(x) for x in centre),
    )
    return kw, "CylinderLight"


def area_light(
    prim, type_name: str, m: np.ndarray, mpu: float, where: str, UsdLux, readers, strict, notice
) -> list[tuple[SceneLight, str]]:
    """The `SceneLight` of a `RectLight` or `CylinderLight` prim with world transform `m` (row
    vectors) and `metersPerUnit` `mpu`, and the kind to report; none, with a notice, for
    settings attenfit does not model (the module docstring; refused when `strict`).
    `readers` are `_usd`'s `number(attr, default, where)`, `flag(attr, where)` and
    `diffuse(where)` (`inputs:diffuse`, a factor on the intensity)."""
    read = _rect if type_name == "RectLight" else _cylinder
    try:
        kw, kind = read(prim, m, mpu, where, UsdLux, readers)
    except NotModelled as exc:
        if strict:
            raise BadValueError(f"{exc}; --strict refuses it") from None
        notice(f"{exc}; skipped")
        return []
    light = SceneLight(**kw)
    try:
        light.emitter()  # the emitter's own checks
    except AttenfitError as exc:
        raise type(exc)(f"{where}: {exc}") from None
    return [(light, kind)]
