"""The numbers behind "what no distance curve can fix": the point-light model with the best
possible `f(d)` against the area models, on the configurations where the error is angular.

Every configuration is a light and receivers of given orientations with attenfit's exact
irradiance (`attenfit.irradiance`). The best possible `f(d)` is the light's exact facing
attenuation `f*(d)`: the irradiance over `I g` of a receiver at distance `d` facing the
light head-on (a sphere `1/d^2`, a one-sided disk on its axis `1/(d^2 + r^2)`, a capsule
from its midpoint, `facing_sweep`); its prediction is the point-light model
`I g f*(d) max(0, n.l)` (`PointLight`). The "facing value" of a receiver is `I f*(d) g_f`,
the irradiance of a facing receiver at its distance; absolute errors are in its units.

Metrics (`errors`): the max relative error over the receivers whose exact irradiance is
above 0.1% of their facing value; the max absolute error in units of the facing value; the
energy ratio (the predicted irradiance summed over the receivers over the exact one: the
power on the floor, for a floor's uniform grid). Computed in float64.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import jax
import numpy as np

from .._curves import AreaModel, PointLight, get_area_model, list_area_models
from .._judge import Contender, rank
from .._truth import (
    CapsuleEmitter,
    DiskEmitter,
    SphereEmitter,
    area_inputs,
    facing_sweep,
    irradiance,
    plane_receivers,
    random_receivers,
)

__all__ = [
    "CEILING_CONFIGS",
    "Case",
    "CeilingConfig",
    "build_case",
    "ceiling_table",
    "cheapest_within",
    "errors",
    "family_costs",
    "models_for",
]

#: Receivers whose exact irradiance is below this fraction of their facing value are left out
#: of the relative error (their relative error says nothing a viewer sees).
FLOOR = 1e-3


@dataclasses.dataclass(frozen=True)
class CeilingConfig:
    """One configuration: `kind` "disk_floor" (`h` the floor's distance below a downward
    one-sided disk, in radii), "sphere_band" (random receivers of any orientation at d/r in
    `band`) or "capsule_wall" (a wall `h` radii from a capsule's axis, parallel to it, normals facing it:
    the light is above every receiver's horizon; the point-light model's error is in its
    emitter factor `g` past the capsule's ends, which no `f(d)` reaches either)."""

    key: str
    title: str
    kind: str
    h: float = 0.0
    band: tuple[float, float] = (0.0, 0.0)


CEILING_CONFIGS: tuple[CeilingConfig, ...] = (
    CeilingConfig("disk_h0.25", "floor under a one-sided disk, h = r/4", "disk_floor", h=0.25),
    CeilingConfig("disk_h1", "floor under a one-sided disk, h = r", "disk_floor", h=1.0),
    CeilingConfig("disk_h4", "floor under a one-sided disk, h = 4 r", "disk_floor", h=4.0),
    CeilingConfig("sphere_1-1.5", "sphere, tilted receivers, d/r 1-1.5", "sphere_band", band=(1.0, 1.5)),
    CeilingConfig("sphere_1.5-3", "sphere, tilted receivers, d/r 1.5-3", "sphere_band", band=(1.5, 3.0)),
    CeilingConfig("sphere_3-10", "sphere, tilted receivers, d/r 3-10", "sphere_band", band=(3.0, 10.0)),
    CeilingConfig("sphere_10-100", "sphere, tilted receivers, d/r 10-100", "sphere_band", band=(10.0, 100.0)),
    CeilingConfig("capsule_wall", "capsule (length 4 r) beside a wall, axis 1.25 r from it", "capsule_wall", h=1.25),
)  # fmt: skip

#: The light's radius (every configuration scales with it) and the floor's half-width in radii.
RADIUS = 1.0
FLOOR_EXTENT = 8.0


@dataclasses.dataclass
class Case:
    """A configuration's receivers: the emitter, points and normals, exact irradiance `E`, the
    facing value of each receiver, the point-light model's best prediction, and (a floor)
    the grid shape and the flat grid index of each receiver."""

    config: CeilingConfig
    emitter: Any
    points: np.ndarray
    normals: np.ndarray
    E: np.ndarray
    facing: np.ndarray
    best_fd: np.ndarray
    f_star: Any  # d -> f*(d) (numpy)
    shape: tuple[int, int] | None = None
    grid_index: np.ndarray | None = None

    def inputs(self) -> Any:
        """The `AreaInputs` of the receivers."""
        return area_inputs(self.emitter, self.points, self.normals)


def _facing_curve(emitter: Any) -> Any:
    """f*(d) of a capsule by log-log interpolation of its facing sweep; sphere and disk closed."""
    if isinstance(emitter, SphereEmitter):
        return lambda d: 1 / np.maximum(d, RADIUS) ** 2
    if isinstance(emitter, DiskEmitter):
        return lambda d: 1 / (d * d + RADIUS * RADIUS)
    ds = facing_sweep(emitter, 1.0001 * RADIUS, 1e3 * RADIUS, 512, dtype=np.float64)
    ld, lf = np.log(ds.distance()), np.log(ds.attenuation())
    return lambda d: np.exp(np.interp(np.log(np.maximum(d, ds.distance()[0])), ld, lf))


def build_case(config: CeilingConfig, n: int = 4000, grid: int = 161, seed: int = 0) -> Case:
    """The receivers of `config` with their exact irradiance (float64)."""
    with jax.enable_x64(True):
        shape = index = None
        if config.kind == "disk_floor":
            em = DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], RADIUS)
            ds = plane_receivers(
                em, config.h * RADIUS, FLOOR_EXTENT * RADIUS, grid, dtype=np.float64
            )
            shape = tuple(ds.provenance["shape"])
            index = np.asarray(ds.provenance["grid_index"])
        elif config.kind == "sphere_band":
            em = SphereEmitter([0.0, 0.0, 0.0], RADIUS)
            lo, hi = config.band
            ds = random_receivers(
                em, n, max(lo, 1.0001) * RADIUS, hi * RADIUS, seed=seed, dtype=np.float64
            )
        elif config.kind == "capsule_wall":
            em = CapsuleEmitter([0.0, 0.0, -2.0], [0.0, 0.0, 2.0], RADIUS)
            ds = plane_receivers(
                em,
                config.h * RADIUS,
                6 * RADIUS,
                grid // 2 + 1,
                up=(0.0, 1.0, 0.0),
                dtype=np.float64,
            )
            shape = tuple(ds.provenance["shape"])
            index = np.asarray(ds.provenance["grid_index"])
        else:  # pragma: no cover - the configurations are fixed
            raise ValueError(config.kind)
        points, normals = np.asarray(ds.points), np.asarray(ds.normals)
        E = np.asarray(irradiance(em, points, normals))
        f_star = _facing_curve(em)
        x = area_inputs(em, points, normals)
        d, g, cos_r = (np.asarray(v) for v in (x.d, x.g, x.cos_r))
        g_facing = 1.0
        if isinstance(em, CapsuleEmitter):  # a facing receiver at the segment's midpoint
            g_facing = 1 + 2 * 4.0 * RADIUS / (math.pi * RADIUS)
        fs = f_star(d)
        best = float(em.intensity) * g * fs * np.maximum(cos_r, 0)
        facing = float(em.intensity) * fs * g_facing
    return Case(config, em, points, normals, E, facing, best, f_star, shape, index)  # type: ignore[arg-type]


def errors(case: Case, predicted: np.ndarray) -> dict[str, float]:
    """Max relative error (receivers above `FLOOR` of their facing value), max absolute error
    in units of the facing value, and the energy ratio, of `predicted` irradiance."""
    p = np.asarray(predicted, dtype=np.float64)
    keep = case.E > FLOOR * case.facing
    rel = np.abs(p[keep] - case.E[keep]) / case.E[keep]
    return {
        "max_rel": float(rel.max()) if rel.size else float("nan"),
        "max_abs": float(np.max(np.abs(p - case.E) / case.facing)),
        "energy": float(p.sum() / case.E.sum()),
    }


def predict(case: Case, model: AreaModel) -> np.ndarray:
    """The irradiance `model` predicts at the case's receivers (float64)."""
    with jax.enable_x64(True):
        x = case.inputs()
        return float(case.emitter.intensity) * np.asarray(model(*x), dtype=np.float64)


def models_for(config: CeilingConfig) -> list[AreaModel]:
    """The shipped area models written for the configuration's light (`AreaModel.light`),
    and the point-light model with `1/d^2` (the familiar curve)."""
    want = "disk" if config.kind == "disk_floor" else "sphere"
    out: list[AreaModel] = []
    for name in list_area_models():
        cls = get_area_model(name)
        if name != "point_light" and cls.light in (want, "any"):
            out.append(cls())
    return out


def fitted_variants(case: Case, models: Sequence[AreaModel]) -> list[tuple[AreaModel, Any]]:
    """Each model with free parameters fitted to the case (relative loss, float64): the
    variant a user gets with `attenfit.fit_dataset`. Returns (model, FitResult) pairs."""
    from .._fit import fit

    out = []
    with jax.enable_x64(True):
        x = case.inputs()
        lit = case.E > FLOOR * case.facing
        stacked = np.stack([np.asarray(v, dtype=np.float64) for v in x])[:, lit]
        target = case.E[lit] / float(case.emitter.intensity)
        for m in models:
            if not m.free_by_default():
                continue
            res = fit(m, stacked, target)
            out.append((res.model, res))
    return out


#: The configurations where fitted variants are computed (the issue's goals).
FIT_ON = ("disk_h0.25", "sphere_1-1.5")


def family_costs() -> dict[str, float]:
    """The compiled cost of `PointLight(family)` for each registered family (its shader form
    times `g max(0, n.l)`, generic parameters): the distance curves on the cost axis."""
    from .._curves import get_family, list_families
    from .._shaders import area_compiled_cost

    out = {}
    for name in list_families():
        try:
            out[name] = area_compiled_cost(PointLight(get_family(name)())).cost
        except (ValueError, TypeError):  # no shader form
            continue
    return out


def ceiling_table(
    configs: Sequence[CeilingConfig] = CEILING_CONFIGS, *, fit_on: Sequence[str] = FIT_ON
) -> list[dict[str, Any]]:
    """One dict per configuration: `config`, `title`, `best_fd` (the errors of the best
    possible f(d)) and `models`: per area model (shipped, and fitted where `fit_on` names the
    configuration) its `errors`, `cost` (SPIR-V instructions of its shader form, or the
    estimate), `cost_label`, `fitted` and `params`."""
    from .._shaders import area_compiled_cost

    costs: dict[str, Any] = {}

    def cost_of(m: AreaModel) -> Any:
        if m.name not in costs:
            costs[m.name] = area_compiled_cost(m)
        return costs[m.name]

    rows = []
    for c in configs:
        case = build_case(c)
        models = models_for(c)
        entries = []
        variants = [(m, None) for m in models]
        if c.key in fit_on:
            variants += fitted_variants(case, models)
        for m, res in variants:
            cc = cost_of(m)
            entries.append(
                {
                    "name": m.name,
                    "fitted": res is not None,
                    "params": {k: float(np.asarray(v)) for k, v in m.params().items()},
                    **errors(case, predict(case, m)),
                    "cost": cc.cost,
                    "cost_label": cc.label(),
                    "exact": get_area_model(m.name).exact,
                }
            )
        rows.append(
            {
                "config": c.key,
                "title": c.title,
                "best_fd": errors(case, case.best_fd),
                "n": int(case.E.size),
                "models": entries,
            }
        )
    return rows


def cheapest_within(row: dict[str, Any], tol: float) -> dict[str, Any] | None:
    """The cheapest model of a `ceiling_table` row within `tol` max relative error (ranked
    by `attenfit._judge.rank`, the tie-break of every verdict); None when none is."""
    best = rank(
        (
            Contender(
                m["name"] + (" (fitted)" if m["fitted"] else ""),
                m["max_rel"],
                m["cost"],
                len(m["params"]),
                item=m,
            )
            for m in row["models"]
        ),
        tol,
    ).best
    return None if best is None else best.item
