"""The engine's closest settings for a light: one search over every property the engine
exposes for it, judged through the engine witness (`attenfit._judge._engine_shading`) with
the worst-case judge at the light's judged receivers.

The properties (`_prop_axes`, `_cone_axes`): the spot cone's outer edge and shape (`EngineWitness.cone_props`,
within the engine's bounds), and `EngineWitness.search_props`: the range (from the nearest
receiver to 1e3 x the farthest, where the window is 1 to 2e-12 at every receiver), the
distance exponent (Godot's `*_attenuation`, three.js's `decay`, Unreal's
`LightFalloffExponent`, within the engine's bounds), Unreal's exponent-mode brightness (1/100
to 100 x the mapped one) and the light size that reaches the diffuse term (Godot's
`light_size`, Unreal's `SourceRadius`: 0 to the farthest receiver). The mode the fitted
family sets (Unreal's `bUseInverseSquaredFalloff`) is kept.

The search (`search`):
1. a grid over the joint box (per property a few values across its bounds, the
   mapped value, and values where the error changes fast: near the mapped exponent, sizes
   near 0, ranges just past the farthest receiver, and the cone's edge at log-spaced
   offsets past the outermost lit receiver (`_edge`), where the largest error has narrow
   valleys between a plateau at 100% and the cone's flat inside);
2. its exact best cells (`_Grid.best`): the engine's rendering is a product of three
   factors, each a function of its own properties (`EngineWitness.render`: distance x
   diffuse x cone), so each is tabulated once per grid value at every receiver and the grid
   is the product of the tables. Judged on a growing set of receivers (an exchange: the
   worst receivers of the best cells join it) until the best cell's error on the set is its
   error over all receivers, the grid's best is exact;
3. from the `_STARTS` best cells, in coordinates of the box scaled per property (log for a
   range, a brightness and `cone_log`, square root for a size), first Nelder-Mead
   (`_nelder_mead_at`: its first steps the grid's spacing there; judged at the receivers
   that matter, grown until its result's error there is its error everywhere), then a
   descent (`_descend`) on 3^k product grids around the point (every combination of -h, 0
   and +h per property, judged exactly as in 2.), moving to the best cell while it is
   better and halving h when none is, down to 1e-9 of the box: Nelder-Mead follows the
   diagonal valleys of the largest error, the descent settles it where no nearby grid
   point renders closer (the largest error is not smooth, where Nelder-Mead can stall).

The answer is the best setting reached, never worse than the mapping. The largest error
can have several valleys (a window whose range sits just past the farthest lit receiver
shapes a floor's light like a cone): the answer is the best of the grid's best cells,
refined, not a proof of the best between grid points. tests/test_engine_search.py checks it
against brute-force grids over the same box and fine ones around the answer: none renders
closer by more than 0.1% (relative).
"""

from __future__ import annotations

import dataclasses
import itertools
import json
import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from .. import _cache
from .._judge import EngineWitness, engine_receiver_errors
from ._light_fits import LightData
from ._types import SceneLight

__all__ = ["Case", "at_centre", "geometry", "renders_as_spot", "search"]

#: grid values per property across its bounds (`_axes`)
_N_EDGE, _N_SHAPE, _N_SIZE, _N_SPAN = 12, 10, 6, 5
#: the cone's edge is kept at least this fraction of its property's span past the outermost
#: lit receiver: 1.6e-6 rad for an angle in radians, which moves the cosine 30 degrees off
#: the axis by 7.9e-7, 13 float32 steps there (float32 rounds a cosine by 6e-8).
_MARGIN = 1e-6
#: the grid's cells refined (`search`); Nelder-Mead's evaluations per property and run;
#: the descent's most steps and smallest step (`_descend`)
_STARTS, _NM_EVALS, _STEPS, _H_MIN = 3, 60, 60, 1e-9
#: grid elements (cells x receivers) judged at once
_CHUNK = 1 << 21


def renders_as_spot(light: SceneLight) -> bool:
    """A spot, and a disk or a rectangle (their emission cosine: a cone is the engine's only
    way to it)."""
    return light.is_spot or light.kind in ("disk", "rect")


def at_centre(light: SceneLight, x: LightData) -> LightData:
    """`x` with each receiver's distance from the light's centre, where an engine's point
    light sits and whence the engine renders it: a capsule's judged receivers carry their
    distance to its segment (`LightData.d`), which no engine's point light sees."""
    if light.kind != "capsule" or x.points is None:
        return x
    rel = x.points - np.asarray(light.position, np.float64)[None, :]
    return dataclasses.replace(x, d=np.linalg.norm(rel, axis=1))


def geometry(light: SceneLight, x: LightData) -> tuple[np.ndarray, np.ndarray]:
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
class Case:
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

    def sub(self, idx: np.ndarray) -> Case:
        """The same light at its receivers `idx` only."""
        x = self.x
        per_receiver = ("d", "wpt", "E_true", "E_irr", "cos_s", "theta", "denom")
        xs = dataclasses.replace(
            x,
            **{k: getattr(x, k)[idx] for k in per_receiver},
            points=None if x.points is None else x.points[idx],
            normals=None if x.normals is None else x.normals[idx],
        )
        return dataclasses.replace(self, x=xs, cos_s=self.cos_s[idx], n_dot_l=self.n_dot_l[idx])

    def factor(self, which: int, props: Mapping[str, Any]) -> np.ndarray:
        """The witness's factor `which` (0 distance, 1 diffuse, 2 cone) at every receiver,
        at the scene's precision, as `EngineWitness.render` computes it."""
        dt = np.dtype(self.precision)
        d = np.asarray(self.x.d, np.float64).astype(dt)
        with np.errstate(over="ignore", invalid="ignore", divide="ignore"):
            if which == 0:
                return np.asarray(self.w.distance(d, props), dt)
            if which == 1:
                return np.asarray(self.w.diffuse(self.n_dot_l.astype(dt), d, props), dt)
            if renders_as_spot(self.light):
                return np.asarray(self.w.cone(np.asarray(self.cos_s).astype(dt), props), dt)
            return np.ones_like(d)

    def judged(
        self, rendered: np.ndarray, idx: np.ndarray, intensity: float, worst: bool = False
    ) -> np.ndarray:
        """`engine_receiver_errors` of `rendered` (E / I at the receivers `idx`, last axis;
        I = `intensity`), or (`worst`) their largest over that axis."""
        x = self.x
        with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
            err = np.asarray(rendered, np.float64) * intensity
            err -= x.E_true[idx]
            np.abs(err, out=err)
            err /= x.denom[idx]
        if worst:  # a NaN's largest is NaN: inf, as engine_receiver_errors reads it
            m = err.max(-1)
            return np.where(np.isnan(m), np.inf, m)
        return np.where(np.isfinite(err), err, np.inf)


@dataclasses.dataclass(frozen=True)
class _Axis:
    """One property searched: its factor (0 distance, 1 diffuse, 2 cone), its box
    `[lo, hi]` with the coordinate `u` in [0, 1] linear in the value, its log (`log`) or
    its square root (`sq`: a size, dense near 0), and its grid values."""

    name: str
    factor: int
    lo: float
    hi: float
    scale: str
    grid: tuple[float, ...]

    def value(self, u: float) -> float:
        u = min(max(float(u), 0.0), 1.0)
        if self.scale == "log":
            return float(math.exp(math.log(self.lo) + (math.log(self.hi) - math.log(self.lo)) * u))
        return self.lo + (self.hi - self.lo) * (u * u if self.scale == "sq" else u)

    def coord(self, v: float) -> float:
        if self.hi <= self.lo:
            return 0.0
        if self.scale == "log":
            return math.log(v / self.lo) / math.log(self.hi / self.lo)
        t = (v - self.lo) / (self.hi - self.lo)
        return math.sqrt(max(t, 0.0)) if self.scale == "sq" else t


def _axis(name, factor, lo, hi, scale, values) -> _Axis:
    grid = sorted({float(min(max(v, lo), hi)) for v in values if math.isfinite(v)})
    return _Axis(name, factor, float(lo), float(hi), scale, tuple(grid))


def _prop_axes(case: Case, props: Mapping[str, Any], size_value: float) -> list[_Axis]:
    """The axes of `EngineWitness.search_props` present in `props` (module docstring)."""
    near, far = float(case.x.d.min()), float(case.x.d.max())
    axes = []
    for name, role, unit, lo, hi in case.w.search_props:
        if name not in props:
            continue
        v0 = float(props[name])
        if role == "range":
            lo, hi = max(lo, near * unit), min(hi, 1e3 * far * unit)
            past = far * unit * np.array([1.02, 1.1, 1.25, 1.5, 2.0, 3.0, 5.0, 1e3])
            grid = [*np.geomspace(lo, far * unit, 4), *past, v0]
            axes.append(_axis(name, 0, lo, hi, "log", grid))
        elif role == "decay":
            off = np.array([0.05, 0.25, 1.0])
            grid = [*np.linspace(lo, hi, _N_SPAN), v0, *(v0 + off), *(v0 - off)]
            axes.append(_axis(name, 0, lo, hi, "lin", grid))
        elif role == "scale":
            lo, hi = max(lo, 1e-2 * v0), min(hi, 1e2 * v0)
            axes.append(_axis(name, 0, lo, hi, "log", [*np.geomspace(lo, hi, 7), v0]))
        elif role == "size":
            hi = min(hi, far * unit)
            grid = [*(hi * np.linspace(0.0, 1.0, _N_SIZE) ** 2), v0, size_value]
            axes.append(_axis(name, 1, lo, hi, "sq", grid))
        else:
            raise ValueError(f"{case.w.name}: unknown search role {role!r} of {name}")
    return axes


def _cone_axes(case: Case, props: Mapping[str, Any]) -> tuple[list[_Axis], float | None]:
    """The cone's edge and shape axes, and the edge past the outermost lit receiver."""
    w = case.w
    if not (renders_as_spot(case.light) and w.cone_props):
        return [], None
    outer = [p for p in w.cone_props if p[0] == w.cone_outer]
    shape = [p for p in w.cone_props if p[0] != w.cone_outer]
    if len(outer) != 1 or len(shape) != 1:
        raise ValueError(f"{w.name}: the cone search takes one outer-edge and one shape property")
    (oname, olo, ohi), (sname, slo, shi) = outer[0], shape[0]
    edge = _edge(case, props, oname, sname, olo, ohi, slo)
    edges = [*np.linspace(olo, ohi, _N_EDGE), float(props.get(oname, olo))]
    if edge is not None and edge + _MARGIN * (ohi - olo) < ohi:
        steps = np.geomspace(_MARGIN * (ohi - olo) / (ohi - edge), 1.0, _N_EDGE)
        edges += list(edge + (ohi - edge) * steps)
    log = sname in w.cone_log
    shapes = np.geomspace(slo, shi, _N_SHAPE) if log else np.linspace(slo, shi, _N_SHAPE)
    return [
        _axis(oname, 2, olo, ohi, "lin", edges),
        _axis(sname, 2, slo, shi, "log" if log else "lin", [*shapes, props.get(sname, slo)]),
    ], edge


def _edge(case: Case, props, oname, sname, olo, ohi, slo) -> float | None:
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


@dataclasses.dataclass(frozen=True)
class _Grid:
    """A product grid of property values (per axis of `axes`, `values`), judged through the
    witness's three factors: per factor, the factor at every receiver for each combination
    of its axes' values (`tables`, rows in `itertools.product` order); a cell (a flat index
    of the tables' product) renders the product of its rows, as `EngineWitness.render`."""

    case: Case
    groups: tuple[tuple[int, ...], ...]  # per factor, the indices of its axes
    sizes: tuple[int, ...]  # per axis, its number of values
    tables: tuple[np.ndarray, ...]
    intensity: float  # the one the properties state, else the light's (no axis moves it)

    @classmethod
    def of(cls, case: Case, props, axes: list[_Axis], values, guard) -> _Grid:
        groups, tables = [], []
        for f in range(3):
            group = tuple(i for i, a in enumerate(axes) if a.factor == f)
            rows = []
            for combo in itertools.product(*(values[i] for i in group)):
                p = {**props, **{axes[i].name: v for i, v in zip(group, combo, strict=True)}}
                rows.append(case.factor(f, guard(p)))
            groups.append(group)
            tables.append(np.stack(rows))
        intensity = case.w.intensity_of(props, case.light.intensity)
        return cls(case, tuple(groups), tuple(len(v) for v in values), tuple(tables), intensity)

    def position(self, flat: int) -> list[int]:
        """Per axis, the index of cell `flat`'s value."""
        pos = [0] * len(self.sizes)
        rows = np.unravel_index(flat, [t.shape[0] for t in self.tables])
        for group, row in zip(self.groups, rows, strict=True):
            if group:
                sub = np.unravel_index(row, [self.sizes[i] for i in group])
                for i, j in zip(group, sub, strict=True):
                    pos[i] = int(j)
        return pos

    def errors(self, flat: np.ndarray, idx: np.ndarray) -> np.ndarray:
        """The judged errors of cells `flat` at the receivers `idx`."""
        i0, i1, i2 = np.unravel_index(flat, [t.shape[0] for t in self.tables])
        t0, t1, t2 = (t[:, idx] for t in self.tables)
        out = np.empty((flat.size, idx.size))
        step = max(1, _CHUNK // max(idx.size, 1))
        for s in range(0, flat.size, step):
            sl = slice(s, s + step)
            out[sl] = self.case.judged(t0[i0[sl]] * t1[i1[sl]] * t2[i2[sl]], idx, self.intensity)
        return out

    def worst(self, idx: np.ndarray) -> np.ndarray:
        """Every cell's largest judged error at the receivers `idx`."""
        t0, t1, t2 = (t[:, idx] for t in self.tables)
        ds = (t0[:, None, :] * t1[None, :, :]).reshape(-1, idx.size)
        out = np.empty((ds.shape[0], t2.shape[0]))
        step = max(1, _CHUNK // (t2.shape[0] * idx.size))
        for s in range(0, ds.shape[0], step):
            prod = ds[s : s + step, None, :] * t2[None]
            out[s : s + step] = self.case.judged(prod, idx, self.intensity, worst=True)
        return out.reshape(-1)

    def best(self, seen: np.ndarray) -> tuple[list[tuple[float, int]], np.ndarray]:
        """(cells with their errors over every receiver, best first; the receivers judged):
        the first is the grid's exact best. Every cell is judged at the receivers `seen`
        (its largest error there bounds its largest below); the best few are judged at
        every receiver, and their worst receivers join `seen`, until the best cell's bound
        is its error (module docstring, 2.)."""
        everyone = np.arange(self.case.x.d.size)
        lb = self.worst(seen)
        exact: dict[int, float] = {}
        for _ in range(64):
            top = np.argsort(lb, kind="stable")[:4]
            worst_receivers = []
            for c in (int(c) for c in top if int(c) not in exact):
                e = self.errors(np.array([c]), everyone)[0]
                exact[c] = float(e.max())
                worst_receivers += list(np.argsort(e)[-2:])
            best = int(top[0])
            new = np.setdiff1d(np.asarray(worst_receivers, int), seen)
            if exact[best] <= lb[best] or new.size == 0:
                break
            cand = np.flatnonzero(lb < min(exact.values()))
            lb[cand] = np.maximum(lb[cand], self.errors(cand, new).max(-1))
            seen = np.union1d(seen, new)
        return sorted((e, c) for c, e in exact.items()), seen


def _first_receivers(case: Case, props) -> np.ndarray:
    """The receivers the exchange starts from: the mapping's worst, the extremes of
    distance, angle, n.l and irradiance, and a spread in distance and angle."""
    n = case.x.d.size
    e = case.errors(props)
    picks = [np.argsort(e)[-16:]]
    for v in (case.x.d, case.cos_s, case.n_dot_l, case.x.E_true):
        order = np.argsort(v, kind="stable")
        picks.append(order[np.linspace(0, n - 1, 24).astype(int)])
    lit = np.flatnonzero(case.x.E_true > 0)
    if lit.size:
        picks.append(lit[[int(np.argmin(case.cos_s[lit]))]])
    return np.unique(np.concatenate(picks))


def search(case: Case, props: Mapping[str, Any], size_value: float = 0.0):
    """The engine's closest settings from the mapping `props` (module docstring): (props,
    their largest error through the witness), never worse than `props`'. A search of the
    same case from the same mapping (an unchanged scene asked again) is read from attenfit's
    cache, by its exact inputs."""
    key = _cache.fingerprint("engine-search", case, dict(props), float(size_value))
    payload = _cache.read("engine-search", key)
    if payload is not None:
        found = json.loads(payload)
        return {**props, **found["props"]}, float(found["error"])
    best, error = _search(case, props, size_value)
    if all(isinstance(v, bool | int | float | str) for v in best.values()):
        _cache.write("engine-search", key, json.dumps({"props": best, "error": error}).encode())
    return best, error


def _search(case: Case, props: Mapping[str, Any], size_value: float):
    props = dict(props)
    cone, edge = _cone_axes(case, props)
    axes = _prop_axes(case, props, size_value) + cone
    start_e = case.worst(props)
    if not axes or case.x.d.size == 0:
        return props, start_e

    def guard(p: dict[str, Any]) -> dict[str, Any]:
        if edge is not None:  # float32 rounding of a receiver's cosine cannot cross it
            a = cone[0]
            margin = _MARGIN * (a.hi - a.lo)
            if edge < p[a.name] < edge + margin:
                p[a.name] = edge + margin
        return p

    def at(u: np.ndarray) -> dict[str, Any]:  # the properties judged at coordinates u
        u = np.round(np.clip(u, 0.0, 1.0), 15)
        return guard({**props, **{a.name: a.value(v) for a, v in zip(axes, u, strict=True)}})

    grid = _Grid.of(case, props, axes, [a.grid for a in axes], guard)
    ranked, seen = grid.best(_first_receivers(case, props))
    best_p, best_e = props, start_e
    starts: list[np.ndarray] = []
    for _, flat in ranked:
        values = [a.grid[j] for a, j in zip(axes, grid.position(flat), strict=True)]
        u0 = np.array([a.coord(v) for a, v in zip(axes, values, strict=True)])
        if any(np.abs(u0 - s).max() < 0.05 for s in starts):
            continue
        starts.append(u0)
        # first steps: the grid's spacing (at least 1/50 of the box, but at the cone's edge)
        h = np.array([_spacing(a, v) if edge is not None and a is cone[0] else
                      max(_spacing(a, v), 0.02) for a, v in zip(axes, values, strict=True)])  # fmt: skip
        u, seen = _nelder_mead_at(case, at, u0, h, seen)
        u, seen = _descend(case, props, axes, guard, u, 0.25 * h, seen)
        p = at(u)
        e = case.worst(p)
        if e < best_e:
            best_p, best_e = p, e
        if len(starts) == _STARTS:
            break
    return _tightest_range(case, best_p, best_e)


#: How much worse (relative) a smaller range may render and still be taken: a tenth of the
#: search's stated resolution (1e-3, `tests/test_engine_search.py`).
_RANGE_SLACK = 1e-4


def _tightest_range(case: Case, p: dict[str, Any], e: float) -> tuple[dict[str, Any], float]:
    """`p` with its range brought down to the smallest (to 1e-6 relative, above the nearest
    receiver) that renders within `_RANGE_SLACK` of `e`, and its error: past the
    farthest receiver a window is nearly 1, the error is nearly flat there, and a search may
    stop anywhere on it (a room would get a range of kilometres)."""
    for name, role, unit, lo, _hi in case.w.search_props:
        if role == "range" and name in p:
            a, b = max(lo, float(case.x.d.min()) * unit), float(p[name])
            while b > a * (1 + 1e-6):  # log bisection; b always renders within the bound
                m = math.sqrt(a * b)
                a, b = (a, m) if case.worst({**p, name: m}) <= e * (1 + _RANGE_SLACK) else (m, b)
            p = {**p, name: b}
    return p, case.worst(p)


def _descend(case: Case, props, axes, guard, u: np.ndarray, h: np.ndarray, seen: np.ndarray):
    """From `u` (coordinates of the box), the best cell of the 3^k grid `u` + {-h, 0, h}
    (a product grid, `_Grid`: its exact best) is taken while it is better than `u`, the
    steps then growing by 5/4 (to 1/4 of the box); else the steps halve, down to `_H_MIN`
    (module docstring, 3.). (the point reached, the receivers judged)."""
    everyone = np.arange(case.x.d.size)
    u = np.clip(u, 0.0, 1.0)
    for _ in range(_STEPS):
        offs = [sorted({min(max(ui + s * hi, 0.0), 1.0) for s in (-1.0, 0.0, 1.0)})
                for ui, hi in zip(u, h, strict=True)]  # fmt: skip
        grid = _Grid.of(
            case,
            props,
            axes,
            [[a.value(o) for o in off] for a, off in zip(axes, offs, strict=True)],
            guard,
        )
        ranked, seen = grid.best(seen)
        e, flat = ranked[0]
        centre = [off.index(ui) for off, ui in zip(offs, u, strict=True)]
        c = int(np.ravel_multi_index(_rows(grid, centre), [t.shape[0] for t in grid.tables]))
        if e < float(grid.errors(np.array([c]), everyone).max()):
            u = np.array([off[j] for off, j in zip(offs, grid.position(flat), strict=True)])
            h = np.minimum(1.25 * h, 0.25)
        else:
            h = 0.5 * h
            if h.max() < _H_MIN:
                break
    return u, seen


def _rows(grid: _Grid, pos: list[int]) -> tuple[int, ...]:
    """Per factor, the table row of the axes' value indices `pos`."""
    return tuple(
        int(np.ravel_multi_index([pos[i] for i in g], [grid.sizes[i] for i in g])) if g else 0
        for g in grid.groups
    )


def _nelder_mead(f, u0: np.ndarray, step: np.ndarray, evals: int) -> tuple[np.ndarray, float]:
    """Nelder-Mead (reflection 1, expansion 2, contraction and shrink 1/2) of `f` on the
    unit box from `u0`, its first simplex `step` along each coordinate (away from the
    nearer face): (the best point, its value) after at most `evals` evaluations."""
    k = u0.size
    pts = [u0]
    for i in range(k):
        p = u0.copy()
        p[i] = p[i] + step[i] if p[i] + step[i] <= 1.0 else p[i] - step[i]
        pts.append(p)
    sim = np.clip(np.array(pts), 0.0, 1.0)
    val = np.array([f(p) for p in sim])
    used = k + 1
    while used < evals:
        order = np.argsort(val, kind="stable")
        sim, val = sim[order], val[order]
        if val[-1] - val[0] <= 1e-6 * val[0] + 1e-12 and np.all(np.ptp(sim, 0) <= 1e-3 * step):
            break  # flat and small: a millionth of the error, a thousandth of the first steps
        centre = sim[:-1].mean(0)
        r = np.clip(2 * centre - sim[-1], 0.0, 1.0)
        fr = f(r)
        used += 1
        if fr < val[0]:
            e = np.clip(3 * centre - 2 * sim[-1], 0.0, 1.0)
            fe = f(e)
            used += 1
            sim[-1], val[-1] = (e, fe) if fe < fr else (r, fr)
        elif fr < val[-2]:
            sim[-1], val[-1] = r, fr
        else:
            c = 0.5 * (centre + (r if fr < val[-1] else sim[-1]))
            fc = f(c)
            used += 1
            if fc < min(fr, val[-1]):
                sim[-1], val[-1] = c, fc
            else:  # shrink towards the best
                sim[1:] = 0.5 * (sim[1:] + sim[0])
                val[1:] = [f(p) for p in sim[1:]]
                used += k
    i = int(np.argmin(val))
    return sim[i], float(val[i])


def _nelder_mead_at(case: Case, at, u0: np.ndarray, step: np.ndarray, seen: np.ndarray):
    """Nelder-Mead from `u0` (and a restart at a quarter of its steps) judged at a set of
    receivers (`seen`, and the start's worst), grown by the worst receivers of its result
    until that result's error over them is its error over all: (the point reached, the
    receivers judged)."""
    idx = np.union1d(seen, np.argsort(case.errors(at(u0)))[-16:])
    u = u0
    for _ in range(4):
        f = _memo_worst(case.sub(idx), at)
        u, e = _nelder_mead(f, u, step, _NM_EVALS * u.size)
        u, e = _nelder_mead(f, u, 0.25 * step, _NM_EVALS * u.size)
        full = case.errors(at(u))
        new = np.setdiff1d(np.argsort(full)[-32:], idx)
        if full.size == 0 or float(full.max()) <= e * (1 + 1e-12) or new.size == 0:
            break
        idx, step = np.union1d(idx, new), 0.5 * step
    return u, idx


def _memo_worst(case: Case, at):
    """u -> the largest error of `at(u)` at `case`'s receivers, each point judged once."""
    memo: dict[tuple[float, ...], float] = {}

    def f(u: np.ndarray) -> float:
        k = tuple(np.round(np.clip(u, 0.0, 1.0), 15))
        if k not in memo:
            memo[k] = case.worst(at(np.array(k)))
        return memo[k]

    return f


def _spacing(a: _Axis, v: float) -> float:
    """The grid's spacing at `v` on axis `a`, in its coordinate (the descent's first step)."""
    u = a.coord(v)
    gaps = [abs(a.coord(g) - u) for g in a.grid]
    gaps = [g for g in gaps if g > 1e-15]
    return min(gaps) if gaps else 0.05
