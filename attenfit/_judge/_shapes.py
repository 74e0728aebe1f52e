"""The worst case of a model on the receivers a rectangle's and a tube's lights are judged
on: a floor under a panel, a wall beside a tube (docs/area.md, "Rectangle and tube lights").

Each configuration (`SHAPE_CONFIGS`) is a light of unit size and a plane of receivers:

* **a floor under a panel**: a square panel of width `w = 1` facing down, the floor at
  `h = w/4, w, 4 w` below it, normals up; receivers out to `10 max(w, h)` from the axis.
* **a wall beside a tube**: a tube of length `l = 1` and radius `l/100` (a fluorescent
  batten's proportions), the wall parallel to its axis at `D = l/4, l, 4 l`, normals facing
  the axis; receivers out to `10 max(l, D)` along and across it.

Each model is judged as the decision table judges a floor (as `receiver_error` with receivers
"floor": the error relative to the truth at each receiver), at its worst case over the
plane: a grid over a quadrant (the light and every model are symmetric about both axes of
the plane), then a local search from the grid's largest distinct errors. The grid's truth
is computed once per configuration and grid (`shape_grid_errors`: judging many models on
one plane evaluates the exact irradiance, a quadrature for the tube, once).
"""

from __future__ import annotations

import dataclasses
import functools
import math
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._curves import AreaModel, Family, PointLight
from .._errors import BadTypeError, BadValueError
from .._float64 import in_float64
from .._truth import RectEmitter, TubeEmitter, area_irradiance, irradiance

__all__ = [
    "SHAPE_CONFIGS",
    "ShapeConfig",
    "ShapeWorst",
    "shape_config",
    "shape_grid_errors",
    "shape_worst_case",
]

#: The tube's radius over its length in the configurations (a 1.2 m batten: 13 mm).
TUBE_RADIUS = 0.01
#: How far the plane reaches, in units of the larger of the light's size and the distance.
REACH = 10.0


@dataclasses.dataclass(frozen=True)
class ShapeConfig:
    """A light of unit size and a plane of receivers (the module docstring)."""

    key: str
    label: str
    light: str  # "rect" | "tube"
    ratio: float  # h / w (a panel's floor) or D / l (a tube's wall)

    @property
    def unit(self) -> str:
        """The size lengths are given in: a panel's width `w`, a tube's length `l`."""
        return "w" if self.light == "rect" else "l"

    def emitter(self) -> RectEmitter | TubeEmitter:
        if self.light == "rect":
            return RectEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], 1.0, 1.0)
        return TubeEmitter([-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], TUBE_RADIUS)

    def receivers(self, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Points and normals at box coordinates `uv` in [0, 1]^2 (squared: denser near the
        light's axis)."""
        extent = 0.5 + REACH * max(1.0, self.ratio)
        a, b = extent * uv[:, 0] ** 2, extent * uv[:, 1] ** 2
        n = len(uv)
        if self.light == "rect":
            pts = np.stack([a, b, np.full(n, -self.ratio)], -1)
            return pts, np.tile([0.0, 0.0, 1.0], (n, 1))
        pts = np.stack([a, np.full(n, self.ratio), b], -1)
        return pts, np.tile([0.0, -1.0, 0.0], (n, 1))


SHAPE_CONFIGS: tuple[ShapeConfig, ...] = (
    ShapeConfig("panel_quarter", "floor under a panel, h = w/4", "rect", 0.25),
    ShapeConfig("panel_one", "floor under a panel, h = w", "rect", 1.0),
    ShapeConfig("panel_four", "floor under a panel, h = 4 w", "rect", 4.0),
    ShapeConfig("tube_quarter", "wall beside a tube, D = l/4", "tube", 0.25),
    ShapeConfig("tube_one", "wall beside a tube, D = l", "tube", 1.0),
    ShapeConfig("tube_four", "wall beside a tube, D = 4 l", "tube", 4.0),
)


@dataclasses.dataclass(frozen=True)
class ShapeWorst:
    """A model's worst case on one configuration: |error| relative to the truth, its sign,
    where (the receiver, in units of the light's size), and the 95th percentile of |error|
    over the grid (`typical`)."""

    model: str
    config: str
    label: str
    error: float
    signed: float
    point: tuple[float, float, float]
    typical: float
    evals: int

    def where(self) -> str:
        x, y, z = self.point
        return f"({x:.3g}, {y:.3g}, {z:.3g})"


def _name(model: Any) -> str:
    return model.family.name if isinstance(model, PointLight) else model.name


def _as_model(model: Any) -> AreaModel:
    if isinstance(model, Family):
        model = PointLight(model)
    if not isinstance(model, AreaModel):
        raise BadTypeError(f"model must be a family or an area model, got {type(model).__name__}")
    return model


def shape_config(config: ShapeConfig | str) -> ShapeConfig:
    """`config` itself, or the configuration of `SHAPE_CONFIGS` whose key it is."""
    if isinstance(config, ShapeConfig):
        return config
    found = [c for c in SHAPE_CONFIGS if c.key == config]
    if not found:
        raise BadValueError(
            f"unknown configuration {config!r}; known: {', '.join(c.key for c in SHAPE_CONFIGS)}"
        )
    return found[0]


def _uv(grid: int) -> np.ndarray:
    u = np.linspace(0.0, 1.0, grid)
    return np.stack(np.meshgrid(u, u, indexing="ij"), -1).reshape(-1, 2)


#: Receivers per compiled evaluation of the local search (the 5 x 5 grids of every start,
#: padded): one compilation of the truth and of each model per block size.
_BLOCK = 128


@eqx.filter_jit
def _truth(emitter: Any, pts: Any, nrm: Any) -> Any:
    return irradiance(emitter, pts, nrm)


@eqx.filter_jit
def predicted(model: AreaModel, emitter: Any, pts: Any, nrm: Any) -> Any:
    """A model's irradiance at receivers, compiled per model structure and light shape (the
    worst-case search's too, `_worst`)."""
    return area_irradiance(model, emitter, pts, nrm)


def _in_blocks(fn: Any, *args: Any, pts: np.ndarray, nrm: np.ndarray) -> np.ndarray:
    """`fn(*args, points, normals)` over blocks of `_BLOCK` receivers (the last padded)."""
    out = []
    for i in range(0, len(pts), _BLOCK):
        p, n = pts[i : i + _BLOCK], nrm[i : i + _BLOCK]
        k = len(p)
        p = np.concatenate([p, np.repeat(p[-1:], _BLOCK - k, axis=0)])
        n = np.concatenate([n, np.repeat(n[-1:], _BLOCK - k, axis=0)])
        out.append(np.asarray(fn(*args, jnp.asarray(p), jnp.asarray(n)))[:k])
    return np.concatenate(out).astype(np.float64)


def _f64(model: Any) -> AreaModel:
    return jax.tree_util.tree_map(
        lambda x: jnp.asarray(x, jnp.float64) if eqx.is_inexact_array_like(x) else x,
        _as_model(model),
    )


def _relative(model: AreaModel, config: ShapeConfig, pts, nrm, E: np.ndarray) -> np.ndarray:
    """The signed error relative to the truth `E` (NaN where it is not positive)."""
    Em = _in_blocks(predicted, _f64(model), config.emitter(), pts=pts, nrm=nrm)
    ok = np.isfinite(E) & (E > 0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return np.where(ok, (Em - E) / np.where(ok, E, 1.0), np.nan)


@in_float64
def _errors(model: Any, config: ShapeConfig, uv: np.ndarray) -> np.ndarray:
    """The signed error at box coordinates `uv` (the truth evaluated here)."""
    pts, nrm = config.receivers(np.clip(uv, 0.0, 1.0))
    E = _in_blocks(_truth, config.emitter(), pts=pts, nrm=nrm)
    return _relative(model, config, pts, nrm, E)


@functools.lru_cache(maxsize=16)
@in_float64
def _grid_truth(config: ShapeConfig, grid: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(points, normals, exact irradiance) of the `grid` x `grid` receivers over a quadrant."""
    pts, nrm = config.receivers(_uv(grid))
    return pts, nrm, _in_blocks(_truth, config.emitter(), pts=pts, nrm=nrm)


@in_float64
def shape_grid_errors(model: Any, config: ShapeConfig | str, grid: int = 33) -> np.ndarray:
    """The signed error of `model` relative to the truth at the `grid` x `grid` receivers of
    `config`'s quadrant (the worst-case search's grid; NaN where the truth is not positive),
    flattened; its largest |value| is a lower bound of `shape_worst_case`'s. The truth is
    computed once per configuration and grid, then kept."""
    config = shape_config(config)
    pts, nrm, E = _grid_truth(config, int(grid))
    return _relative(_as_model(model), config, pts, nrm, E)


def _refine(model, config, x: np.ndarray, f: np.ndarray, step: float, levels: int):
    """A 5 x 5 local grid around each start `x` (k, 2), narrowed 4 times per level, every
    start's grid in one evaluation; (best x per start, their |error|, evals)."""
    evals = 0
    offsets = np.stack(np.meshgrid(*[np.linspace(-1, 1, 5)] * 2, indexing="ij"), -1)
    offsets = offsets.reshape(-1, 2)
    x, f = np.array(x, dtype=np.float64), np.array(f, dtype=np.float64)
    for _ in range(levels):
        trial = np.clip(x[:, None, :] + step * offsets[None], 0.0, 1.0)
        e = np.abs(np.nan_to_num(_errors(model, config, trial.reshape(-1, 2)), nan=-1.0))
        e = e.reshape(len(x), -1)
        evals += e.size
        i = np.argmax(e, axis=1)
        up = e[np.arange(len(x)), i] > f
        x[up], f[up] = trial[up, i[up]], e[up, i[up]]
        step /= 4
    return x, f, evals


@in_float64
def shape_worst_case(
    model: Any, config: ShapeConfig | str, *, grid: int = 33, seeds: int = 3, levels: int = 4
) -> ShapeWorst:
    """The largest |error| of `model` (a distance family, judged as the point-light model, or
    an area model written for the configuration's light or for any) on `config` (a
    `ShapeConfig` or its key), and where it lies."""
    config = shape_config(config)
    model = _as_model(model)
    uv = _uv(grid)
    e = shape_grid_errors(model, config, grid)
    a = np.abs(np.nan_to_num(e, nan=-1.0))
    evals = len(uv)
    order = np.argsort(-a)
    starts: list[int] = []
    for i in order:
        if len(starts) == seeds:
            break
        if all(np.max(np.abs(uv[i] - uv[j])) > 2.5 / (grid - 1) for j in starts):
            starts.append(int(i))
    best_x, best_f = uv[order[0]], float(a[order[0]])
    xs, fs, k = _refine(model, config, uv[starts], a[starts], 1.0 / (grid - 1), levels)
    evals += k
    for x, f in zip(xs, fs, strict=True):
        if f > best_f:
            best_x, best_f = x, float(f)
    if not best_f >= 0:
        raise BadValueError(f"no receiver of {config.key} has a defined error")
    signed = float(_errors(model, config, best_x[None])[0])
    pts, _ = config.receivers(best_x[None])
    ok = a[a >= 0]
    typical = float(np.quantile(ok, 0.95)) if ok.size else math.nan
    return ShapeWorst(
        _name(model),
        config.key,
        config.label,
        best_f,
        signed,
        tuple(float(v) for v in pts[0]),  # type: ignore[arg-type]
        typical,
        evals,
    )
