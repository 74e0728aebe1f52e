"""An engine answer judged through the engine's own shading (`attenfit._judge._engine_shading`),
and the best settings the engine allows when its first mapping is not within tolerance.

`engine_verdict(engine, light, props, x, tolerance)`: the light properties attenfit hands
out (`Engine.properties`) rendered by the engine's witness at the light's judged receivers
`x`, with the scene's judged error, at the scene's precision (the precision the answer
claims: in float32 or float16 every operation of the engine's shading is rounded to it, as
attenfit's own curve is). The worst case over the scene's receivers (a finite set)
is their largest error. When that is over the tolerance, the spot cone's properties that
the engine exposes (`EngineWitness.cone_props`) are moved within their bounds (a grid
over the cone's edge and, at each edge, the best cone shape: `_cone_search`), and a light size the
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
from ._engine_area import AREA_KINDS, area_verdict
from ._light_fits import LightData
from ._types import SceneLight

__all__ = ["EngineVerdict", "engine_verdict", "renders_as_spot"]

#: The cone search (`_cone_search`): grid points per property, edge values refined, and
#: golden-section steps per refinement.
_GRID, _KEEP, _REFINE = 24, 3, 24
#: The cone's edge is kept at least this fraction of its property's span past the outermost
#: lit receiver: 1.6e-6 rad for an angle in radians, which moves the cosine 30 degrees off
#: the axis by 7.9e-7, 13 float32 steps there (float32 rounds a cosine by 6e-8).
_MARGIN = 1e-6


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


@dataclasses.dataclass(frozen=True)
class _Case:
    """A light's receivers as the engine sees them: witness `w`, the light, its judged
    receivers `x`, their cosine from the spot's axis and n.l, the scene's precision."""

    w: type[EngineWitness]
    light: SceneLight
    x: LightData
    cos_s: np.ndarray
    n_dot_l: np.ndarray
    precision: str

    def errors(self, props: Mapping[str, Any]) -> np.ndarray:
        x = self.x
        return engine_receiver_errors(
            self.w, props, d=x.d, cos_s=self.cos_s, n_dot_l=self.n_dot_l,
            spot=renders_as_spot(self.light), intensity=self.light.intensity,
            E_true=x.E_true, denom=x.denom, precision=self.precision,
        )  # fmt: skip

    def worst(self, props: Mapping[str, Any]) -> float:
        e = self.errors(props)
        return float(e.max()) if e.size else 0.0


def _cone_search(case: _Case, props: dict[str, Any]):
    """The cone properties moved to the engine's closest rendering: (props, error).

    The largest error over the receivers is flat where the cone leaves a lit receiver dark
    and has narrow valleys where the cone's edge sits just past the outermost lit receiver,
    so a local search from a few starts misses them. Every engine's cone has one property
    for its outer edge (`EngineWitness.cone_outer`) and one for its shape, and at a fixed
    edge the cone at each receiver is monotone in the shape property: each receiver's error
    is then quasi-convex in it, and so is their largest. So: for each edge value, the best
    shape by a `_GRID`-point scan (log-spaced for `cone_log`) refined by golden section
    between the best point's neighbours; edge values on a grid across the bounds and at
    offsets past the outermost lit receiver's edge (`_edge`; log-spaced from `_MARGIN` of
    the span, never closer), and the best `_KEEP` refined by golden section between their
    neighbours.
    tests/test_engine_search.py checks it against a brute-force grid."""
    (oname, olo, ohi), (sname, slo, shi) = _cone_axes(case.w)
    log = sname in case.w.cone_log
    seen: dict[tuple[float, float], float] = {}

    edge = _edge(case, props, oname, sname, olo, ohi, slo)
    margin = _MARGIN * (ohi - olo)

    def err(vo: float, vs: float) -> float:
        if edge is not None and edge < vo < edge + margin:
            vo = edge + margin  # float32 rounding of a receiver's cosine cannot cross it
        key = (float(vo), float(vs))
        if key not in seen:
            seen[key] = case.worst({**props, oname: key[0], sname: key[1]})
        return seen[key]

    def shape_of(u: float) -> float:
        return float(
            np.exp(np.log(slo) + (np.log(shi) - np.log(slo)) * u) if log else slo + (shi - slo) * u
        )

    def profile(vo: float) -> float:  # the best error at edge value vo, over the shape
        us = np.linspace(0.0, 1.0, _GRID)
        es = [err(vo, shape_of(u)) for u in us]
        i = int(np.argmin(es))
        lo_u, hi_u = us[max(i - 1, 0)], us[min(i + 1, _GRID - 1)]
        return min(es[i], _golden(lambda u: err(vo, shape_of(u)), lo_u, hi_u))

    edges = list(np.linspace(olo, ohi, _GRID))
    given = float(props.get(oname, olo))
    edges.append(min(max(given, olo), ohi))
    err(edges[-1], float(props.get(sname, slo)))
    if edge is not None and edge + margin < ohi:
        steps = np.geomspace(_MARGIN * (ohi - olo) / (ohi - edge), 1.0, _GRID)
        edges += list(np.minimum(edge + (ohi - edge) * steps, ohi))
    edges = sorted(set(edges))
    prof = {vo: profile(vo) for vo in edges}
    for vo in sorted(prof, key=prof.__getitem__)[:_KEEP]:
        i = edges.index(vo)
        _golden(profile, edges[max(i - 1, 0)], edges[min(i + 1, len(edges) - 1)])
    (vo, vs), e = min(seen.items(), key=lambda kv: kv[1])
    return {**props, oname: vo, sname: vs}, e


def _cone_axes(w: type[EngineWitness]):
    """((name, low, high) of the outer-edge property, the same of the shape one)."""
    outer = [p for p in w.cone_props if p[0] == w.cone_outer]
    shape = [p for p in w.cone_props if p[0] != w.cone_outer]
    if len(outer) != 1 or len(shape) != 1:
        raise ValueError(f"{w.name}: the cone search takes one outer-edge and one shape property")
    return outer[0], shape[0]


def _golden(f, a: float, b: float, n: int = _REFINE) -> float:
    """Golden-section search of `f` on [a, b] (`n` steps): the smallest value seen."""
    r = (math.sqrt(5.0) - 1.0) / 2.0
    c, d = b - r * (b - a), a + r * (b - a)
    fc, fd = f(c), f(d)
    best = min(fc, fd)
    for _ in range(n):
        if fc <= fd:
            b, d, fd = d, c, fc
            c = b - r * (b - a)
            fc = f(c)
        else:
            a, c, fc = c, d, fd
            d = a + r * (b - a)
            fd = f(d)
        best = min(best, fc, fd)
    return best


def _edge(case: _Case, props, oname, sname, olo, ohi, slo) -> float | None:
    """The smallest value of the cone's outer-edge property at which the engine's cone
    lights the outermost lit receiver (the shape property at its lower bound), by
    bisection; None when no value lights it."""
    lit = case.x.E_true > 0
    if not lit.any():
        return None
    c = np.array([float(case.cos_s[lit].min())])
    base = {**props, sname: slo}

    def lights(v: float) -> bool:
        return bool(case.w.cone(c, {**base, oname: v})[0] > 0)

    a, b = float(olo), float(ohi)
    if not lights(b):
        return None
    for _ in range(60):
        m = 0.5 * (a + b)
        a, b = (a, m) if lights(m) else (m, b)
    return b


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
    the engine's shading rounded to it (`EngineWitness.render`)."""
    case = _Case(w, light, x, *_geometry(light, x), precision)
    props = dict(props)
    mapped = case.worst(props)
    notes: list[str] = []
    tries = [props]
    if size_prop is not None:
        tries = [{**props, size_prop: 0.0}, {**props, size_prop: size_value}]
    best, best_e = props, mapped
    for p in tries:
        e = case.worst(p)
        if renders_as_spot(light) and w.cone_props and e > tolerance:
            p, e = _cone_search(case, p)
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
    errs = case.errors(best)
    if not math.isfinite(best_e):
        best_e = math.inf
    status = "pass" if best_e <= tolerance else "fail"
    verdict = EngineVerdict(best, best_e, errs, status, mapped, tuple(notes))
    if light.kind in AREA_KINDS:  # the engine's own area light, or a rescaled stand-in
        verdict = area_verdict(verdict, w, light, x, tolerance, precision)
    return verdict
