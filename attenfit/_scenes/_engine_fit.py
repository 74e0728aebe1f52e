"""An engine answer judged through the engine's own shading (`attenfit._judge._engine_shading`),
and the best settings the engine allows when its first mapping is not within tolerance.

`engine_verdict(engine, light, props, x, tolerance)`: the light properties attenfit hands
out (`Engine.properties`) rendered by the engine's witness at the light's judged receivers
`x`, with the scene's judged error. The worst case over the scene's receivers (a finite set)
is their largest error. When that is over the tolerance, the spot cone's properties that
the engine exposes (`EngineWitness.cone_props`) are moved within their bounds (Nelder-Mead on the largest
error, from the mapping and from a few starts across the bounds), and a light size the
engine feeds into its diffuse term (Godot's `light_size`, Unreal's `SourceRadius`) is tried
at 0 and at the light's radius: the settings kept are the ones the engine renders closest,
never worse than the mapping. A light no settings bring within tolerance is "fail" with
the closest error and those settings.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .._judge import EngineWitness, engine_receiver_errors
from ._light_fits import LightData
from ._types import SceneLight

__all__ = ["EngineVerdict", "engine_verdict", "renders_as_spot"]

#: Nelder-Mead evaluations per start, and starts across the bounds besides the mapping.
_EVALS, _STARTS = 240, 4


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


def renders_as_spot(light: SceneLight) -> bool:
    """A spot, and a disk or a rectangle (their emission cosine: a cone is the engine's only
    way to it)."""
    return light.is_spot or light.kind in ("disk", "rect")


def _geometry(light: SceneLight, x: LightData) -> tuple[np.ndarray, np.ndarray]:
    """(cos from the spot's axis, n.l to the light's centre) at the receivers of `x`."""
    if x.points is None or x.normals is None:
        return x.cos_s, np.ones_like(x.d)
    to_light = np.asarray(light.position, np.float64)[None, :] - x.points
    dist = np.linalg.norm(to_light, axis=1, keepdims=True)
    l = to_light / np.where(dist > 0, dist, 1.0)
    n = x.normals / np.linalg.norm(x.normals, axis=1, keepdims=True)
    axis = np.asarray(light.direction if light.is_spot else light.normal, np.float64)
    axis = axis / np.linalg.norm(axis)
    return -(l @ axis), np.sum(n * l, axis=1)


def _errors(w: type[EngineWitness], props, light, x, geo) -> np.ndarray:
    cos_s, n_dot_l = geo
    return engine_receiver_errors(
        w, props, d=x.d, cos_s=cos_s, n_dot_l=n_dot_l, spot=renders_as_spot(light),
        intensity=light.intensity, E_true=x.E_true, denom=x.denom,
    )  # fmt: skip


def _worst(w, props, light, x, geo) -> float:
    e = _errors(w, props, light, x, geo)
    return float(e.max()) if e.size else 0.0


def _cone_search(w: type[EngineWitness], props: dict[str, Any], light, x, geo):
    """The cone properties moved to the engine's closest rendering: (props, error)."""
    from scipy.optimize import minimize

    names = [p[0] for p in w.cone_props]
    lo = np.array([p[1] for p in w.cone_props])
    hi = np.array([p[2] for p in w.cone_props])

    def with_(u):
        v = lo + (hi - lo) * np.clip(u, 0.0, 1.0)
        return {**props, **dict(zip(names, (float(a) for a in v), strict=True))}

    def objective(u):
        return _worst(w, with_(u), light, x, geo)

    u0 = np.array(
        [(float(props.get(n, lo[k])) - lo[k]) / (hi[k] - lo[k]) for k, n in enumerate(names)]
    )
    starts = [np.clip(u0, 0.0, 1.0)]
    rng = np.random.default_rng(0)
    starts += [rng.uniform(0.05, 0.95, len(names)) for _ in range(_STARTS)]
    best_u, best_e = starts[0], objective(starts[0])
    for s in starts:
        res = minimize(
            objective, s, method="Nelder-Mead",
            options={"maxfev": _EVALS, "xatol": 1e-6, "fatol": 1e-9, "initial_simplex": None},
        )  # fmt: skip
        e = objective(res.x)
        if e < best_e:
            best_u, best_e = res.x, e
    return with_(best_u), best_e


def engine_verdict(
    w: type[EngineWitness],
    light: SceneLight,
    props: Mapping[str, Any],
    x: LightData,
    tolerance: float,
    size_prop: str | None = None,
    size_value: float = 0.0,
) -> EngineVerdict:
    """The engine's rendering of `props` judged at `x`, and its closest settings (module
    docstring). `size_prop`: the property through which a light's size reaches the diffuse
    term, tried at 0 and at `size_value`."""
    geo = _geometry(light, x)
    props = dict(props)
    mapped = _worst(w, props, light, x, geo)
    notes: list[str] = []
    tries = [props]
    if size_prop is not None:
        tries = [{**props, size_prop: 0.0}, {**props, size_prop: size_value}]
    best, best_e = props, mapped
    for p in tries:
        e = _worst(w, p, light, x, geo)
        if renders_as_spot(light) and w.cone_props and e > tolerance:
            p, e = _cone_search(w, p, light, x, geo)
        if e < best_e or (e == best_e and p is tries[0]):
            best, best_e = p, e
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
    errs = _errors(w, best, light, x, geo)
    if not math.isfinite(best_e):
        best_e = math.inf
    status = "pass" if best_e <= tolerance else "fail"
    return EngineVerdict(best, best_e, errs, status, mapped, tuple(notes))
