"""The report's decision table, "Which curve for which light" (docs/report.md).

For each emitter kind, each band of distance from the light's surface (`_metrics.GAP_BANDS`:
contact to r, r to 10 r, beyond 10 r) and each tolerance in `TOLERANCES`, the cheapest model
(by the compiled shader cost the report measured) whose largest error on every receiver set
(facing, floor, random; `_configs.Receivers`) in that band is within the tolerance. The
candidates are every family's result rows, as published and fitted; a windowed curve
qualifies only for bands its range/2 covers (beyond it a window is judged off by design).
Where no distance curve meets a tolerance, the candidates of `sources` (by default the area
models, `_area_candidates.area_candidates`) are tried. Every cell is ranked by
`attenfit._judge.rank`: one tie-break, and a closest chosen among every model class.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from .._curves import get_family
from .._judge import Ranking, rank
from ._area_candidates import area_candidates
from ._candidates import SET_LABELS, Candidate, judge
from ._candidates import SETS as SETS  # the summary's order of the sets, as before
from ._markdown import fmt_num, fmt_pct, fmt_stops, md_row
from ._metrics import GAP_BAND_LABELS, GAP_BANDS
from ._verify import Verifier

#: The name of the typical error (the 95th percentile over random receivers) in every table.
TYPICAL_HEADER = "typical (p95)"
#: The tolerances of the decision table (largest |error| on the receivers that matter).
TOLERANCES: tuple[float, ...] = (0.01, 0.05, 0.2)
#: Where the candidates of the cells no distance curve meets come from:
#: `fn(config, report) -> iterable of Candidate`, judged on `config.receivers`.
SOURCES: tuple[Callable[[Any, Any], Iterable[Candidate]], ...] = (area_candidates,)


# ============================================================================ parameters in r
_NICE = ((1.0, ""), (math.sqrt(2.0), "√2"), (0.5, "1/2"), (1 / math.sqrt(2.0), "1/√2"), (2.0, "2"))


def _coef(x: float) -> str:
    for v, text in _NICE:
        if abs(x / v - 1) < 1e-4:
            return text
    return f"{x:.3g}"


def _in_r(name: str, value: float, power: int) -> str:
    sym = "r′" if name == "r" else name
    c = value
    if power == 0:
        return f"{sym} = {value:.3g}"
    unit = {1: "r", 2: "r²", -2: "/ r²", -1: "/ r"}.get(power, f"r^{power}")
    k = _coef(c)
    if power < 0:
        return f"{sym} = {k or '1'} {unit}"
    return f"{sym} = {k} {unit}".replace("=  ", "= ")


def params_in_r(
    family: str, params: Mapping[str, Any] | None, r: float, absolute: Sequence[str] = ()
) -> str:
    """A result row's parameters as a function of the light's radius `r` (a scale-covariant
    family's length-like ones divided by r to their power), or in metres for `absolute` ones
    (engine constants) and for families that are not scale-covariant."""
    if not params:
        return "none"
    try:
        cls = get_family(family)
    except Exception:
        cls = None
    parts = []
    for k, v in params.items():
        if isinstance(v, list):
            parts.append(f"{k} = [{', '.join(f'{x:.3g}' for x in v)}] (r = {r:g} m)")
            continue
        p = cls.length_power(k) if cls is not None else 0
        if cls is None or not cls.scale_covariant or k in absolute:
            unit = {0: "", 1: " m", 2: " m²", -2: " /m²"}.get(p, f" m^{p}")
            parts.append(f"{k} = {v:.3g}{unit}")
        else:
            parts.append(_in_r(k, float(v) / r**p, p))
    return ", ".join(parts)


# ============================================================================ candidates
def _row_candidate(report, row: Mapping[str, Any], r: float, absolute: Sequence[str]):
    errors, worst, per_set = judge(row.get("receivers") or {})
    cost = (report.costs.get(row["family"]) or {}).get("shader_cost")
    return Candidate(
        model=row["family"],
        mode=row["mode"],
        params=params_in_r(row["family"], row.get("params"), r, absolute),
        cost=None if cost is None else float(cost),
        errors=errors,
        worst=worst,
        set_errors=per_set,
        n_params=len(row.get("params") or {}),
        build=lambda: _model(row),
    )


def _model(row: Mapping[str, Any]) -> Any:
    """The family of a result row with the row's parameter values."""
    values = {k: np.asarray(v, dtype=np.float64) for k, v in (row.get("params") or {}).items()}
    return get_family(row["family"])(**values)


def _absolute(report, fam: str, cfg) -> tuple[str, ...]:
    """Published parameters that do not follow the light's radius (engine constants)."""
    from ._published import published_params

    try:
        cls = get_family(fam)
        a, _ = published_params(cls, cfg.radius)
        b, _ = published_params(cls, 2.0 * cfg.radius)
    except Exception:
        return ()
    out = []
    for k, v in a.items():
        if k == "scale" or np.ndim(v):
            continue
        if float(np.asarray(b[k])) == float(np.asarray(v)):
            out.append(k)
    return tuple(out)


def candidates(report, cfg) -> list[Candidate]:
    """Every result row of `cfg` that evaluated fine, as a decision candidate."""
    out = []
    for row in report.results:
        if row["config"] != cfg.name or row["status"] != "ok" or not row.get("receivers"):
            continue
        absolute = _absolute(report, row["family"], cfg) if row["mode"] == "published" else ()
        out.append(_row_candidate(report, row, cfg.radius, absolute))
    return out


def _where(c: Candidate, band: str) -> str:
    w = c.worst.get(band)
    if not w:
        return ""
    s, x = w
    return f" on the {SET_LABELS.get(s, s)} at d = {x:.3g} r" if x is not None else f" on the {s}"


def rank_band(cands: Iterable[Candidate], band: str, tol: float) -> Ranking[Candidate]:
    """The candidates judged in `band`, ranked at tolerance `tol` (`attenfit._judge.rank`:
    within it cheapest first, and the closest of every model class among them)."""
    return rank((c.contender(band) for c in cands if c.errors.get(band) is not None), tol)


def decide(
    report,
    sources: Sequence[Callable[[Any, Any], Iterable[Candidate]]] = SOURCES,
    *,
    verify: bool = True,
) -> list[dict[str, Any]]:
    """The decision table's entries: one per configuration with receivers x band x tolerance.

    Each entry: `config`, `kind`, `band`, `tolerance`, `model`, `mode`, `params`, `error`,
    `cost`, `why` (one sentence), `model_kind`; `model` None where nothing meets the
    tolerance (then `best`, `error` and `why` are about the closest, of every model class).
    `sources` give the candidates tried where no distance curve meets a tolerance (`SOURCES`:
    the area models). With `verify` (the report's way), a model is named only when its worst
    case over the band (`_verify`, `attenfit._judge.worst_case`) is within the tolerance, and
    `error` is that worst case, `where` where it lies and `sampled` the largest error over the
    sampled receivers; without it, the sampled errors decide (a lower bound: for tests of the
    ranking alone)."""
    out = []
    for cfg in report.configs:
        if not cfg.receivers:
            continue
        cands = candidates(report, cfg)
        check = Verifier(cfg) if verify else None
        # asked for once, where no distance curve meets a tolerance
        more = functools.cache(lambda cfg=cfg: [x for fn in sources for x in fn(cfg, report)])
        for band in GAP_BANDS:
            judged = [c for c in cands if c.errors.get(band) is not None]
            if not judged:
                continue
            for tol in TOLERANCES:
                entry = {
                    "config": cfg.name,
                    "kind": cfg.kind,
                    "radius": cfg.radius,
                    "band": band,
                    "tolerance": tol,
                }
                entry.update(decide_cell(judged, more, band, tol, check))
                out.append(entry)
    return out


def decide_cell(
    judged: Sequence[Candidate],
    more: Callable[[], Sequence[Candidate]],
    band: str,
    tol: float,
    check: Verifier | None,
) -> dict[str, Any]:
    """One cell of the decision table: the cheapest of `judged` (the distance curves) whose
    worst case on `band` holds `tol`, else of those and `more()` (the area models, asked
    for only then), else the closest of all, with why (`decide`'s entry fields)."""
    pool = list(judged)
    pick = _pick(rank_band(pool, band, tol), band, tol, check)
    if pick is None:
        pool = [*judged, *more()]
        pick = _pick(rank_band(pool, band, tol), band, tol, check)
    if pick is None:
        return _none_within(rank_band(pool, band, tol), judged, band, tol, check)
    entry = _chosen(pick[0], judged, band, tol, check)
    entry.update(_worst_fields(pick[0], pick[1], band, entry["why"]))
    return entry


def _pick(ranking: Ranking[Candidate], band: str, tol: float, check: Verifier | None):
    """The cheapest candidate within `tol`: by its worst case with a `Verifier`, else by its
    sampled error; `(candidate, worst case or None)`, or None."""
    if check is None:
        return None if ranking.best is None else (ranking.best.item, None)
    return check.first_holding(ranking.within, band, tol)


def _worst_fields(c: Candidate, w: Any, band: str, why: str) -> dict[str, Any]:
    """An entry's error (its worst case), where it lies, and the sampled error beside it."""
    if w is None:
        return {}
    if "its largest error is" not in why:
        why += f" Its worst case: {fmt_pct(w.error)} {w.where()}."
    return {"error": w.error, "where": w.where(), "typical": w.typical,
            "sampled": c.errors.get(band), "why": why}  # fmt: skip


def _error(c: Candidate, band: str, check: Verifier | None) -> tuple[float, str]:
    """`c`'s error on `band` (its worst case where searched) and where it lies, in words."""
    w = check.worst(c, band) if check is not None else None
    if w is None:
        return c.errors[band], _where(c, band)
    return w.error, f" {w.where()}"


def _chosen(
    best: Candidate, judged: Sequence[Candidate], band: str, tol: float, check: Verifier | None
) -> dict:
    """The entry's fields for the cheapest candidate within `tol`, with why."""
    cheaper = [
        c for c in judged if c.cost is not None and best.cost is not None and c.cost < best.cost
    ]
    near = rank_band(cheaper, band, tol).closest
    if near is not None:
        n = near.item
        # within by sample yet cheaper: its worst case ruled it out (and is known)
        err, where = _error(n, band, check) if n.errors[band] <= tol else (n.errors[band], "")
        at_least = "" if check is None or n.errors[band] <= tol else "at least "
        why = (
            f"The cheapest within {fmt_pct(tol)}; the best cheaper curve, "
            f"`{n.model}` {n.mode} (cost {fmt_num(n.cost)}), is "
            f"{at_least}{fmt_pct(err)} off{where or _where(n, band)}."
        )
    elif best.cost is not None:
        where = _error(best, band, check)[1] if check is not None else _where(best, band)
        why = f"The cheapest curve of all; its largest error is{where or ' here'}."
    else:
        why = f"Cost not measured: the smallest error{_where(best, band)}."
    if best.mode == "fitted":
        why += " Parameters fitted on the facing sweep."
    return {
        "model": best.model,
        "mode": best.mode,
        "model_kind": best.kind,
        "params": best.params,
        "error": best.errors.get(band),
        "cost": best.cost,
        "why": why,
    }


def _none_within(
    ranking: Ranking[Candidate],
    judged: Sequence[Candidate],
    band: str,
    tol: float,
    check: Verifier | None,
) -> dict:
    """The entry's fields where no candidate is within `tol`: the closest, and why."""
    top = (ranking.closest or ranking.outside[0]).item
    assert top is not None
    err, where, typical = top.errors[band], _where(top, band), None
    if check is not None:
        sampled = [c for c in (*ranking.within, *ranking.outside) if c.error is not None]
        by_error = [c.item for c in sorted(sampled, key=lambda c: c.error) if c.item is not top]
        found = check.closest([top, *by_error], band)
        if found is not None:
            top, w = found
            err, where, typical = w.error, f" {w.where()}", w.typical
    if top.kind != "distance curve":  # an area model is closest, and still not within
        curve = rank_band(judged, band, tol).closest
        reason = "; no model of either class meets the tolerance" + (
            f" (the closest distance curve, `{curve.item.model}` {curve.item.mode}, is "
            f"{fmt_pct(_error(curve.item, band, check)[0])} off)"
            if curve is not None and curve.item is not None
            else ""
        )
    else:
        w = top.worst.get(band)
        horizon = (
            w is not None
            and w[0] == "random"
            and all(
                (top.set_errors.get(s, {}).get(band) or 0.0) <= tol for s in ("facing", "floor")
            )
        )
        reason = (
            ", where part of the light sinks below a tilted receiver's horizon "
            f"(within {fmt_pct(tol)} on the facing and floor receivers)"
            if horizon and check is None
            else "; an area-light model is needed here"
        )
    return {
        "model": None,
        "mode": top.mode,
        "model_kind": top.kind,
        "params": top.params,
        "error": err,
        "cost": top.cost,
        "why": f"The closest is {fmt_pct(err)} off{where}{reason}.",
        "best": top.model,
        "sampled": top.errors[band],
        "typical": typical,
    }


def decision_markdown(entries: Sequence[Mapping[str, Any]], costs_label: str = "") -> str:
    """The decision table as Markdown: one row per light x band x tolerance."""
    if not entries:
        return ""
    lines = [
        md_row(["light", "distance from its surface", "tolerance", "cheapest model",
                "parameters (r: the light's radius)", "worst case", "in stops", TYPICAL_HEADER,
                "cost", "why"]),
        md_row(["---", "---", "---:", "---", "---", "---:", "---:", "---:", "---:", "---"]),
    ]  # fmt: skip
    rows: list[list[Any]] = []  # consecutive tolerances with the same answer share a row
    for e in entries:
        light = f"{e['kind']} ({e['config']})" if e["kind"] != e["config"] else e["kind"]
        if e["model"] is None:
            model = f"none; closest: `{e['best']}` {e['mode']}"
        else:
            model = f"`{e['model']}` {e['mode']}"
        if e.get("model_kind") and e["model_kind"] != "distance curve":
            model += f" ({e['model_kind']})"
        why = e["why"].replace(f"within {fmt_pct(e['tolerance'])}", "within the tolerance")
        same = (light, e["band"], model, e["params"], fmt_pct(e["error"]), why)
        if rows and rows[-1][0] == same:
            rows[-1][1].append(e["tolerance"])
        else:
            rows.append([same, [e["tolerance"]], e])
    last = None
    for same, tols, e in rows:
        light, band = same[0], same[1]
        group = (light, band)
        tol_text = (
            fmt_pct(tols[0]) if len(tols) == 1 else f"{fmt_pct(tols[0])} to {fmt_pct(tols[-1])}"
        )
        lines.append(
            md_row(
                [
                    light if group != last else "",
                    (e.get("band_label") or GAP_BAND_LABELS[band]) if group != last else "",
                    tol_text,
                    same[2],
                    e["params"],
                    fmt_pct(e["error"]),
                    fmt_stops(e["error"]),
                    fmt_pct(e["typical"]) if e.get("typical") is not None else "—",
                    fmt_num(e["cost"]),
                    same[5],
                ]
            )
        )
        last = group
    note = (
        "*Worst case*: the worst |error| of the model's irradiance over every receiver of the band "
        "that the three receiver sets span (facing, floors from contact to 10 r, any "
        "orientation), found by a search from contact (docs/judging.md), and where it lies; "
        "the sampled receivers of the summary only rule models out (their largest error is a "
        "lower bound of the worst). "
        f"*{TYPICAL_HEADER}*: the 95th percentile of |error| over random receivers of the band "
        "(4096 per receiver set, the largest over the sets; docs/judging.md), a typical error "
        "beside the worst. Bands on the distance from the light's surface (d − r for a sphere, to the nearest point of a disk); "
        "*in stops*: the most that error can be in stops, −log2(1 − error) (a stop is a "
        "doubling of light; 0.1 stop is about the smallest step a viewer sees). "
        "Cheapest by the compiled shader cost"
        + (f" ({costs_label})" if costs_label else "")
        + "; ties go to the smaller error (errors equal to 3 digits: to the model with fewer "
        "parameters), then to the name. Where no model is within the tolerance, the closest "
        "of either class is named. Windowed curves qualify only for bands within "
        "half their range. *published*: the source's parameters for the light; *fitted*: "
        "shape parameters fitted to the facing sweep by least squares on the relative error, "
        "ranges fixed."
    )
    if any(e.get("band_label") for e in entries):
        note += (
            " *rect*, *tube* (`--emitters rect,tube`): each band is a plane of receivers, a "
            "floor under a square panel of width w or a wall beside a tube of length l, and "
            "the worst case is over that plane (`attenfit._judge.shape_worst_case`; the "
            "section \"Rectangle and tube lights\"); *r* is the panel's equal-area disk's "
            "radius or the tube's radius."
        )
    return "\n".join(lines) + "\n\n" + note + "\n"
