"""A rect or tube light answered for an engine: the engine's own area light where it has
one (`attenfit._judge._area_shading`: Unreal's Rect Light and its point light with a
`SourceLength`, three.js's `RectAreaLight`, Godot's `AreaLight3D`), else its punctual
stand-in, each with the intensity the engine renders closest.

`area_verdict(verdict, witness, light, x, tolerance, precision)` takes the punctual
answer `_engine_fit.engine_verdict` judged (a rectangle as a spot whose cone stands in for
its cosine, a tube as a point light) and:

* re-renders the stand-in from the light's centre (the engine's point light sits there,
  whatever distance attenfit's curves read) with its intensity property
  (`EngineWitness.intensity_prop`) chosen by `best_intensity`: a tube's file intensity is
  an end disk's along its axis, and its side is `2 l / (pi r)` times brighter broadside, so
  the file's intensity as it stands renders a tube's point light about 98% dark;
* renders each of the engine's own lights of the shape (`area_witnesses`), with the
  engine's size settings (`AreaWitness.candidates`), a range at which the engine's window
  changes no receiver by more than a twentieth of the tolerance (`window_range`), and the
  intensity `best_intensity` chooses;
* answers with the engine's own light when it is within the tolerance or no further than
  the stand-in, else with the stand-in; either way its error is the engine-rendered worst
  case at the light's judged receivers, and the notes name the other's.

Intensities are rounded to float32 (what an engine stores) before the final render.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from .._judge import (
    AreaWitness,
    EngineWitness,
    area_witnesses,
    best_intensity,
    engine_receiver_errors,
    window_range,
)
from ._light_fits import LightData
from ._types import SceneLight

__all__ = ["AREA_KINDS", "area_verdict", "light_frame"]

#: The light kinds answered here (the others keep `engine_verdict`'s answer).
AREA_KINDS = ("rect", "tube")


def _unit(v) -> np.ndarray:
    v = np.asarray(v, np.float64)
    return v / np.linalg.norm(v)


def light_frame(light: SceneLight) -> np.ndarray:
    """The light's frame as rows (x, y, z): a rectangle's tangent, normal x tangent, normal
    (`SceneLight`); a tube's axis and two unit vectors across it."""
    if light.kind == "rect":
        z, x = _unit(light.normal), _unit(light.tangent)
        x = _unit(x - z * (x @ z))
        return np.stack([x, np.cross(z, x), z])
    x = _unit(light.axis)
    helper = np.eye(3)[int(np.argmin(np.abs(x)))]
    y = _unit(np.cross(x, helper))
    return np.stack([x, y, np.cross(x, y)])


def _size(light: SceneLight) -> tuple[float, float]:
    if light.kind == "rect":
        return tuple(light.size or (2 * light.radius, 2 * light.radius))  # type: ignore[return-value]
    return float(light.length), float(light.radius)


@dataclasses.dataclass(frozen=True)
class _Option:
    props: dict[str, Any]
    error: float
    errors: np.ndarray
    native: AreaWitness | None
    scale: float  # the intensity over its nominal value


def _errors(E: np.ndarray, x: LightData) -> np.ndarray:
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        err = np.abs(E - x.E_true) / x.denom
    return np.where(np.isfinite(err), err, np.inf)


def _worst(err: np.ndarray) -> float:
    return float(err.max()) if err.size else 0.0


def _stand_in(w, light, props, x: LightData, geo, precision) -> _Option:
    d, cos_s, n_dot_l = geo
    spot = light.kind == "rect"  # a rectangle's stand-in is a spot (`renders_as_spot`)
    unit = w.render(props, d, cos_s, n_dot_l, spot, precision)  # per candela
    c, _ = best_intensity(unit, x.E_true, x.denom)
    value = float(np.float32(c * w.intensity_per_cd))
    out = {**props, w.intensity_prop: value}
    err = engine_receiver_errors(
        w, out, d=d, cos_s=cos_s, n_dot_l=n_dot_l, spot=spot, intensity=light.intensity,
        E_true=x.E_true, denom=x.denom, precision=precision,
    )  # fmt: skip
    return _Option(out, _worst(err), err, None, value / w.intensity_per_cd / light.intensity)


def _native(aw: type[AreaWitness], cand, light, x: LightData, local, precision) -> _Option:
    unit = aw.render({**cand, aw.intensity_prop: 1.0}, local, precision)
    c, _ = best_intensity(unit, x.E_true, x.denom)
    props = {"light_type": aw.light_type, **cand, aw.intensity_prop: float(np.float32(c))}
    err = _errors(aw.render(props, local, precision), x)
    nominal = aw.nominal(light.intensity, _size(light))
    return _Option(props, _worst(err), err, aw, props[aw.intensity_prop] / nominal)


def _geometry(light: SceneLight, x: LightData):
    """(receivers in the light's frame, (distance to the centre, cosine from the axis,
    n.l to the centre))."""
    frame = light_frame(light)
    rel = x.points - np.asarray(light.position, np.float64)[None, :]
    p = rel @ frame.T
    nrm = x.normals / np.linalg.norm(x.normals, axis=1, keepdims=True)
    n = nrm @ frame.T
    local = dict(zip(("x", "y", "z", "nx", "ny", "nz"), (*p.T, *n.T), strict=True))
    d = np.linalg.norm(rel, axis=1)
    safe = np.where(d > 0, d, 1.0)
    n_dot_l = -np.sum(nrm * rel, axis=1) / safe
    cos_s = p[:, 2] / safe if light.kind == "rect" else np.ones_like(d)
    return local, (d, cos_s, n_dot_l)


def _notes(pick: _Option, stand: _Option, natives: list[_Option], w, light) -> list[str]:
    out = []
    if pick.native is not None:
        aw = pick.native
        out.append(
            f"answered with {w.name}'s own {aw.light_type} ({aw.source}); {aw.intensity_prop} "
            f"in {aw.intensity_unit}, {pick.scale:.4g} x the file's intensity as {w.name} "
            "reads it, the value that renders closest"
        )
        if aw.note:
            out.append(aw.note)
        out.append(
            f"its punctual stand-in renders {100 * stand.error:.3g}% off at best "
            f"({w.intensity_prop} = {stand.props[w.intensity_prop]:.6g})"
        )
        return out
    if natives:
        best = min(natives, key=lambda o: o.error)
        out.append(
            f"{w.name}'s own {best.native.light_type} renders {100 * best.error:.3g}% off at "
            f"best, no closer than this stand-in"  # type: ignore[union-attr]
        )
    else:
        out.append(f"{w.name} has no {light.kind} light: answered with its punctual light")
    if light.kind == "tube":
        out.append(
            "a tube's file intensity is an end disk's along its axis; the point light's "
            f"{w.intensity_prop} is chosen to render closest ({stand.scale:.4g} x it)"
        )
    else:
        out.append(f"{w.intensity_prop} chosen to render closest ({stand.scale:.4g} x the file's)")
    return out


def area_verdict(verdict, w: type[EngineWitness], light: SceneLight, x: LightData,
                 tolerance: float, precision: str):  # fmt: skip
    """`verdict` (an `_engine_fit.EngineVerdict` for a rect or tube light) answered with
    the engine's own light or its rescaled stand-in (module docstring); `verdict` itself
    for another kind or receivers without points."""
    if light.kind not in AREA_KINDS or x.points is None or x.normals is None or not x.d.size:
        return verdict
    local, geo = _geometry(light, x)
    stand = _stand_in(w, light, dict(verdict.properties), x, geo, precision)
    R = window_range(float(geo[0].max()), tolerance)
    natives = [
        _native(aw, cand, light, x, local, precision)
        for aw in area_witnesses(w.name, light.kind)
        for cand in aw.candidates(_size(light), R)
    ]
    pick = stand
    if natives:
        best = min(natives, key=lambda o: o.error)
        if best.error <= tolerance or best.error <= stand.error:
            pick = best
    notes = list(verdict.notes) if pick.native is None else []
    notes += _notes(pick, stand, natives, w, light)
    error = pick.error if math.isfinite(pick.error) else math.inf
    return dataclasses.replace(
        verdict,
        properties=pick.props,
        error=error,
        errors=pick.errors,
        status="pass" if error <= tolerance else "fail",
        notes=tuple(notes),
    )
