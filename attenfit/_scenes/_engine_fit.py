"""An engine answer judged through the engine's own shading (`attenfit._judge._engine_shading`),
and the best settings the engine allows when its first mapping is not within tolerance.

`engine_verdict(engine, light, props, x, tolerance)`: the light properties attenfit hands
out (`Engine.properties`) rendered by the engine's witness at the light's judged receivers
`x`, with the scene's judged error, at the scene's precision (the precision the answer
claims: in float32 or float16 every operation of the engine's shading is rounded to it, as
attenfit's own curve is). The worst case over the scene's receivers (a finite set)
is their largest error. A light size the engine feeds into its diffuse term (Godot's
`light_size`, Unreal's `SourceRadius`) is tried at 0 and at the light's radius. When the
closer of the two is over the tolerance, every property the engine exposes for the light
(its cone, range, distance exponent or brightness, and light size) is searched jointly
(`attenfit._scenes._engine_search.search`): the settings kept are the ones the engine
renders closest, never worse than the mapping. A light no settings bring within tolerance
is "fail" with the closest error and those settings.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .._judge import EngineWitness
from ._engine_area import AREA_KINDS, area_verdict
from ._engine_search import Case, at_centre, search
from ._engine_search import geometry as _geometry
from ._engine_search import renders_as_spot as renders_as_spot
from ._light_fits import LightData
from ._types import SceneLight

__all__ = ["EngineVerdict", "engine_verdict", "renders_as_spot"]


@dataclasses.dataclass(frozen=True)
class EngineVerdict:
    """What the engine renders: `properties` (the settings kept), `error` (the largest
    judged error at the light's receivers), `errors` (per receiver), `status` ("pass"
    within tolerance, else "fail"), `mapped_error` (the first mapping's), `notes`."""

    properties: Mapping[str, Any]
    error: float
    errors: np.ndarray
    status: str
    mapped_error: float
    notes: tuple[str, ...]


def engine_verdict(
    w: type[EngineWitness],
    light: SceneLight,
    props: Mapping[str, Any],
    x: LightData,
    tolerance: float,
    size_prop: str | None = None,
    size_value: float = 0.0,
    precision: str = "float64",
) -> EngineVerdict:
    """The engine's rendering of `props` judged at `x`, and its closest settings (module
    docstring). `size_prop`: the property through which a light's size reaches the diffuse
    term, tried at 0 and at `size_value`. `precision`: the scene's, every operation of
    the engine's shading rounded to it (`EngineWitness.render`). The engine's point light
    sits at the light's centre: a capsule is judged at its receivers' distances from it
    (`at_centre`), not from its segment."""
    x = at_centre(light, x)
    case = Case(w, light, x, *_geometry(light, x), precision)
    props = dict(props)
    mapped = case.worst(props)
    tries = [props]
    if size_prop is not None:
        tries = [{**props, size_prop: 0.0}, {**props, size_prop: size_value}]
    best, best_e = props, mapped
    for p in tries:
        e = case.worst(p)
        if e < best_e or (e == best_e and p is tries[0]):
            best, best_e = p, e
    kept = [(best, best_e)]
    if best_e > tolerance:
        p, e = search(case, best, size_value)
        if e < best_e:
            kept.insert(0, (p, e))
    verdicts = [_verdict(case, p, e, tolerance, mapped, size_prop) for p, e in kept]
    if light.kind not in AREA_KINDS:
        return verdicts[0]
    # the engine's own area light, or a stand-in at the intensity that renders closest: the
    # search ran at the file's intensity, so the unsearched mapping is rescaled too
    area = [area_verdict(v, w, light, x, tolerance, precision) for v in verdicts]
    return min(area, key=lambda v: v.error)


def _verdict(case: Case, best, best_e: float, tolerance: float, mapped: float, size_prop):
    """The verdict of the settings `best` (their largest error `best_e`), with its notes."""
    w, light = case.w, case.light
    notes: list[str] = []
    if size_prop is not None:
        used = float(best.get(size_prop, 0.0))
        notes.append(
            f"{size_prop} = {used:g}: "
            + (
                "the light's size widens the engine's diffuse term and renders closer here"
                if used > 0
                else "0, since any size > 0 widens the engine's diffuse term "
                f"({w.size_effect.split(':')[0]}) and renders further from the truth here"
            )
        )
    if light.kind in ("disk", "rect"):
        notes.append(
            f"a {light.kind}: no {w.name} punctual light has an emission cosine; answered as a "
            f"spot whose cone is fitted to the {light.kind}'s cosine through the engine's own cone"
        )
    errs = case.errors(best)
    if not math.isfinite(best_e):
        best_e = math.inf
    status = "pass" if best_e <= tolerance else "fail"
    return EngineVerdict(best, best_e, errs, status, mapped, tuple(notes))
