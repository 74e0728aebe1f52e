"""The report's decision table, "Which curve for which light" (docs/report.md).

For each emitter kind, each band of distance from the light's surface (`_metrics.GAP_BANDS`:
contact to r, r to 10 r, beyond 10 r) and each tolerance in `TOLERANCES`, the cheapest model
(by the compiled shader cost the report measured) whose largest error on every receiver set
(facing, floor, random; `_configs.Receivers`) in that band is within the tolerance. The
candidates are every family's result rows, as published and fitted; a windowed curve
qualifies only for the bands its range/2 covers (beyond it a window is judged off by
design). Where no distance curve meets a tolerance, candidates from the sources registered
with `register_candidate_source` (e.g. area-light models) are tried; nothing else changes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from .._curves import get_family
from ._markdown import fmt_num, fmt_pct, md_row
from ._metrics import GAP_BAND_LABELS, GAP_BANDS

#: The tolerances of the decision table (largest |error| on the receivers that matter).
TOLERANCES: tuple[float, ...] = (0.01, 0.05, 0.2)
#: The receiver sets every model is judged on, in the order the tables show them.
SETS: tuple[str, ...] = ("facing", "floor", "random")
SET_LABELS: Mapping[str, str] = {
    "facing": "facing sweep",
    "floor": "floor",
    "random": "random orientations",
}


@dataclasses.dataclass(frozen=True)
class Candidate:
    """A model the decision table may pick for one configuration.

    `errors[band]` is its largest |error| over the receivers of that band (None: not judged
    there), `worst[band]` the (set, d / r) of that error; `params` its parameters as a
    function of the light's radius, in words; `cost` its compiled cost (None: unknown)."""

    model: str
    mode: str
    params: str
    cost: float | None
    errors: Mapping[str, float | None]
    worst: Mapping[str, tuple[str, float] | None]
    kind: str = "distance curve"
    #: Per receiver set, the largest |error| per band (what `errors` is the maximum of).
    set_errors: Mapping[str, Mapping[str, float | None]] = dataclasses.field(default_factory=dict)


#: Extra candidate sources: `fn(config, report) -> iterable of Candidate` (area models).
_SOURCES: list[Callable[[Any, Any], Iterable[Candidate]]] = []


def register_candidate_source(fn: Callable[[Any, Any], Iterable[Candidate]]) -> None:
    """Add a source of candidates (e.g. area-light models) to the decision table.

    `fn(config, report)` returns `Candidate`s judged on `config.receivers` (the same
    `_metrics.receiver_errors` bands); they are tried only where no distance curve meets a
    tolerance, and shown with their `kind`."""
    if fn not in _SOURCES:
        _SOURCES.append(fn)


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
def judge(rx: Mapping[str, Any]) -> tuple[dict, dict, dict]:
    """`(errors, worst, set_errors)` of a `Candidate` from its `_metrics.receiver_errors`
    per receiver set: per band, the largest |error| over the sets and where it is."""
    errors: dict[str, float | None] = {}
    worst: dict[str, tuple[str, float] | None] = {}
    per_set = {
        s: {
            b: (st or {}).get("max_abs") for b, st in ((rx.get(s) or {}).get("bands") or {}).items()
        }
        for s in SETS
    }
    for band in GAP_BANDS:
        best, where = None, None
        judged = False
        for s in SETS:
            st = ((rx.get(s) or {}).get("bands") or {}).get(band) or {}
            if not st.get("n"):
                continue
            judged = True
            v = st.get("max_abs")
            if v is None:
                continue
            if best is None or v > best:
                best, where = v, (s, st.get("worst_at"))
        covers = (rx.get("facing") or {}).get("covers")
        if covers is not None and band not in covers:
            judged = False  # a window whose range/2 ends inside the band
        errors[band] = best if judged else None
        worst[band] = where if judged else None
    return errors, worst, per_set


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
    )


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


def _key(c: Candidate, band: str):
    return (math.inf if c.cost is None else c.cost, c.errors[band], c.mode != "published")


def _where(c: Candidate, band: str) -> str:
    w = c.worst.get(band)
    if not w:
        return ""
    s, x = w
    return f" on the {SET_LABELS.get(s, s)} at d = {x:.3g} r" if x is not None else f" on the {s}"


def decide(report) -> list[dict[str, Any]]:
    """The decision table's entries: one per configuration with receivers x band x tolerance.

    Each entry: `config`, `kind`, `band`, `tolerance`, `model`, `mode`, `params`, `error`,
    `cost`, `why` (one sentence), `model_kind`; `model` None where nothing meets the
    tolerance (then `error` and `why` are about the best there is)."""
    out = []
    for cfg in report.configs:
        if not cfg.receivers:
            continue
        cands = candidates(report, cfg)
        extra: list[Candidate] | None = None
        for band in GAP_BANDS:
            judged = [c for c in cands if c.errors.get(band) is not None]
            if not judged:
                continue
            for tol in TOLERANCES:
                ok = sorted(
                    (c for c in judged if c.errors[band] <= tol), key=lambda c: _key(c, band)
                )
                if not ok:
                    if extra is None:
                        extra = [x for fn in _SOURCES for x in fn(cfg, report)]
                    ok = sorted(
                        (
                            c
                            for c in extra
                            if c.errors.get(band) is not None and c.errors[band] <= tol
                        ),
                        key=lambda c: _key(c, band),
                    )
                entry = {
                    "config": cfg.name,
                    "kind": cfg.kind,
                    "radius": cfg.radius,
                    "band": band,
                    "tolerance": tol,
                }
                if ok:
                    best = ok[0]
                    cheaper = [
                        c
                        for c in judged
                        if c.cost is not None and best.cost is not None and c.cost < best.cost
                    ]
                    if cheaper:
                        near = min(cheaper, key=lambda c: c.errors[band])
                        why = (
                            f"The cheapest within {fmt_pct(tol)}; the best cheaper curve, "
                            f"`{near.model}` {near.mode} (cost {fmt_num(near.cost)}), is "
                            f"{fmt_pct(near.errors[band])} off{_where(near, band)}."
                        )
                    elif best.cost is not None:
                        why = (
                            "The cheapest curve of all; its largest error is"
                            f"{_where(best, band) or ' here'}."
                        )
                    else:
                        why = f"Cost not measured: the smallest error{_where(best, band)}."
                    if best.mode == "fitted":
                        why += " Parameters fitted on the facing sweep."
                    entry.update(
                        model=best.model,
                        mode=best.mode,
                        model_kind=best.kind,
                        params=best.params,
                        error=best.errors.get(band),
                        cost=best.cost,
                        why=why,
                    )
                else:
                    top = min(  # errors equal to 3 digits: the cheaper
                        judged,
                        key=lambda c: (float(f"{c.errors[band]:.3g}"), _key(c, band)),
                    )
                    w = top.worst.get(band)
                    horizon = (
                        w is not None
                        and w[0] == "random"
                        and all(
                            (top.set_errors.get(s, {}).get(band) or 0.0) <= tol
                            for s in ("facing", "floor")
                        )
                    )
                    reason = (
                        ", where part of the light sinks below a tilted receiver's horizon "
                        f"(within {fmt_pct(tol)} on the facing and floor receivers)"
                        if horizon
                        else "; an area-light model is needed here"
                    )
                    entry.update(
                        model=None,
                        mode=top.mode,
                        model_kind=top.kind,
                        params=top.params,
                        error=top.errors[band],
                        cost=top.cost,
                        why=(
                            f"The closest is {fmt_pct(top.errors[band])} off"
                            f"{_where(top, band)}{reason}."
                        ),
                        best=top.model,
                    )
                out.append(entry)
    return out


def decision_markdown(entries: Sequence[Mapping[str, Any]], costs_label: str = "") -> str:
    """The decision table as Markdown: one row per light x band x tolerance."""
    if not entries:
        return ""
    lines = [
        md_row(["light", "distance from its surface", "tolerance", "cheapest model",
                "parameters (r: the light's radius)", "max error", "cost", "why"]),
        md_row(["---", "---", "---:", "---", "---", "---:", "---:", "---"]),
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
                    GAP_BAND_LABELS[band] if group != last else "",
                    tol_text,
                    same[2],
                    e["params"],
                    fmt_pct(e["error"]),
                    fmt_num(e["cost"]),
                    same[5],
                ]
            )
        )
        last = group
    note = (
        "The largest |error| of a model's irradiance over three receiver sets in each band "
        "(facing sweep, floors from contact to 10 r, random orientations; see the summary), "
        "bands on the distance from the light's surface (d − r for a sphere, to the nearest point of a disk). "
        "Cheapest by the compiled shader cost"
        + (f" ({costs_label})" if costs_label else "")
        + "; ties go to the smaller error. Windowed curves qualify only for bands within "
        "half their range. *published*: the source's parameters for the light; *fitted*: "
        "shape parameters fitted to the facing sweep by least squares on the relative error, "
        "ranges fixed."
    )
    return "\n".join(lines) + "\n\n" + note + "\n"
