"""Per-light answers for a scene read from a file: the cheapest family within tolerance at
each light, its parameters, its range, the engine's own light properties, and the check of
the answer against the exact irradiance at the light's receivers.

The range trade
---------------
A windowed curve (one with a range: `r_max`, `cutoff`, `range`) is culled beyond its range,
and a light's culling and shading cost grows with its influence volume (`4/3 pi R^3` for a
point light, `2/3 pi (1 - cos umbra) R^3` for a spot's cone). Given a visibility threshold
`T` (an absolute irradiance), the smallest range is wanted that keeps the judged error within
the tolerance at every receiver whose true irradiance exceeds `T` (below `T` the light is
not visible, culled or not). For each candidate range the family's free parameters are
refitted to those receivers with the range pinned, and the smallest range that passes is
found on a geometric grid from the farthest visible receiver `d_vis` to `16 d_vis` (24
points), then on a finer grid (12 points) inside the bracketing step: the range is found to
within 1.3%. The influence volume saved is against the light's published range (glTF
`range`) or the engine's default range.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from .._curves import Family, get_family
from .._errors import AttenfitError, BadValueError
from .._judge import rank
from ._advice import Candidate, Recommendation, param_text, pct
from ._engine import Engine
from ._engine_fit import engine_verdict, renders_as_spot
from ._files import ImportedScene
from ._light_fits import LightData, _range_param, fit_group, fit_plan, judged_errors, shade

__all__ = ["LightChoice", "light_choices", "range_trade"]

_GRID, _FINE, _SPAN = 24, 12, 16.0  # multiples of the solve's batch (4 lights)


@dataclasses.dataclass(frozen=True)
class LightChoice:
    """The answer for one light (see the module docstring); `checked_error` is the largest
    error of the final curve (its parameters and range) against the exact irradiance at the
    light's judged receivers (those above the threshold when there is one)."""

    light: int
    name: str
    file_kind: str
    receivers: int
    family: str | None
    status: str  # "pass" | "fail" (the closest family, when none is within tolerance)
    params: Mapping[str, Any]
    error: float | None
    shader_cost: float | None
    spot: Mapping[str, Any] | None
    range: Mapping[str, Any] | None
    properties: Mapping[str, Any]
    checked_error: float | None
    model: Family | None = dataclasses.field(default=None, repr=False, compare=False)
    #: the checked receivers' distances (m) and errors, for the figure
    checked: tuple[np.ndarray, np.ndarray] | None = dataclasses.field(
        default=None, repr=False, compare=False
    )
    #: with an engine: the largest error of what the engine renders with `properties` at
    #: the light's judged receivers (`_engine_fit`), the error this answer vouches for
    engine_error: float | None = None
    engine_notes: tuple[str, ...] = ()
    #: when no family meets the tolerance at this light: its area models judged
    #: (`_escalate.AreaEscalation`; the answer is its winner, when it has one)
    area: Any = None

    @property
    def answered_as(self) -> str | None:
        """What the light is answered with: the engine's own area light (its light type,
        `_engine_area`) where the answer is one, else the family."""
        own = self.properties.get("light_type")
        return f"{own} (the engine's own area light)" if own else self.family

    @property
    def area_model(self) -> Any:
        """The area model this light needs (`AreaCandidate`): no family meets the tolerance
        here and it does; None otherwise."""
        return None if self.area is None else self.area.winner

    def to_dict(self) -> dict[str, Any]:
        return {
            "light": self.light,
            "name": self.name,
            "file_kind": self.file_kind,
            "receivers": self.receivers,
            "family": self.family,
            "status": self.status,
            "params": dict(self.params),
            "error": self.error,
            "shader_cost": self.shader_cost,
            "spot": None if self.spot is None else dict(self.spot),
            "range": None if self.range is None else dict(self.range),
            "properties": dict(self.properties),
            "checked_error": self.checked_error,
            "engine_error": self.engine_error,
            "engine_notes": list(self.engine_notes),
            "area": None if self.area is None else self.area.to_dict(),
        }

    @property
    def claimed_error(self) -> float | None:
        """The error this answer vouches for: the engine-rendered one with an engine."""
        return self.engine_error if self.engine_error is not None else self.checked_error


def pick_for_light(
    candidates: Sequence[Candidate], i: int, tolerance: float, windowed: bool = False
) -> tuple[Candidate | None, str]:
    """The family to answer light `i` with, and its status: the cheapest of the fitted
    `candidates` within `tolerance` at that light ("pass"; with `windowed`, a windowed one
    where any passes), else the closest there ("fail"; None when none is judged there).

    Ranked by `attenfit._judge.rank` on each candidate's error at light `i`
    (`Candidate.contender(i)`): the tie-break of the all-lights recommendation, so both
    answers break a tie alike. A candidate failed for a reason other than its error (a
    precision failure, a non-finite value, a broken constraint) is never within."""
    ranking = rank((c.contender(i) for c in candidates if c.models), tolerance)
    if ranking.best is not None:
        within = [c.item for c in ranking.within]
        if windowed:
            within = [c for c in within if _is_windowed(c)] or within  # type: ignore[arg-type]
        return within[0], "pass"
    if ranking.closest is not None:
        return ranking.closest.item, "fail"
    return None, "fail"


def _is_windowed(c: Candidate) -> bool:
    return _range_param(get_family(c.family)) is not None


def _volume(light, R: float) -> float:
    if light.is_spot:
        return 2 / 3 * math.pi * (1 - math.cos(math.radians(light.umbra))) * R**3
    if light.kind in ("disk", "rect"):
        return 2 / 3 * math.pi * R**3
    return 4 / 3 * math.pi * R**3


def _g(spot_model, x: LightData, precision: str) -> np.ndarray:
    return np.ones_like(x.d) if spot_model is None else shade(spot_model, x.cos_s, precision)


def _subset(x: LightData, keep: np.ndarray, R: float | None) -> LightData:
    return dataclasses.replace(
        x,
        d=x.d[keep],
        wpt=x.wpt[keep],
        E_true=x.E_true[keep],
        E_irr=x.E_irr[keep],
        cos_s=x.cos_s[keep],
        theta=x.theta[keep],
        denom=x.denom[keep],
        range=R,
        points=None if x.points is None else x.points[keep],
        normals=None if x.normals is None else x.normals[keep],
    )


def _fit_at(cls, x: LightData, vis, ranges: Sequence[float], pins, precision, g, chunk: int):
    """The family refitted to the receivers `vis` of `x` with its range pinned at each of
    `ranges`: (models, errors over `vis`). The other receivers weigh 0 (an infinite
    denominator), so the solve has the shape of the recommendation's (`chunk` lights of the
    same receiver count) and reuses its compiled form."""
    hidden = dataclasses.replace(x, denom=np.where(vis, x.denom, np.inf))
    datas = [dataclasses.replace(hidden, range=float(R)) for R in ranges]
    d_vis = x.d[vis]
    knots = tuple(float(k) for k in np.geomspace(d_vis.min(), d_vis.max() * 1.001, 6))
    plans = [fit_plan(cls, d, float(x.d.max()), knots) for d in datas]
    if pins:
        plans = [({**v, **pins}, tuple(p for p in f if p not in pins)) for v, f in plans]
    models = []
    for k in range(0, len(datas), chunk):
        models += [m for m, _, _ in fit_group(cls, datas[k : k + chunk], plans[k : k + chunk])]
    errs = []
    for m in models:
        try:
            f = shade(m, x.d[vis], precision)
            errs.append(float(judged_errors(_subset(x, vis, None), f, g).max()))
        except AttenfitError:
            errs.append(math.inf)
    return models, errs


def range_trade(
    family: str,
    x: LightData,
    light,
    *,
    threshold: float,
    tolerance: float,
    precision: str,
    spot_model=None,
    pins: Mapping[str, float] | None = None,
    reference: float | None = None,
    chunk: int = 4,
    candidates: Sequence[float] = (),
) -> tuple[dict[str, Any], Family | None]:
    """The smallest range of `family` for one light (module docstring): a summary dict and
    the refitted model at that range (None when no range within `16 d_vis` passes)."""
    cls = get_family(family)
    vis = x.E_true > threshold
    out: dict[str, Any] = {"threshold": threshold, "visible_receivers": int(vis.sum())}
    if not vis.any():
        out.update(range=0.0, note="below the threshold at every receiver: cull the light")
        return out, None
    sub = _subset(x, vis, None)
    g = _g(spot_model, sub, precision)
    d_vis = float(sub.d.max())
    out["d_visible"] = d_vis
    extra = sorted(float(c) for c in candidates if d_vis < float(c) < _SPAN * d_vis)
    grid = np.unique(np.concatenate([d_vis * np.geomspace(1.0 + 1e-6, _SPAN, _GRID), extra]))
    models, errs = _fit_at(cls, x, vis, grid, pins, precision, g, chunk)
    ok = [k for k, e in enumerate(errs) if e <= tolerance]
    if not ok:
        out.update(
            range=None,
            note=f"no range up to {_SPAN:g} x d_visible keeps the error within "
            f"{pct(tolerance)} (best {pct(min(errs))})",
        )
        return out, None
    k = ok[0]
    best_R, best_m, best_e = float(grid[k]), models[k], errs[k]
    if k > 0:
        fine = np.geomspace(grid[k - 1], grid[k], _FINE + 2)[1:-1]
        fm, fe = _fit_at(cls, x, vis, fine, pins, precision, g, chunk)
        for R, m, e in zip(fine, fm, fe, strict=True):
            if e <= tolerance:
                best_R, best_m, best_e = float(R), m, e
                break
    out.update(range=best_R, error=best_e, volume=_volume(light, best_R))
    if reference is not None:
        out["reference_range"] = reference
        out["reference_volume"] = _volume(light, reference)
        out["volume_saved"] = 1.0 - (best_R / reference) ** 3
        if reference < d_vis:
            out["note"] = (
                f"the reference range {reference:g} m culls visible light (above the "
                f"threshold out to {d_vis:.3g} m)"
            )
    else:
        out["reference_range"] = math.inf
        out["volume_saved"] = 1.0
        out["note"] = "no published or default range (infinite): any range saves it all"
    return out, best_m


def _plain(model: Family) -> dict[str, Any]:
    out = {}
    for k, v in model.params().items():
        a = np.asarray(v, dtype=np.float64)
        out[k] = float(a) if a.ndim == 0 else a.tolist()
    return out


def _spot_of(pick: Candidate, i: int, light, engine: Engine | None):
    """(the fitted spot falloff model, the spot dict handed to the engine): a disk is a
    90-degree spot for an engine (its cone then fitted to the disk's cosine)."""
    spot_model = pick.spot_models[i] if pick.spot_models else None
    if spot_model is not None:
        return spot_model, {
            "falloff": pick.directional,
            "umbra": math.degrees(float(spot_model.umbra)),
            "penumbra": math.degrees(float(spot_model.penumbra)),
        }
    if engine is not None and renders_as_spot(light):
        return None, {
            "falloff": f"engine cone (the {light.kind}'s cosine)",
            "umbra": 90.0,
            "penumbra": 0.0,
        }
    return None, None


def _trade(imported, x, light, pick, spot_model, i) -> tuple[dict[str, Any] | None, Any]:
    """The range trade for light `i` (module docstring): with a threshold, the published
    range is one candidate among the grid's; without one, a light with no published range
    gets a range for the scene's extent (every lit receiver visible). (summary, refit)."""
    scene, engine = imported.scene, imported.engine
    published = imported.published_ranges[i]
    threshold = imported.threshold
    if threshold is None:
        if published is not None or engine is None:
            return None, None
        threshold = 0.0  # no threshold: every lit receiver counts (the scene's extent)
    ref = published if published is not None else (engine.default_range if engine else None)
    pins = engine.fixed.get(pick.family) if engine is not None else None
    trade, refit = range_trade(
        pick.family, x, light,
        threshold=threshold, tolerance=scene.tolerance,
        precision=scene.precision, spot_model=spot_model, pins=pins, reference=ref,
        chunk=max(2, 1 << max(0, (len(scene.lights) - 1).bit_length())),
        candidates=() if published is None else (published,),
    )  # fmt: skip
    if imported.threshold is None:
        trade["note"] = (
            "no threshold: the range is chosen for the scene's extent (the smallest that keeps "
            "every lit receiver within tolerance)"
        )
    return trade, refit


def _ran_away(model: Family, x: LightData) -> float | None:
    """The range of `model` if it ran away in a fit (not finite, or past 1e4 x the farthest
    receiver), else None."""
    rp = _range_param(type(model))
    if rp is None:
        return None
    R = float(np.asarray(model.params()[rp]))
    return R if not math.isfinite(R) or R > 1e4 * float(x.d.max()) else None


def _pin_range(imported, i: int, model: Family, x: LightData, spot_model) -> Family:
    """`model` refitted with its range pinned at the scene's extent (`_SPAN` x the farthest
    receiver) when its fitted range ran away; a range that still runs away is refused,
    naming the file and the light (`_check_range`)."""
    if _ran_away(model, x) is None:
        return model
    scene, engine = imported.scene, imported.engine
    pins = engine.fixed.get(model.name) if engine is not None else None
    vis = np.ones(len(x.d), bool)
    g = _g(spot_model, x, scene.precision)
    try:
        (refit,), _ = _fit_at(
            type(model), x, vis, [_SPAN * float(x.d.max())], pins, scene.precision, g, 2
        )
    except AttenfitError:
        refit = model
    _check_range(imported, i, refit, x)
    return refit


def _check_range(imported, i: int, model: Family, x: LightData) -> None:
    """A range that ran away in a fit is refused, naming the file and the light."""
    R = _ran_away(model, x)
    if R is not None:
        rp = _range_param(type(model))
        raise BadValueError(
            f"{imported.path.name}: light {imported.names[i]!r}: the fitted {model.name} "
            f"range {rp} = {R:.3g} ran away (the farthest receiver is {float(x.d.max()):.3g} m); "
            "give the light a range or a --threshold"
        )


def _one_choice(imported, rec: Recommendation, i: int, x: LightData) -> LightChoice:
    scene, engine = imported.scene, imported.engine
    light = scene.lights[i]
    windowed = imported.threshold is not None
    pick, status = pick_for_light(rec.candidates, i, scene.tolerance, windowed=windowed)
    # no family meets the tolerance here: the light's area models (the all-lights answer's)
    area = rec.area.for_light(i) if status == "fail" and rec.area is not None else None
    if pick is None:
        return LightChoice(
            i, imported.names[i], imported.file_kinds[i], len(x.d), None, "fail",
            {}, None, None, None, None, {}, None, area=area,
        )  # fmt: skip
    spot_model, spot = _spot_of(pick, i, light, engine)
    trade, final = None, pick.models[i]
    no_range = imported.published_ranges[i] is None and engine is not None
    if _is_windowed(pick) and (status == "pass" or imported.threshold is not None or no_range):
        trade, refit = _trade(imported, x, light, pick, spot_model, i)
        if refit is not None:
            final = refit
            status = "pass"
    final = _pin_range(imported, i, final, x, spot_model)
    if status == "pass":  # a curve met it (refitted above the threshold): no area form
        area = None
    # the check: the final curve against the exact irradiance at the judged receivers
    keep = np.ones(len(x.d), bool)
    if trade is not None and trade.get("range"):
        keep = x.E_true > trade["threshold"]
    sub = _subset(x, keep, None)
    f = shade(final, sub.d, scene.precision)
    errs = judged_errors(sub, f, _g(spot_model, sub, scene.precision))
    params = _plain(final)
    props: dict[str, Any] = {}
    verdict = None
    if engine is not None and pick.family in engine.families:
        props = engine.properties(pick.family, params, light, spot)
        verdict = engine_verdict(
            engine.witness, light, props, sub, scene.tolerance,
            engine.size_prop, engine.size_unit * light.radius, scene.precision,
        )  # fmt: skip
        props, status = dict(verdict.properties), verdict.status
        trade = _engine_range(engine.witness, props, trade)
        if status == "pass":  # the engine renders it within tolerance: no shader of its own
            area = None
    return LightChoice(
        light=i,
        name=imported.names[i],
        file_kind=imported.file_kinds[i],
        receivers=len(x.d),
        family=pick.family,
        status=status,
        params=params,
        error=float(pick.error_by_light[i]),
        shader_cost=pick.shader_cost,
        spot=spot,
        range=trade,
        properties=props,
        checked_error=float(errs.max()),
        model=final,
        checked=(sub.d, errs if verdict is None else verdict.errors),
        engine_error=None if verdict is None else verdict.error,
        engine_notes=() if verdict is None else verdict.notes,
        area=area,
    )


def _engine_range(w, props: Mapping[str, Any], trade):
    """`trade` with the range the engine's settings hold (m): the engine search moves the
    range with the other properties (`_engine_search`), and the headline, the table and the
    write-back state that one range."""
    held = [(n, u) for n, role, u, *_ in w.search_props if role == "range" and n in props]
    if trade is None or not trade.get("range") or not held:
        return trade
    (name, unit), *_ = held
    R = float(props[name]) / unit
    if math.isclose(R, float(trade["range"]), rel_tol=1e-9):
        return trade
    out = {**trade, "range": R}
    ref = trade.get("reference_range")
    if "volume_saved" in trade and ref is not None and math.isfinite(ref) and ref > 0:
        out["volume_saved"] = 1.0 - (R / ref) ** 3
    moved = (
        f"the engine's closest settings, searched with its other properties, put the range "
        f"at {R:.4g} m (the range trade's {float(trade['range']):.4g} m)"
    )
    out["note"] = f"{trade['note']}; {moved}" if trade.get("note") else moved
    return out


def light_choices(
    imported: ImportedScene,
    rec: Recommendation,
    datas: Sequence[LightData],
) -> tuple[LightChoice, ...]:
    """The answer for every light of `imported` from its recommendation `rec` (and the
    lights' judged receivers `datas`), with the range trade, and with an engine, judged
    through the engine's own shading (`_engine_fit`)."""
    return tuple(_one_choice(imported, rec, i, datas[i]) for i in range(len(datas)))


def choices_markdown(imported: ImportedScene, choices: Sequence[LightChoice]) -> str:
    """A Markdown section: one row per light, then each light's engine properties."""
    eng = imported.engine
    lines = [
        f"## Per-light choices{f' for {eng.name}' if eng else ''}",
        "",
        f"Tolerance {pct(imported.scene.tolerance)}, {imported.scene.precision}"
        + (f", visibility threshold {imported.threshold:g}" if imported.threshold else "")
        + f"; {imported.samples} receivers sampled per light. *Error, far range*: the "
        "family's fit with its range 10x the farthest receiver; *checked error*: the final "
        "curve (its parameters and range) against the exact irradiance at the light's "
        "receivers (those above the threshold, with one).",
        "",
        "| light | kind | receivers | family | params | error, far range | checked error |"
        + (" engine-rendered error |" if eng else "")
        + " range | volume saved |",
        "|---|---|---|---|---|---|---|" + ("---|" if eng else "") + "---|---|",
    ]
    for c in choices:
        radius = imported.scene.lights[c.light].radius
        params = ", ".join(param_text(k, v, radius) for k, v in c.params.items()) or "-"
        if c.spot:
            params += f"; {c.spot['falloff']}: umbra {c.spot['umbra']:.4g}, penumbra {c.spot['penumbra']:.4g} deg"
        rng, saved = "-", "-"
        if c.range is not None:
            R = c.range.get("range")
            rng = "none found" if R is None else f"{R:.4g} m"
            if "volume_saved" in c.range and R is not None:
                ref, v = c.range["reference_range"], c.range["volume_saved"]
                if not math.isfinite(ref):
                    saved = "all (no range: infinite)"
                elif v >= 0:
                    saved = f"{pct(v)} of {ref:g} m's"
                else:
                    saved = f"none: {1 - v:.3g} x the volume of {ref:g} m"
        fam = c.answered_as
        fam = fam if c.status == "pass" else f"fail, closest {pct(c.claimed_error)}: {fam}"
        eng_col = f" {pct(c.engine_error)} |" if eng is not None else ""
        lines.append(
            f"| {c.name} | {c.file_kind} | {c.receivers} | {fam} | {params} | {pct(c.error)} "
            f"| {pct(c.checked_error)} |{eng_col} {rng} | {saved} |"
        )
    notes = [(c.name, c.range["note"]) for c in choices if c.range and c.range.get("note")]
    notes += [(c.name, _area_note(c)) for c in choices if c.area is not None]
    if notes:
        lines += ["", *(f"- {n}: {t}" for n, t in notes)]
    if eng is not None:
        lines += ["", f"### {eng.name} light properties", "", f"Source: {eng.source}.", ""]
        if eng.note:
            lines += [f"Note: {eng.note}.", ""]
        lines += [
            f"Judged through {eng.name}'s own shading (the engine witness: "
            f"{eng.witness.source}): the engine-rendered error is the largest error of what "
            f"{eng.name} draws with these properties at the light's receivers, every "
            f"operation rounded to {imported.scene.precision} (the scene's precision).",
            "",
        ]
        for c in choices:
            props = ", ".join(f"{k} = {_num(v)}" for k, v in c.properties.items()) or "-"
            verdict = "" if c.status == "pass" else f" (fail, closest {pct(c.claimed_error)})"
            lines.append(f"- {c.name}: {props}{verdict}")
            lines += [f"  - {n}" for n in c.engine_notes]
    if imported.notices:
        lines += ["", "Skipped:", "", *(f"- {n}" for n in imported.notices)]
    lines.append("")
    return "\n".join(lines)


def _area_note(c: LightChoice) -> str:
    """What a light no family meets needs: its area model, or that none meets it either."""
    w, near = c.area.winner, c.area.closest
    if w is None:
        found = f" (closest: {near.label}, {pct(near.error)})" if near else ""
        return f"no family meets the tolerance here, and no area model meets it either{found}"
    return (
        f"no family meets the tolerance here: its answer is the area model {w.label}, max "
        f"error {pct(w.error)} over its judged receivers, shader cost {w.cost:g} (the area "
        'models judged: "Beyond a distance curve" below; their functions: all-lights/)'
    )


def _num(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, list):
        return "[" + ", ".join(f"{x:.4g}" for x in v) + "]"
    return str(v)


def _text(text: str) -> str:
    """A scene's own names as text, never matplotlib mathtext (`$...$` in a light's name)."""
    return text.replace("$", r"\$")


def plot_choices(imported: ImportedScene, choices: Sequence[LightChoice]):
    """Each light's checked error against distance (its final curve at its receivers; with
    an engine, what the engine renders), the tolerance dashed and each chosen range dotted;
    `(fig, ax)`, never shown."""
    import matplotlib
    import matplotlib.pyplot as plt

    with matplotlib.rc_context({"font.size": 9, "axes.grid": True, "grid.alpha": 0.3}):
        fig, ax = plt.subplots(figsize=(7, 4.2))
        tol = imported.scene.tolerance
        floor = tol * 1e-4
        for k, c in enumerate(choices):
            if c.checked is None:
                continue
            d, e = c.checked
            o = np.argsort(d)
            line = ax.plot(
                d[o], np.maximum(e[o], floor), "os^vDP"[k % 6], ms=2.5, alpha=0.6,
                label=_text(f"{c.name}: {c.answered_as} (max {pct(c.claimed_error)})"
                            + (f"; needs {c.area_model.label}" if c.area_model else "")),
            )[0]  # fmt: skip
            R = c.range.get("range") if c.range else None
            if R:
                ax.axvline(R, color=line.get_color(), ls=":", lw=1)
        ax.axhline(tol, color="k", ls="--", lw=1, label=f"tolerance {pct(tol)}")
        ax.set_yscale("log")
        ax.set_xlabel("distance from the light's centre (m); dotted: the chosen range")
        what = "engine-rendered" if imported.engine else "checked"
        ax.set_ylabel(f"{what} error (< {floor:.0e} drawn at it)")
        eng = f" as {imported.engine.name} renders it" if imported.engine else ""
        ax.set_title(_text(f"{imported.path.name}: each light's final curve{eng} at its receivers"))
        ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
    return fig, ax
