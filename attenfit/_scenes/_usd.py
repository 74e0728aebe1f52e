"""USD scenes (`.usd`, `.usda`, `.usdc`) read with Pixar's `usd-core` (`pxr`): lights and meshes
in world space, lengths in metres.

Lights (UsdLux, https://openusd.org/release/api/usd_lux_page_front.html):

* `SphereLight`: a sphere of `inputs:radius` (attenfit kind "sphere"); `treatAsPoint` asks a
  renderer for a point: attenfit then needs a radius from `--radius` or the side file.
* `DiskLight`: a disk of `inputs:radius` in its local XY plane, emitting along -Z
  (UsdLux DiskLight: "The disk is centered in the XY plane and emits light along the -Z
  axis"); kind "disk".
* Either with `ShapingAPI` and `shaping:cone:angle` < 180 is a spot (kind "spot", shape
  sphere or disk): umbra = the cone angle (UsdLux: "angular limit off the primary axis"),
  and the penumbra from `shaping:cone:softness` as Blender writes and reads it
  (`io/usd/intern/usd_writer_light.cc` writes `spot_size / 2` as the angle and `spot_blend`
  as the softness; EEVEE `lamps_lib.glsl::spot_attenuation`, with `l_spot_size = cos(angle)`
  and `l_spot_blend = (1 - cos(angle)) blend` from `eevee_lights.c`, ramps smoothstep over
  `cos` from `cos(angle)` to `cos(angle) + (1 - cos(angle)) * blend`): penumbra =
  `acos(cos u + (1 - cos u) softness)`, profile "threejs" (smoothstep in cos).
* `RectLight` and `CylinderLight`: a one-sided rectangle and a tube (kinds "rect", "tube";
  `_usd_area`).
* Dome, distant, geometry and portal lights are not modelled: skipped with a notice, or
  refused with `strict`. So is a light whose `inputs:shaping:focus` is not 0
  (usdLux/schema.usda: "Implemented as an off-axis cosine power exponent. TODO: clarify
  semantics", no formula to model) or whose `inputs:shaping:ies:file` names a file.

Intensity: the radiance is `inputs:intensity * 2^inputs:exposure` (UsdLux LightAPI); with
`inputs:normalize` it is divided by the light's area (sphere 4 pi r^2, disk pi r^2). It is
multiplied by `inputs:diffuse` (UsdLux LightAPI, default 1: "A multiplier for the effect of
this light on the diffuse response of materials"; attenfit judges diffuse irradiance); a
light of `inputs:diffuse` 0 lights no diffuse surface: skipped with a notice (refused with
`strict`), and a negative one refused. The
point-equivalent intensity attenfit takes is radiance x pi r^2 (a sphere's in every
direction, a disk's along its axis). Colour and colour temperature are left out: they scale
the truth and every curve alike (only `--threshold` compares absolute values, in the file's
intensity units per m^2).

Names and times (`_usd_attrs`): a light input authored only under its pre-2021 name
(`radius`, `intensity`, `exposure`, `normalize`, `shaping:cone:angle`...) is read, with a
notice; every attribute is read at `time`, or (None) at the default time, or the stage's
start time code for a value authored only as time samples (transforms too, op by op).

Prims: the stage's default traversal with instance proxies (instanced meshes count), less
invisible prims (`visibility` inherited: an invisible ancestor hides it) and `guide` or
`proxy` purposes: a light so hidden is skipped with a notice; a mesh is sampled as its
control cage (`_usd_mesh`; Blender writes `subdivisionScheme = "none"`).

Transforms: the world transform of each prim (its xformOps composed as
`UsdGeomXformable::GetLocalTransformation` composes them, `_usd_attrs.world_matrix`) times
the stage's `metersPerUnit`; a light whose transform scales non-uniformly (its radius would
not be a radius) is refused.
"""

from __future__ import annotations

import math
import os
import sys
from collections.abc import Callable
from typing import Any

import numpy as np

from .._errors import AttenfitError, BadTypeError, BadValueError, DataFileError
from ._sample import Mesh
from ._types import SceneLight
from ._usd_area import AREA_TYPES, area_light
from ._usd_attrs import (
    UsdTime,
    check_time,
    light_input,
    prim_errors,
    shaped,
    show,
    world_matrix,
)
from ._usd_layers import MAX_PRIMS, USD_SUFFIXES, UsdLayers, pxr_error, usd_diagnostics, usd_layers
from ._usd_mesh import check_mesh_memory, read_mesh

__all__ = ["USD_SUFFIXES", "UsdLight", "read_usd"]

_UNSUPPORTED = ("DomeLight", "DistantLight", "GeometryLight", "PortalLight")


def _pxr():
    from pxr import Usd, UsdGeom, UsdLux

    return Usd, UsdGeom, UsdLux


def _scales(m: np.ndarray) -> np.ndarray:
    """The lengths of the transformed unit axes (row-vector matrices: rows 0..2)."""
    return np.linalg.norm(m[:3, :3], axis=1)


class UsdLight:
    """A light read from a file: the `SceneLight` and where it came from."""

    def __init__(
        self,
        name: str,
        light: SceneLight,
        kind: str,
        published_range: float | None,
        ref: str | int | None = None,
    ):
        self.name = name
        self.light = light
        self.kind = kind  # the file's type: SphereLight, DiskLight, point, spot
        self.published_range = published_range
        self.ref = name if ref is None else ref  # USD prim path; glTF light index


def read_usd(
    path: str | os.PathLike,
    label: str,
    *,
    radius_for: Callable[[str], float | None],
    strict: bool,
    notice: Callable[[str], None],
    time: float | None = None,
) -> tuple[list[UsdLight], list[Mesh]]:
    """The lights and meshes of the USD file `path` (`label` names it in messages).

    Every layer the scene names is found and checked first (`_usd_layers.usd_layers`), so
    usd-core composes only files inside the scene's folder. `radius_for(name)` gives a
    radius from the options for a light that has none (`treatAsPoint`); `notice` receives
    one line per skipped prim, and one per warning of usd-core's (kept off standard error).
    `time`: the time code every attribute is read at; None, each attribute's default value,
    or its value at the stage's start time code when it has only time samples
    (`_usd_attrs.UsdTime`).
    """
    time = check_time(time)
    with usd_diagnostics() as warned:
        lights, meshes = _read(path, label, radius_for, strict, notice, time)
    for text in warned:
        notice(f"{label}: usd-core: {text}")
    return lights, meshes


def _read(path, label, radius_for, strict, notice, time) -> tuple[list[UsdLight], list[Mesh]]:
    Usd, UsdGeom, _ = _pxr()
    layers = usd_layers(path, label)
    stage = _open_stage(layers, label, Usd)
    mpu = _meters_per_unit(stage, label, UsdGeom)
    when = UsdTime(time, float(stage.GetStartTimeCode()))
    cache: dict[str, Any] = {}
    found = _found(stage, label, when, notice)
    check_mesh_memory([p for p, t in found if t == "Mesh"], layers, label, when)
    lights: list[UsdLight] = []
    meshes: list[Mesh] = []
    for prim, type_name in found:
        name = str(prim.GetPath())
        where = f"{label}: {type_name} {name}"
        with prim_errors(where):
            reason = None if type_name == "Mesh" else _not_modelled(prim, type_name, when, where)
        if reason is not None:
            if strict:
                raise BadValueError(f"{where}: {reason}; --strict refuses it")
            notice(f"{where}: {reason}; skipped")
            continue
        with prim_errors(where):
            if type_name in ("SphereLight", "DiskLight"):
                m = world_matrix(prim, when, cache)
                lights.append(_light(prim, type_name, m, mpu, where, radius_for, when, notice))
            elif type_name in AREA_TYPES:  # `_usd_area`
                m, read = world_matrix(prim, when, cache), _readers(prim, when)
                got = area_light(prim, type_name, m, mpu, where, _pxr()[2], read, strict, notice)
                lights.extend(UsdLight(name, light, kind, None) for light, kind in got)
            else:
                with np.errstate(over="ignore", invalid="ignore"):
                    meshes.append(read_mesh(prim, when, cache, mpu, label))
    if when.used_start:
        notice(
            f"{label}: values authored only as time samples read at the start time code "
            f"{when.start:g} (--time T reads every value at time code T)"
        )
    return lights, meshes


def _found(stage, label: str, when: UsdTime, notice) -> list[tuple[Any, str]]:
    """The light and mesh prims of the stage's default traversal (instance proxies
    included), less invisible ones and those of purpose guide or proxy: a light so skipped
    gets a notice (no engine draws it)."""
    Usd, UsdGeom, _ = _pxr()
    found: list[tuple[Any, str]] = []
    for k, prim in enumerate(stage.Traverse(Usd.TraverseInstanceProxies())):
        if k >= MAX_PRIMS:
            raise BadValueError(
                f"{label}: more than {MAX_PRIMS:,} prims (instances counted); attenfit reads "
                f"at most {MAX_PRIMS:,}"
            )
        type_name = prim.GetTypeName()
        if type_name not in (*_UNSUPPORTED, *AREA_TYPES, "SphereLight", "DiskLight", "Mesh"):
            continue
        where = f"{label}: {type_name} {prim.GetPath()}"
        with prim_errors(where):
            hidden = _hidden(prim, when, UsdGeom)
        if hidden is not None:
            if type_name != "Mesh":
                notice(f"{where}: {hidden}; skipped (it gets no answer and no range)")
            continue
        found.append((prim, type_name))
    return found


def _hidden(prim, when: UsdTime, UsdGeom) -> str | None:
    """Why `prim` is not drawn, or None: invisible (its `visibility` or an ancestor's
    `invisible`: UsdGeomImageable, "visibility is inherited"... an invisible prim hides its
    namespace descendants), or of purpose `guide` or `proxy` (drawn only on request;
    `UsdGeomImageable::ComputePurpose`, inherited too)."""
    p = prim
    while p and p.IsValid() and not p.IsPseudoRoot():
        img = UsdGeom.Imageable(p)
        if img and when.get(img.GetVisibilityAttr()) == UsdGeom.Tokens.invisible:
            at = "" if p == prim else f" (from {p.GetPath()})"
            return f"invisible{at}"
        p = p.GetParent()
    img = UsdGeom.Imageable(prim)
    purpose = img.ComputePurpose() if img else UsdGeom.Tokens.default_
    if purpose in (UsdGeom.Tokens.guide, UsdGeom.Tokens.proxy):
        return f"purpose {purpose}"
    return None


def _not_modelled(prim, type_name: str, when: UsdTime, where: str) -> str | None:
    """Why attenfit cannot answer the light `prim`, or None.

    Besides the light types attenfit does not model, two ShapingAPI inputs change the
    emission in ways it does not: `inputs:shaping:focus` ("Implemented as an off-axis
    cosine power exponent. TODO: clarify semantics", usdLux/schema.usda: no formula to
    model) when not 0, and `inputs:shaping:ies:file` (a photometric profile in another
    file, which attenfit never reads) when it names a file. A RectLight's
    `inputs:texture:file` ("A color texture to use on the rectangle", usdLux/schema.usda)
    naming a file makes its emission vary over the rectangle, which is not modelled either."""
    if type_name in _UNSUPPORTED:
        return "not modelled (attenfit takes sphere, disk, spot, rect and cylinder lights)"
    from pxr import UsdLux

    if type_name == "RectLight":
        tex = when.get(light_input(prim, UsdLux.RectLight(prim).GetTextureFileAttr(), []))
        path = getattr(tex, "path", tex)
        if isinstance(path, str) and path:
            return (
                f"texture:file {path!r}: a textured rect light's emission varies over the "
                "rectangle, which is not modelled (attenfit reads no other file)"
            )
    olds: list[str] = []
    diffuse = _diffuse(prim, where, when, olds)
    if diffuse == 0:
        return (
            "inputs:diffuse 0: the light does not reach diffuse surfaces (UsdLux LightAPI: "
            "'A multiplier for the effect of this light on the diffuse response of "
            "materials'), and attenfit judges diffuse irradiance"
        )
    if not shaped(prim):
        return None
    shaping = UsdLux.ShapingAPI(prim)
    focus = _number(light_input(prim, shaping.GetShapingFocusAttr(), olds), 0.0, where, when)
    if focus != 0:
        return (
            f"shaping:focus {focus:g} is not modelled (UsdLux gives it no formula: 'an "
            "off-axis cosine power exponent'); set it to 0 to answer the light without it"
        )
    ies = when.get(light_input(prim, shaping.GetShapingIesFileAttr(), olds))
    path = getattr(ies, "path", ies)
    if isinstance(path, str) and path:
        return f"shaping:ies:file {path!r}: an IES profile is not modelled (attenfit reads no other file)"
    return None


def _open_stage(layers: UsdLayers, label: str, Usd):
    """The stage composed from the checked layers, refusing one that used any other file."""
    try:
        stage = Usd.Stage.Open(layers.root, Usd.Stage.LoadAll)
    except Exception as exc:  # pxr raises Tf.ErrorException
        raise DataFileError(
            f"{label}: not a USD scene usd-core can compose ({pxr_error(exc)})"
        ) from None
    if stage is None:
        raise DataFileError(f"{label}: not a USD file usd-core can open")
    checked = set(layers.files)
    for used in stage.GetUsedLayers():
        if not used.anonymous and os.path.realpath(used.realPath) not in checked:
            raise DataFileError(  # never seen: every composition arc is walked first
                f"{label}: usd-core composed {used.identifier!r}, which attenfit did not check"
            )
    return stage


def _meters_per_unit(stage, label: str, UsdGeom) -> float:
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    if isinstance(mpu, bool) or not isinstance(mpu, int | float):
        raise BadValueError(f"{label}: metersPerUnit must be a number, got {mpu!r}")
    if not (math.isfinite(mpu) and 1e-12 <= mpu <= 1e12):
        raise BadValueError(
            f"{label}: metersPerUnit {mpu:g}: must be a length from 1e-12 to 1e12 m "
            "(0.01 for centimetres, 1 for metres)"
        )
    return float(mpu)


def _number(attr, default: float, where: str, when: UsdTime) -> float:
    """A finite number from `attr` at `when` (its default when unauthored), refused with one
    line naming the attribute otherwise."""
    v = when.get(attr)
    v = default if v is None else v
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise BadTypeError(f"{where}: {attr.GetName()} must be a number, got {show(v)}")
    if not math.isfinite(v):
        raise BadValueError(f"{where}: {attr.GetName()} must be finite, got {v!r}")
    return float(v)


def _diffuse(prim, where: str, when: UsdTime, olds: list[str]) -> float:
    """The light's `inputs:diffuse` (pre-2021 `diffuse`; UsdLux LightAPI, default 1): a
    factor on its diffuse effect, refused when negative."""
    from pxr import UsdLux

    attr = light_input(prim, UsdLux.LightAPI(prim).GetDiffuseAttr(), olds)
    diffuse = _number(attr, 1.0, where, when)
    if diffuse < 0:
        raise BadValueError(
            f"{where}: {attr.GetName()} {diffuse:g} is negative (a factor on the light's "
            "diffuse effect: 0 to switch it off, 1 as authored)"
        )
    return diffuse


def _readers(prim, when: UsdTime):
    """`_usd_area`'s attribute readers `number(attr, default, where)`, `flag(attr, where)`
    and `diffuse(where)`: `_number`, `_flag` and `_diffuse` at `when`, pre-2021 input names
    included."""
    olds: list[str] = []
    return (
        lambda attr, default, where: _number(light_input(prim, attr, olds), default, where, when),
        lambda attr, where: _flag(light_input(prim, attr, olds), where, when),
        lambda where: _diffuse(prim, where, when, olds),
    )


def _flag(attr, where: str, when: UsdTime) -> bool:
    v = when.get(attr)
    v = False if v is None else v
    if not isinstance(v, bool):
        raise BadTypeError(f"{where}: {attr.GetName()} must be true or false, got {show(v)}")
    return v


def _normal_square(r: float) -> bool:
    """Whether `r` is a positive length whose square (areas, radiance) is a normal float."""
    return r > 0 and math.isfinite(r) and sys.float_info.min <= r * r < math.inf


def _placement(m: np.ndarray, mpu: float, where: str):
    """(scale in m per local unit, centre in m, the local -Z axis in world space) of a light's
    world transform `m`; a transform that is not finite or not uniform is refused."""
    if not np.all(np.isfinite(m)) or not all(math.isfinite(float(x) * mpu) for x in m[3, :3]):
        raise BadValueError(
            f"{where}: its world transform is not finite (translation {show(m[3, :3].tolist())} "
            f"x metersPerUnit {mpu:g})"
        )
    s = _scales(m)
    if not np.all(s > 0) or (s.max() - s.min()) > 1e-6 * s.max():
        raise BadValueError(
            f"{where}: non-uniform scale {tuple(round(float(x), 6) for x in s)} "
            "on a light (its radius would not be a radius); scale its radius instead"
        )
    centre = tuple(float(x) * mpu for x in m[3, :3])
    axis = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
    axis = tuple(float(x) for x in axis / np.linalg.norm(axis))
    return float(s[0]) * mpu, centre, axis


def _radius(prim, type_name, scale, where, radius_for, when, olds) -> float:
    """The light's radius in metres: `inputs:radius` x scale, or the one the options give for
    a `treatAsPoint` sphere or a radius that is not positive."""
    from pxr import UsdLux

    name = str(prim.GetPath())
    api = UsdLux.SphereLight(prim) if type_name == "SphereLight" else UsdLux.DiskLight(prim)
    r_attr = light_input(prim, api.GetRadiusAttr(), olds)
    r_local = _number(r_attr, 0.5, where, when)
    radius = r_local * scale
    point = type_name == "SphereLight" and _flag(api.GetTreatAsPointAttr(), where, when)
    if point or not radius > 0:
        given = radius_for(name)
        if given is None:
            why = "treatAsPoint has no radius" if point else f"radius {radius:g} m is not positive"
            raise BadValueError(
                f"{where}: {why}; give one with --radius R (m) or a side file with "
                f"[lights.'{name}'] radius = R"
            )
        radius = given
    if not _normal_square(radius):
        raise BadValueError(
            f"{where}: radius {radius:g} m ({r_attr.GetName()} {r_local:g} x scale {scale:g} m, "
            "or the one given) is out of range: its square must be a normal float"
        )
    return radius


def _intensity(prim, type_name, radius, where, when, olds) -> float:
    """The point-equivalent intensity: radiance (`intensity x 2^exposure x diffuse`, over
    the area with `normalize`) x pi r^2."""
    from pxr import UsdLux

    lux = UsdLux.LightAPI(prim)
    i_attr = light_input(prim, lux.GetIntensityAttr(), olds)
    e_attr = light_input(prim, lux.GetExposureAttr(), olds)
    intensity = _number(i_attr, 1.0, where, when)
    exposure = _number(e_attr, 0.0, where, when)
    normalize = _flag(light_input(prim, lux.GetNormalizeAttr(), olds), where, when)
    diffuse = _diffuse(prim, where, when, olds)  # > 0: a light of 0 is skipped before
    area = (4.0 if type_name == "SphereLight" else 1.0) * math.pi * radius**2
    if not intensity > 0:
        raise BadValueError(f"{where}: intensity {intensity:g} is not positive (a dark light)")
    # radiance x pi r^2; in logarithms first: 2^exposure alone may overflow
    log2 = math.log2(intensity) + exposure + math.log2(diffuse * math.pi * radius**2)
    log2 -= math.log2(area) if normalize else 0.0
    if not -1000 < log2 < 1000:
        raise BadValueError(
            f"{where}: {i_attr.GetName()} {intensity:g} x 2^{e_attr.GetName()} ({exposure:g}) "
            f"gives a point-equivalent intensity of 2^{log2:.5g}, outside the float range"
        )
    if abs(exposure) >= 1000:
        return 2.0**log2
    intensity *= 2.0**exposure * diffuse
    intensity = intensity / area if normalize else intensity
    return intensity * math.pi * radius**2


def _cone(prim, where, when, olds) -> tuple[float, float] | None:
    """(umbra, penumbra) in degrees of a ShapingAPI cone, or None for no cone. Without the
    API applied (`shaped`), an unauthored angle is no cone (the schema's 90 applies with
    the API only)."""
    from pxr import UsdLux

    if not shaped(prim):
        return None
    shaping = UsdLux.ShapingAPI(prim)
    a_attr = light_input(prim, shaping.GetShapingConeAngleAttr(), olds)
    if not prim.HasAPI(UsdLux.ShapingAPI) and not (a_attr and a_attr.HasAuthoredValue()):
        return None
    angle = _number(a_attr, 90.0, where, when)
    softness = _number(light_input(prim, shaping.GetShapingConeSoftnessAttr(), olds), 0.0, where, when)  # fmt: skip
    if angle >= 180:
        return None  # no cone
    if not 0 < angle <= 90:
        raise BadValueError(
            f"{where}: {a_attr.GetName()} {angle:g} deg: attenfit models cones of 0 to 90 "
            "degrees (or 180, no cone)"
        )
    softness = min(max(softness, 0.0), 1.0)
    cu = math.cos(math.radians(angle))
    penumbra = math.degrees(math.acos(min(1.0, cu + (1 - cu) * softness)))
    return angle, min(penumbra, angle)


def _light(prim, type_name, m, mpu, where, radius_for, when, notice) -> UsdLight:
    name = str(prim.GetPath())
    olds: list[str] = []
    scale, centre, axis = _placement(m, mpu, where)
    radius = _radius(prim, type_name, scale, where, radius_for, when, olds)
    intensity = _intensity(prim, type_name, radius, where, when, olds)
    kw: dict[str, Any] = {"radius": radius, "position": centre, "intensity": intensity}
    cone = _cone(prim, where, when, olds)
    if cone is not None:
        kw.update(
            kind="spot",
            umbra=cone[0],
            penumbra=cone[1],
            direction=axis,
            shape="sphere" if type_name == "SphereLight" else "disk",
            profile="threejs",
        )
        kind = f"{type_name} + ShapingAPI"
    elif type_name == "SphereLight":
        kw["kind"] = "sphere"
        kind = type_name
    else:
        kw.update(kind="disk", normal=axis)
        kind = type_name
    if olds:
        notice(
            f"{where}: read the pre-2021 UsdLux names {', '.join(olds)} as inputs:"
            f"{', inputs:'.join(olds)} (usd-core before 21.02 wrote them without 'inputs:')"
        )
    light = SceneLight(**kw)
    try:
        light.emitter()  # the emitter's own checks
    except AttenfitError as exc:
        raise type(exc)(f"{where}: {exc}") from None
    return UsdLight(name, light, kind, None)
