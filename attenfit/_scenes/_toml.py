"""TOML scene files: every key, validated, with errors that name the file, the table and the
key (`scene.toml: [[lights]][1].radius: must be a positive number, got -1`; tables of an
array are numbered from 0). `SCENE_KEYS` documents the format key by key."""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._curves import list_families
from .._errors import BadTypeError, BadValueError, UnknownNameError
from .._input import LIMITS, load_toml, read_text
from .._truth import DiskEmitter, RectEmitter
from ._lighting import inside_light
from ._types import (
    LIGHT_EXTRA,
    LIGHT_KINDS,
    RECEIVER_KINDS,
    SPOT_PROFILES,
    SPOT_SHAPES,
    DistanceDistribution,
    PlaneReceivers,
    PointReceivers,
    Receivers,
    SceneLight,
)

SCENE_KEYS: dict[str, dict[str, str]] = {
    "top level": {
        "tolerance": "required; the largest acceptable error of the irradiance, relative (0.05 = 5%)",
        "error_floor": "optional, default 0; below `error_floor` x the light's brightest receiver, errors are measured relative to that floor instead (dim receivers do not need 5% accuracy)",
        "name": "optional; a title for the report",
        "description": "optional; free text",
        "seed": "optional integer, default 0; the seed of random receiver distributions",
    },
    "[constraints]": {
        "reach_zero_at_range": "optional, default false; the curve must reach 0 at each light's `range` (so culling there leaves no seam): only windowed families qualify, their range pinned to the light's",
        "precision": "optional, default float64; the precision the scene shades in: float32 | float16 (GLSL mediump, HLSL min16float). Every candidate's shader form (what `attenfit export` writes) is evaluated in it, per operation, at the judged receivers; a family that overflows, flushes to 0 or leaves the tolerance there fails with the reason. float64 judges the JAX reference form (fits run in float64; their parameters are rounded to float32 for float32 and float16)",
        "float32": 'optional, default false; `float32 = true` is `precision = "float32"`',
        "families": "optional list of family names; only these are candidates (default: every registered family)",
    },
    "[[lights]]": {
        "kind": "required; sphere | disk | capsule | spot | rect | tube",
        "radius": "required (not for rect); the emitter's radius (m), > 0",
        "position": "[x, y, z] of the centre (m); give this or `height`",
        "height": "the centre's height above the floor z = 0 (m): the light sits at (0, 0, height)",
        "intensity": "optional, default 1; the point-equivalent intensity I (W/sr)",
        "range": "optional; the distance (m) beyond which the engine culls the light; receivers beyond it are not judged; windows reach 0 there",
        "normal": "disk and rect only, default [0, 0, -1]: the emitting side",
        "two_sided": "disk only, default false",
        "size": "rect only, required; [width, height] (m), width along `tangent`, height along `normal` x `tangent`",
        "tangent": "rect only, default [1, 0, 0]: the width's direction (its part in the rectangle's plane)",
        "length": "capsule and tube only, required; the segment's length (m)",
        "axis": "capsule and tube only, default [1, 0, 0]: the segment's direction",
        "caps": "tube only, default false; whether its two end disks emit too (a UsdLux CylinderLight's do not)",
        "umbra": "spot only, required; the cone's half-angle in degrees, 0 < umbra <= 90",
        "penumbra": "spot only, required; the half-angle of full intensity in degrees, 0 <= penumbra <= umbra",
        "direction": "spot only, default [0, 0, -1]",
        "shape": "spot only, default sphere; sphere | disk (a disk faces along `direction`)",
        "profile": "spot only, default aperture; the true angular falloff: aperture | linear | frostbite | threejs",
    },
    "[[receivers]] kind = plane": {
        "extent": "required; half-width (m) of the square grid",
        "resolution": "optional, default 16; grid points per side (2..256)",
        "center": "optional, default [0, 0, 0]",
        "normal": "optional, default [0, 0, 1]; the receivers' normal (the plane is perpendicular to it)",
    },
    "[[receivers]] kind = points": {
        "points": "required; a list of [x, y, z] (at most 4096)",
        "normals": "optional; a list of [x, y, z], one per point (default: each receiver faces the light)",
    },
    "[[receivers]] kind = distribution": {
        "distance": "required; [min, max] distance (m) from each light's centre (capsule: from its segment)",
        "angle": "optional, default [0, 0]; [min, max] degrees between a receiver's normal and the direction to the light (0 = facing it), within [0, 90]",
        "off_axis": "optional, default [0, 90]; [min, max] degrees between the light's axis (disk normal, spot direction) and the receiver's direction, within [0, 180]; ignored for spheres; capsules put receivers perpendicular to the segment",
        "n": "optional, default 64; receivers per light (1..4096)",
        "spacing": "optional, default log; log | linear spacing of distances",
    },
}


_TOP = (
    "tolerance",
    "error_floor",
    "name",
    "description",
    "seed",
    "lights",
    "receivers",
    "constraints",
)
_CONSTRAINTS = ("reach_zero_at_range", "precision", "float32", "families")
#: The precisions a scene may declare.
SCENE_PRECISIONS = ("float64", "float32", "float16")
_LIGHT_COMMON = ("kind", "radius", "position", "height", "intensity", "range")

_RECEIVER_KEYS = {
    "plane": ("kind", "extent", "resolution", "center", "normal"),
    "points": ("kind", "points", "normals"),
    "distribution": ("kind", "distance", "angle", "off_axis", "n", "spacing"),
}
_MAX_RECEIVERS = 4096


def read_toml(path: str | os.PathLike) -> tuple[dict[str, Any], str]:
    """The parsed TOML of a scene file and its label (the file's name) for messages."""
    path = Path(path)
    label = path.name
    text = read_text(path, f"scene file {label!r}", LIMITS["scene"])
    return load_toml(text, f"scene file {label!r}"), label


# ----------------------------------------------------------------------------- validation
class _Where:
    """Builds messages `file: table.key: what`."""

    def __init__(self, source: str, table: str = ""):
        self.source = source
        self.table = table

    def at(self, table: str) -> _Where:
        return _Where(self.source, table)

    def path(self, key: str) -> str:
        return f"{self.table}.{key}" if self.table else key

    def bad(self, key: str, what: str) -> BadValueError:
        return BadValueError(f"{self.source}: {self.path(key)}: {what}")

    def type(self, key: str, what: str) -> BadTypeError:
        return BadTypeError(f"{self.source}: {self.path(key)}: {what}")

    def table_msg(self, what: str) -> str:
        return f"{self.source}: {self.table or 'top level'}: {what}"


def _show(value: Any) -> str:
    if isinstance(value, str):
        return repr(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    return repr(value)


def _check_keys(table: Mapping[str, Any], allowed: Sequence[str], w: _Where) -> None:
    for key in table:
        if key not in allowed:
            raise UnknownNameError(
                w.table_msg(f"unknown key {key!r}; allowed: {', '.join(allowed)}")
            )


def _require(table: Mapping[str, Any], key: str, w: _Where, what: str) -> Any:
    if key not in table:
        raise BadValueError(w.table_msg(f"missing key {key!r} ({what})"))
    return table[key]


def _number(value: Any, key: str, w: _Where, *, what: str = "a number") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise w.type(key, f"must be {what}, got {_show(value)}")
    x = float(value)
    if not math.isfinite(x):
        raise w.bad(key, f"must be {what} (finite), got {_show(value)}")
    return x


def _positive(value: Any, key: str, w: _Where) -> float:
    x = _number(value, key, w, what="a positive number")
    if not x > 0:
        raise w.bad(key, f"must be a positive number, got {_show(value)}")
    return x


def _integer(value: Any, key: str, w: _Where, lo: int, hi: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise w.type(key, f"must be an integer from {lo} to {hi}, got {_show(value)}")
    if not lo <= value <= hi:
        raise w.bad(key, f"must be an integer from {lo} to {hi}, got {value}")
    return int(value)


def _boolean(value: Any, key: str, w: _Where) -> bool:
    if not isinstance(value, bool):
        raise w.type(key, f"must be true or false, got {_show(value)}")
    return value


def _string(value: Any, key: str, w: _Where) -> str:
    if not isinstance(value, str):
        raise w.type(key, f"must be a string, got {_show(value)}")
    return value


def _choice(value: Any, key: str, w: _Where, allowed: Sequence[str]) -> str:
    if not isinstance(value, str):
        raise w.type(key, f"must be one of {', '.join(allowed)}, got {_show(value)}")
    if value not in allowed:
        raise UnknownNameError(
            f"{w.source}: {w.path(key)}: unknown {key} {value!r}; allowed: {', '.join(allowed)}"
        )
    return value


def _vec3(value: Any, key: str, w: _Where, *, nonzero: bool = False) -> tuple[float, float, float]:
    if not isinstance(value, list) or len(value) != 3:
        raise w.type(key, f"must be a list of 3 numbers [x, y, z], got {_show(value)}")
    v = tuple(_number(x, key, w, what="a list of 3 finite numbers") for x in value)
    if nonzero and not any(v):
        raise w.bad(key, f"must be a non-zero vector, got {_show(value)}")
    return v  # type: ignore[return-value]


def _interval(
    value: Any, key: str, w: _Where, *, lo: float, hi: float, positive: bool = False
) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise w.type(key, f"must be a list [min, max] of 2 numbers, got {_show(value)}")
    a, b = (_number(x, key, w, what="a list [min, max] of finite numbers") for x in value)
    if positive and not a > 0:
        raise w.bad(key, f"min must be > 0, got {_show(value)}")
    if not (lo <= a and b <= hi):
        raise w.bad(key, f"must lie within [{lo:g}, {hi:g}], got {_show(value)}")
    if b < a:
        raise w.bad(key, f"range is backwards (min > max): {_show(value)}")
    return (a, b)


def _table(value: Any, what: str, w: _Where) -> Mapping[str, Any]:
    if not isinstance(value, Mapping):
        raise BadTypeError(f"{w.source}: {what}: must be a table, got {_show(value)}")
    return value


def _array_of_tables(d: Mapping[str, Any], key: str, w: _Where) -> list[Mapping[str, Any]]:
    if key not in d:
        raise BadValueError(
            f"{w.source}: missing [[{key}]]: a scene needs at least one [[{key}]] table"
        )
    value = d[key]
    if not isinstance(value, list) or not all(isinstance(t, Mapping) for t in value):
        raise BadTypeError(
            f"{w.source}: {key}: must be an array of tables ([[{key}]]), got {_show(value)}"
        )
    if not value:
        raise BadValueError(f"{w.source}: [[{key}]]: a scene needs at least one table")
    return value


def parse_scene(d: Mapping[str, Any], source: str) -> dict[str, Any]:
    """The validated fields of a `Scene` from a parsed scene file (`source` labels errors)."""
    w = _Where(source)
    if not isinstance(d, Mapping):
        raise BadTypeError(f"{source}: a scene must be a table (dict), got {type(d).__name__}")
    _check_keys(d, _TOP, w)
    tolerance = _number(
        _require(d, "tolerance", w, "the largest acceptable relative error, e.g. 0.05"),
        "tolerance",
        w,
        what="a relative error in (0, 1]",
    )
    if not 0 < tolerance <= 1:
        raise w.bad("tolerance", f"must be a relative error in (0, 1], got {_show(d['tolerance'])}")
    error_floor = 0.0
    if "error_floor" in d:
        error_floor = _number(d["error_floor"], "error_floor", w, what="a number in [0, 1)")
        if not 0 <= error_floor < 1:
            raise w.bad("error_floor", f"must be a number in [0, 1), got {_show(d['error_floor'])}")
    name = _string(d["name"], "name", w) if "name" in d else ""
    description = _string(d["description"], "description", w) if "description" in d else ""
    seed = _integer(d["seed"], "seed", w, 0, 2**63 - 1) if "seed" in d else 0

    reach_zero, float32, families, precision = False, False, None, "float64"
    if "constraints" in d:
        cons = _table(d["constraints"], "constraints", w)
        wc = w.at("[constraints]")
        _check_keys(cons, _CONSTRAINTS, wc)
        if "reach_zero_at_range" in cons:
            reach_zero = _boolean(cons["reach_zero_at_range"], "reach_zero_at_range", wc)
        if "float32" in cons:
            float32 = _boolean(cons["float32"], "float32", wc)
            precision = "float32" if float32 else precision
        if "precision" in cons:
            given = cons["precision"]
            if given not in SCENE_PRECISIONS:
                raise wc.bad(
                    "precision",
                    f"must be one of {', '.join(SCENE_PRECISIONS)}, got {_show(given)}",
                )
            if float32 and given != "float32":
                raise wc.bad("precision", f"is {given!r} but float32 = true says float32")
            precision = given
        if "families" in cons:
            families = _family_names(cons["families"], wc)

    lights = tuple(
        _parse_light(t, w.at(f"[[lights]][{i}]"))
        for i, t in enumerate(_array_of_tables(d, "lights", w))
    )
    receivers = tuple(
        _parse_receivers(t, w.at(f"[[receivers]][{i}]"))
        for i, t in enumerate(_array_of_tables(d, "receivers", w))
    )
    if reach_zero:
        for i, light in enumerate(lights):
            if light.range is None:
                raise BadValueError(
                    f"{source}: [constraints].reach_zero_at_range: needs every light to have a "
                    f"range; [[lights]][{i}] has none"
                )
    _check_geometry(lights, receivers, w)
    return dict(
        lights=lights,
        receivers=receivers,
        tolerance=tolerance,
        error_floor=error_floor,
        reach_zero_at_range=reach_zero,
        float32=precision == "float32",
        precision=precision,
        families=families,
        name=name,
        description=description,
        seed=seed,
        source=source,
    )


def _family_names(value: Any, w: _Where) -> tuple[str, ...]:
    known = list_families()
    if not isinstance(value, list) or not value or not all(isinstance(v, str) for v in value):
        raise w.type("families", f"must be a non-empty list of family names, got {_show(value)}")
    for v in value:
        if v not in known:
            raise UnknownNameError(
                f"{w.source}: {w.path('families')}: unknown family {v!r}; allowed: {', '.join(known)}"
            )
    return tuple(dict.fromkeys(value))


def _parse_light(t: Mapping[str, Any], w: _Where) -> SceneLight:
    kind = _choice(_require(t, "kind", w, " | ".join(LIGHT_KINDS)), "kind", w, LIGHT_KINDS)
    common = tuple(k for k in _LIGHT_COMMON if not (kind == "rect" and k == "radius"))
    _check_keys(t, (*common, *LIGHT_EXTRA[kind]), w)
    size = None
    if kind == "rect":
        size = _rect_size(_require(t, "size", w, "[width, height] in m"), w)
        radius = math.sqrt(size[0] * size[1] / math.pi)
    else:
        radius = _positive(_require(t, "radius", w, "the emitter's radius in m"), "radius", w)
    if "position" in t and "height" in t:
        raise BadValueError(w.table_msg("give either 'position' or 'height', not both"))
    if "position" in t:
        position = _vec3(t["position"], "position", w)
    elif "height" in t:
        position = (0.0, 0.0, _number(t["height"], "height", w))
    else:
        raise BadValueError(
            w.table_msg("missing key 'position' ([x, y, z] in m) or 'height' (above z = 0, in m)")
        )
    kw: dict[str, Any] = {"kind": kind, "radius": radius, "position": position}
    if "intensity" in t:
        kw["intensity"] = _positive(t["intensity"], "intensity", w)
    if "range" in t:
        rng = _positive(t["range"], "range", w)
        if not rng > radius:
            raise w.bad("range", f"must exceed the radius ({radius:g}), got {_show(t['range'])}")
        kw["range"] = rng
    if kind == "disk":
        if "normal" in t:
            kw["normal"] = _vec3(t["normal"], "normal", w, nonzero=True)
        if "two_sided" in t:
            kw["two_sided"] = _boolean(t["two_sided"], "two_sided", w)
    elif kind == "rect":
        kw["size"] = size
        for key in ("normal", "tangent"):
            if key in t:
                kw[key] = _vec3(t[key], key, w, nonzero=True)
    elif kind in ("capsule", "tube"):
        kw["length"] = _positive(
            _require(t, "length", w, f"the {kind}'s segment length in m"), "length", w
        )
        if "axis" in t:
            kw["axis"] = _vec3(t["axis"], "axis", w, nonzero=True)
        if "caps" in t:
            kw["caps"] = _boolean(t["caps"], "caps", w)
    elif kind == "spot":
        umbra = _number(
            _require(t, "umbra", w, "the cone's half-angle in degrees"), "umbra", w,
            what="an angle in degrees",
        )  # fmt: skip
        if not 0 < umbra <= 90:
            raise w.bad("umbra", f"must be an angle in (0, 90] degrees, got {_show(t['umbra'])}")
        penumbra = _number(
            _require(t, "penumbra", w, "the half-angle of full intensity in degrees"),
            "penumbra", w, what="an angle in degrees",
        )  # fmt: skip
        if not 0 <= penumbra <= umbra:
            raise w.bad(
                "penumbra",
                f"must be an angle in [0, umbra = {umbra:g}] degrees, got {_show(t['penumbra'])}",
            )
        kw["umbra"], kw["penumbra"] = umbra, penumbra
        if "direction" in t:
            kw["direction"] = _vec3(t["direction"], "direction", w, nonzero=True)
        if "shape" in t:
            kw["shape"] = _choice(t["shape"], "shape", w, SPOT_SHAPES)
        if "profile" in t:
            kw["profile"] = _choice(t["profile"], "profile", w, SPOT_PROFILES)
    light = SceneLight(**kw)
    if kind == "rect":
        try:
            light.emitter()  # a tangent along the normal
        except BadValueError as exc:
            raise BadValueError(w.table_msg(str(exc))) from None
    return light


def _rect_size(value: Any, w: _Where) -> tuple[float, float]:
    if not isinstance(value, list) or len(value) != 2:
        raise w.type("size", f"must be [width, height] in m, got {_show(value)}")
    return (_positive(value[0], "size[0]", w), _positive(value[1], "size[1]", w))


def _parse_receivers(t: Mapping[str, Any], w: _Where) -> Receivers:
    kind = _choice(_require(t, "kind", w, " | ".join(RECEIVER_KINDS)), "kind", w, RECEIVER_KINDS)
    _check_keys(t, _RECEIVER_KEYS[kind], w)
    if kind == "plane":
        kw: dict[str, Any] = {
            "extent": _positive(_require(t, "extent", w, "half-width in m"), "extent", w)
        }
        if "resolution" in t:
            kw["resolution"] = _integer(t["resolution"], "resolution", w, 2, 256)
        if "center" in t:
            kw["center"] = _vec3(t["center"], "center", w)
        if "normal" in t:
            kw["normal"] = _vec3(t["normal"], "normal", w, nonzero=True)
        return PlaneReceivers(**kw)
    if kind == "points":
        pts = _require(t, "points", w, "a list of [x, y, z]")
        if not isinstance(pts, list) or not pts:
            raise w.type("points", f"must be a non-empty list of [x, y, z], got {_show(pts)}")
        if len(pts) > _MAX_RECEIVERS:
            raise w.bad("points", f"at most {_MAX_RECEIVERS} points, got {len(pts)}")
        points = tuple(_vec3(p, f"points[{j}]", w) for j, p in enumerate(pts))
        normals = None
        if "normals" in t:
            nrm = t["normals"]
            if not isinstance(nrm, list) or len(nrm) != len(points):
                raise w.type(
                    "normals",
                    f"must be a list of {len(points)} [x, y, z] (one per point), got {_show(nrm)}",
                )
            normals = tuple(_vec3(n, f"normals[{j}]", w, nonzero=True) for j, n in enumerate(nrm))
        return PointReceivers(points=points, normals=normals)
    kw = {
        "distance": _interval(
            _require(t, "distance", w, "[min, max] in m"),
            "distance",
            w,
            lo=0.0,
            hi=math.inf,
            positive=True,
        )
    }
    if "angle" in t:
        kw["angle"] = _interval(t["angle"], "angle", w, lo=0.0, hi=90.0)
    if "off_axis" in t:
        kw["off_axis"] = _interval(t["off_axis"], "off_axis", w, lo=0.0, hi=180.0)
    if "n" in t:
        kw["n"] = _integer(t["n"], "n", w, 1, _MAX_RECEIVERS)
    if "spacing" in t:
        kw["spacing"] = _choice(t["spacing"], "spacing", w, ("log", "linear"))
    return DistanceDistribution(**kw)


def _check_geometry(
    lights: Sequence[SceneLight], receivers: Sequence[Receivers], w: _Where
) -> None:
    """Refuse receivers inside a solid light (points, distributions) before any work."""
    for i, light in enumerate(lights):
        em = light.emitter()
        solid = not isinstance(em, DiskEmitter | RectEmitter)
        for j, rec in enumerate(receivers):
            where = f"[[receivers]][{j}]"
            if isinstance(rec, DistanceDistribution) and solid and rec.distance[0] <= light.radius:
                raise BadValueError(
                    f"{w.source}: {where}.distance: min {rec.distance[0]:g} is inside "
                    f"[[lights]][{i}] (radius {light.radius:g}); distances start at the centre"
                )
            if isinstance(rec, PointReceivers) and solid:
                inside = inside_light(em, np.asarray(rec.points, dtype=np.float64), 1e-6)
                if inside.any():
                    k = int(np.argmax(inside))
                    raise BadValueError(
                        f"{w.source}: {where}.points[{k}]: lies inside [[lights]][{i}] "
                        f"(radius {light.radius:g})"
                    )
