"""The report's summary table: every family on the three receiver sets of each light, as
published and fitted, with the plane energy of both lights and the compiled cost; a fitted
value worse than the published one is marked and explained under the table."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from ._area_candidates import area_candidates
from ._decide import SET_LABELS, SETS
from ._markdown import cell_error, fmt_num, fmt_pct, md_row

#: What "fitted" means, as every table of the report says it.
FIT_WHAT = (
    "*fitted*: shape parameters only (a radius, eps, an exponent, a scale; a range stays at its "
    "published value), least squares on the relative error over the facing sweep (windowed "
    "families over d ≤ range/2, where they are judged)"
)


def _max(row: Mapping[str, Any] | None, s: str) -> float | None:
    if row is None or row["status"] != "ok":
        return None
    return (((row.get("receivers") or {}).get(s) or {}).get("overall") or {}).get("max_abs")


def _rms(row: Mapping[str, Any] | None, s: str) -> float | None:
    if row is None or row["status"] != "ok":
        return None
    return (((row.get("receivers") or {}).get(s) or {}).get("overall") or {}).get("rms")


def _cell(row: Mapping[str, Any] | None, s: str) -> str:
    if row is None:
        return "—"
    if row["status"] != "ok":
        return "fit failed"
    return fmt_pct(_max(row, s))


def _why_worse(fam: str, cfg: str, s: str, pub, fit) -> str:
    """One sentence on why a fit is worse than the published curve on the set `s`."""
    a, b = _max(pub, s), _max(fit, s)
    if s != "facing":
        fa, fb = _max(pub, "facing"), _max(fit, "facing")
        return (
            f"`{fam}` on the {cfg}'s {SET_LABELS[s]} ({fmt_pct(a)} → {fmt_pct(b)}): the fit sees "
            f"only the facing sweep, where its largest error went {fmt_pct(fa)} → {fmt_pct(fb)}."
        )
    ra, rb = _rms(pub, s), _rms(fit, s)
    if ra is not None and rb is not None and rb < ra:
        return (
            f"`{fam}` on the {cfg}'s facing sweep ({fmt_pct(a)} → {fmt_pct(b)}): least squares "
            f"lowered the RMS relative error {fmt_pct(ra)} → {fmt_pct(rb)}; the cell shows the "
            "largest error, which it does not minimise."
        )
    return (
        f"`{fam}` on the {cfg}'s facing sweep ({fmt_pct(a)} → {fmt_pct(b)}): the fit stopped at "
        "a worse point than its start (see its row's fit status in report.json)."
    )


def _area_rows(report, lights: list, others: list) -> list[list[str]]:
    """A row per area model: its largest |error| on each receiver set of the lights it is
    written for (`_area_candidates`, the same receivers and errors as the families')."""
    per = {c.name: {a.model: a for a in area_candidates(c, report)} for c in lights}
    rows = []
    for name in dict.fromkeys(n for found in per.values() for n in found):
        cost = next(found[name].cost for found in per.values() if name in found)
        row = [f"`{name}` (area model)", fmt_num(cost, digits=3)]
        for c in lights:
            a = per[c.name].get(name)
            for s in SETS:
                values = (
                    []
                    if a is None
                    else [v for v in a.set_errors.get(s, {}).values() if v is not None]
                )
                row.append(fmt_pct(max(values)) if values else "—")
            if c.plane is not None and c.plane.rho is not None:
                row.append("—")
        rows.append(row + ["—"] * len(others))
    return rows


def summary_markdown(report) -> str:
    """One row per family: for each light, the largest error on each receiver set (published
    / fitted) and the plane energy ratio; the compiled cost; notes on worse fits."""
    lights = [c for c in report.configs if c.receivers]
    others = [c for c in report.configs if not c.receivers and c.sweep is not None]
    modes = [m for m in ("published", "fitted") if any(r["mode"] == m for r in report.results)]
    head = ["family", "cost"]
    for c in lights:
        head += [f"{c.name}: {SET_LABELS[s]}" for s in SETS]
        if c.plane is not None and c.plane.rho is not None:
            head.append(f"{c.name}: floor energy / truth")
    for c in others:
        head.append(f"{c.name}: sweep")
    lines = [md_row(head), md_row(["---"] + ["---:"] * (len(head) - 1))]
    notes: list[str] = []
    for fam in report.families:
        cost = (report.costs.get(fam) or {}).get("shader_cost")
        row = [f"`{fam}`", fmt_num(cost, digits=3)]
        for c in lights:
            rows = {m: report._get(fam, c.name, m) for m in modes}
            windowed = (
                ((rows.get("published") or {}).get("receivers") or {}).get("facing") or {}
            ).get("covers") is not None
            for s in SETS:
                cells = [_cell(rows[m], s) for m in modes]
                pub, fit = rows.get("published"), rows.get("fitted")
                a, b = _max(pub, s), _max(fit, s)
                mark = ""
                # worse as shown (3 digits), and above float64 rounding (1e-9): flagged
                if (
                    a is not None
                    and b is not None
                    and b > 1e-9
                    and float(f"{b:.3g}") > float(f"{a:.3g}")
                ):
                    notes.append(_why_worse(fam, c.name, s, pub, fit))
                    mark = f" [{len(notes)}]"
                row.append(" / ".join(cells) + (" ᵂ" if windowed else "") + mark)
            if c.plane is not None and c.plane.rho is not None:
                row.append(
                    " / ".join(
                        fmt_num(
                            (((rows[m] or {}).get("plane") or {}).get("energy") or {}).get("ratio")
                        )
                        for m in modes
                    )
                )
        for c in others:
            row.append(" / ".join(cell_error(report._get(fam, c.name, m)) for m in modes))
        lines.append(md_row(row))
    lines += [md_row(r) for r in _area_rows(report, lights, others)]
    cost_label = next(iter(report.costs.values())).get("cost_label", "") if report.costs else ""
    text = (
        "Cells: the largest |error| of the model's irradiance on each receiver set's sampled "
        "receivers (a lower bound of the worst case the decision table judges by), "
        + ("*published* / *fitted*" if len(modes) == 2 else f"*{modes[0]}*")
        + ". Facing sweep: receivers facing the light's centre from contact to 1000 r; floor: "
        "floors facing up at the light at heights from contact to 10 r, out to 100 r; random "
        "orientations: receivers in random directions (contact to 1000 r) with random normals, "
        "the error relative to the irradiance a receiver facing the light would get there (so "
        "a dim, grazing receiver does not dominate). Windowed families (ᵂ) are judged on "
        "receivers within half their range (beyond it a window is dark by design). Floor "
        "energy: the irradiance integrated over the plane of the light's images (the sphere "
        "touching it, the disk r/4 above it) over the truth's. *published*: the source's "
        f"parameters for this light; {FIT_WHAT}. Cost: "
        + (cost_label or "not measured")
        + " of the shader form `attenfit export` writes. Area models (the decision's other "
        "class): as shipped, one value a cell, on the lights they are written for."
    )
    out = "\n".join(lines) + "\n\n" + text + "\n"
    if notes:
        out += (
            "\nFitted worse than published on the cell's measure:\n\n"
            + "\n".join(f"{i}. {n}" for i, n in enumerate(notes, 1))
            + "\n"
        )
    return out
