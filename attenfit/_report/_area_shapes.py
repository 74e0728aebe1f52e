"""The rectangle's and the tube's rows of the report (`attenfit report --emitters rect,tube`,
`build_report(shapes=...)`; docs/area.md, "Rectangle and tube lights"): their ceiling and
their decision rows.

Their receivers are the judge's configurations (`attenfit._judge.SHAPE_CONFIGS`): floors
under a square panel of width `w` at h = w/4, w, 4 w, and walls beside a tube of length `l`
at D = l/4, l, 4 l. Each is a band of the decision table; a model's error there is its worst
case over the plane (`attenfit._judge.shape_worst_case`), its typical error the 95th
percentile over the search's grid.

The candidates:

* every family through the point-light model, on the light's facing sweep (`shape_sweep`:
  a sweep-only configuration, whose rows `_build` makes as it makes every light's: as
  published for the light's radius r, and fitted); a window is judged only on planes that
  lie within half its range;
* every area model written for the light (`AreaModel.light`), as shipped.

The ceiling (`shapes_data`, `shapes_markdown`): per configuration the best f(d) (the
closest by `attenfit._judge.rank` of the `_verify.CLOSEST_SEARCHED` curves closest on the
grid, by their worst cases) and
every area model, with its worst case, where, typical error and compiled cost. The
decision: per configuration and tolerance, `_decide.decide_cell`, ranked by
`attenfit._judge.rank` as every other row, the worst cases from `ShapeVerifier`.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._curves import PointLight, get_area_model, list_area_models
from .._judge import (
    SHAPE_CONFIGS,
    Contender,
    ShapeConfig,
    rank,
    shape_config,
    shape_grid_errors,
    shape_worst_case,
)
from .._truth import facing_sweep
from ._area_candidates import _cost as area_cost
from ._candidates import Candidate
from ._configs import Config, Sweep
from ._decide import TOLERANCES, TYPICAL_HEADER, _absolute, decide_cell, params_in_r
from ._markdown import fmt_num, fmt_pct, md_row
from ._published import range_of
from ._verify import CLOSEST_SEARCHED, Found, Verifier

__all__ = [
    "SHAPE_GRID",
    "SHAPE_LIGHTS",
    "ShapeVerifier",
    "shape_sweep",
    "shapes_data",
    "shapes_markdown",
    "split_shapes",
]

#: The lights the judge has configurations for, in its order ("rect", "tube").
SHAPE_LIGHTS: tuple[str, ...] = tuple(dict.fromkeys(c.light for c in SHAPE_CONFIGS))
#: Grid points per side of the worst-case search's grid (`shape_worst_case`'s default).
SHAPE_GRID = 33


def _configs_of(light: str) -> list[ShapeConfig]:
    return [c for c in SHAPE_CONFIGS if c.light == light]


def _reach(config: ShapeConfig, corner: float) -> float:
    """The distance from the light's centre of the plane's receiver at box corner (c, c)."""
    pts, _ = config.receivers(np.array([[corner, corner]]))
    return float(np.linalg.norm(pts[0]))


def shape_sweep(light: str, n: int) -> Config:
    """A sweep-only configuration of `light` (its unit-size emitter of the judge's
    configurations): `n` receivers facing it, log-spaced from half the nearest receiver of
    its planes to twice the farthest, with the exact attenuation there."""
    configs = _configs_of(light)
    emitter = configs[0].emitter()
    lo = 0.5 * min(_reach(c, 0.0) for c in configs)
    hi = 2.0 * max(_reach(c, 1.0) for c in configs)
    ds = facing_sweep(emitter, lo, hi, n, dtype=np.float64)
    d, truth = np.asarray(ds.distance(), np.float64), np.asarray(ds.attenuation(), np.float64)
    sweep = Sweep(d, truth, None, None, float(np.max(truth)),
                  f"receivers facing the {light}, {n} distances from {lo:.3g} to {hi:.3g}")  # fmt: skip
    return Config(light, light, emitter, float(emitter.radius), sweep, None,
                  "attenfit.irradiance (exact)")  # fmt: skip


def _grid_worst(model: Any, config: ShapeConfig, grid: int) -> float | None:
    """The largest |error| on the search's grid (a lower bound of the worst case)."""
    e = np.abs(shape_grid_errors(model, config, grid))
    return float(np.nanmax(e)) if np.any(np.isfinite(e)) else None


def _curve_candidates(sweep: Config, models, results, grid: int) -> list[Candidate]:
    """Every family's rows on the light's sweep, judged on each plane's grid."""
    from .._curves import get_family
    from .._shaders import area_compiled_cost

    configs = _configs_of(sweep.kind)
    costs: dict[str, float | None] = {}
    out = []
    for row in results:
        if row["config"] != sweep.name or row["status"] != "ok":
            continue
        fam, mode = row["family"], row["mode"]
        model = PointLight(models[(fam, sweep.name, mode)])
        if fam not in costs:
            try:
                costs[fam] = area_compiled_cost(PointLight(get_family(fam)())).cost
            except (ValueError, TypeError):  # no shader form
                costs[fam] = None
        rng = range_of(model.family)
        errors = {
            c.key: _grid_worst(model, c, grid)
            if rng is None or 0.5 * rng >= _reach(c, 1.0)
            else None  # a window is judged only within half its range
            for c in configs
        }
        absolute = _absolute(None, fam, sweep) if mode == "published" else ()
        out.append(
            Candidate(
                model=fam,
                mode=mode,
                params=params_in_r(fam, row.get("params"), sweep.radius, absolute),
                cost=costs[fam],
                errors=errors,
                worst=dict.fromkeys(errors),
                n_params=len(row.get("params") or {}),
                build=lambda model=model: model,
            )
        )
    return out


def _params(model: Any) -> str:
    """An area model's parameters in words, or the inputs it reads (`input_names`)."""
    values = model.params()
    if not values:
        return f"none (reads {', '.join(type(model).input_names)})"
    return ", ".join(f"{k} = {float(np.asarray(v)):.4g}" for k, v in values.items())


def _model_candidates(light: str, grid: int) -> list[Candidate]:
    """The area models written for `light`, as shipped, judged on each plane's grid."""
    out = []
    for name in list_area_models():
        if get_area_model(name).light != light:
            continue
        model = get_area_model(name)()
        errors = {c.key: _grid_worst(model, c, grid) for c in _configs_of(light)}
        out.append(
            Candidate(
                model=name,
                mode="published",
                params=_params(model),
                cost=area_cost(name),
                errors=errors,
                worst=dict.fromkeys(errors),
                kind="area model",
                n_params=len(model.params()),
                build=lambda model=model: model,
            )
        )
    return out


class ShapeVerifier(Verifier):
    """Worst cases on the judge's planes: the band is a configuration's key, the search
    `shape_worst_case` (kept in attenfit's cache as the decision's, by model, light, plane
    and grid)."""

    def __init__(self, cfg: Config, grid: int = SHAPE_GRID):
        super().__init__(cfg)
        self.grid = int(grid)

    def _key(self, model: Any, band: str) -> str:
        key = json.loads(super()._key(model, band))
        key.update(judge="shape_worst_case", grid=self.grid,
                   plane=dataclasses.asdict(shape_config(band)))  # fmt: skip
        return json.dumps(key, sort_keys=True)

    def _measure(self, model: Any, band: str) -> Found | None:
        config = shape_config(band)
        w = shape_worst_case(model, config, grid=self.grid)
        return Found(float(w.error), f"at {w.where()} {config.unit}", float(w.typical))


def _cell(c: Candidate, w: Found) -> dict[str, Any]:
    """A ceiling cell: the model (`values`: its parameters, a point light's its family's),
    its worst case, where, typical error and cost."""
    model = c.build() if c.build is not None else None
    inner = model.family if isinstance(model, PointLight) else model
    values = {} if inner is None else {k: np.asarray(v).tolist() for k, v in inner.params().items()}
    return {"name": c.model, "mode": c.mode, "kind": c.kind, "params": c.params,
            "values": values, "error": w.error, "where": w.where(), "typical": w.typical,
            "cost": c.cost}  # fmt: skip


def _ceiling_row(config: ShapeConfig, curves, areas, check: ShapeVerifier) -> dict[str, Any]:
    judged = sorted((c for c in curves if c.errors.get(config.key) is not None),
                    key=lambda c: c.errors[config.key])  # fmt: skip
    searched = [(c, check.worst(c, config.key)) for c in judged[:CLOSEST_SEARCHED]]
    closest = rank(
        (Contender(c.label, w.error, c.cost, c.n_params, item=(c, w)) for c, w in searched if w),
        0.0,
    ).closest  # the one ranking: error to 3 digits, then cost, parameters, name
    best = None if closest is None else closest.item
    models = [(c, check.worst(c, config.key)) for c in areas]
    return {
        "config": config.key,
        "label": config.label,
        "light": config.light,
        "best_fd": None if best is None else _cell(*best),
        "models": [_cell(c, w) for c, w in models if w is not None],
    }


def shapes_data(
    sweeps: Sequence[Config], models: Mapping, results: Sequence[Mapping], *, grid: int, say=None
) -> dict[str, Any]:
    """The ceiling rows and the decision entries of the lights of `sweeps` (`shape_sweep`),
    from the rows `_build` made on them (`models`, `results`), JSON-ready."""
    rows: list[dict[str, Any]] = []
    decisions: list[dict[str, Any]] = []
    for sw in sweeps:
        if say is not None:
            say(f"{sw.kind}: every model's worst case on {len(_configs_of(sw.kind))} planes")
        curves = _curve_candidates(sw, models, results, grid)
        areas = _model_candidates(sw.kind, grid)
        check = ShapeVerifier(sw, grid)
        for config in _configs_of(sw.kind):
            rows.append(_ceiling_row(config, curves, areas, check))
            judged = [c for c in curves if c.errors.get(config.key) is not None]
            for tol in TOLERANCES:
                entry = {"config": sw.name, "kind": sw.kind, "radius": sw.radius,
                         "band": config.key, "band_label": config.label, "tolerance": tol}  # fmt: skip
                entry.update(decide_cell(judged, lambda a=areas: a, config.key, tol, check))
                decisions.append(entry)
    return {"grid": int(grid), "rows": rows, "decisions": decisions}


def _name(cell: Mapping[str, Any]) -> str:
    if cell["kind"] == "area model":
        return f"`{cell['name']}` (area model)"
    return f"best f(d): `{cell['name']}` {cell['mode']}"


def shapes_markdown(data: Mapping[str, Any]) -> str:
    """The ceiling of the rectangle and the tube as Markdown: per plane, the best f(d) and
    every area model written for the light."""
    lines = [
        "What no distance curve can fix on a rectangle's and a tube's lights: on each plane, "
        "the best f(d) (the point-light model with the family and parameters of smallest "
        "worst case) against every area model written for the light. Their decision rows "
        "are in the decision table above.",
        "",
        md_row(["configuration", "model", "worst case", "where (x, y, z) / size", TYPICAL_HEADER,
                "cost"]),
        md_row(["---", "---", "---:", "---", "---:", "---:"]),
    ]  # fmt: skip
    for row in data["rows"]:
        cells = ([row["best_fd"]] if row["best_fd"] else []) + list(row["models"])
        for cell in cells:
            lines.append(
                md_row([row["label"], _name(cell), fmt_pct(cell["error"]),
                        cell["where"].removeprefix("at "), fmt_pct(cell["typical"]),
                        fmt_num(cell["cost"])])
            )  # fmt: skip
    note = (
        f"Worst case over each plane (`attenfit._judge.shape_worst_case`: a {data['grid']} x "
        f"{data['grid']} grid over a quadrant, then a local search), relative to the exact "
        "irradiance; where, in units of the panel's width `w` or the tube's length `l` (the "
        "panel at the origin facing -z, the tube along x); typical: the 95th percentile "
        "over the grid. The best f(d): every family through the point-light model, as "
        "published for the light's radius r (a panel's equal-area disk's, the tube's) and "
        f"fitted to its facing sweep: of the {CLOSEST_SEARCHED} closest on the grid, the "
        "smallest worst case (equal to 3 digits: the cheaper). Cost: compiled (SPIR-V instructions where the "
        "compilers are installed)."
    )
    return "\n".join(lines) + "\n\n" + note + "\n"


def split_shapes(emitters: Any) -> tuple[Any, tuple[str, ...]]:
    """`(emitters, shapes)`: the names of `SHAPE_LIGHTS` taken out of a list of emitters (or
    of names; a comma-separated name is split), the rest as given, or None (the report's
    default lights) when only shapes were named."""
    if emitters is None or isinstance(emitters, Mapping):
        return emitters, ()
    items = [emitters] if isinstance(emitters, str) else list(emitters)
    names: list[Any] = []
    for e in items:
        names += [p.strip() for p in e.split(",") if p.strip()] if isinstance(e, str) else [e]
    shapes = tuple(dict.fromkeys(n for n in names if isinstance(n, str) and n in SHAPE_LIGHTS))
    rest = [n for n in names if not (isinstance(n, str) and n in SHAPE_LIGHTS)]
    return (rest if rest or not shapes else None), shapes
