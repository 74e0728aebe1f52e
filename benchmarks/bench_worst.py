"""The decision table re-judged by its worst case (docs/judging.md).

Builds the default report (as `make docs` does: every family, as published and fitted, the
sphere and the disk), takes its decision table ("Which curve for which light") and judges
every model it names, or names as the closest, with `attenfit._judge.worst_case`: the
largest error over the band's whole receiver space (facing, floors, any orientation; bands
from contact), with the report's own error measure. Prints, per entry, the error the table
claims (the largest over its sampled receivers), the worst found, where, the typical error
(95th percentile over random receivers of the band) and whether the named model still meets
the tolerance; then the search against brute force on two cases (a finer grid of the same
receiver space, and how many receivers each evaluated).

Run: `python -m benchmarks worst` (about 5 minutes on 2 cores: a minute or more building the
report, then about 10 s per model and band, most of it compiling the exact irradiance with
each model once).
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

import attenfit
from attenfit._curves import get_area_model, get_family
from attenfit._judge import worst_case
from attenfit._judge._receivers import GAP_BAND_LABELS, pieces
from attenfit._judge._worst import GRID, _as_model, _eval, _f64, _grid, _search


def _pct(x: float | None) -> str:
    if x is None:
        return "—"
    if x >= 100:
        return f"{x:.3g}×"
    return f"{100 * x:.3g}%"


def _model(rep: Any, entry: dict[str, Any]) -> tuple[Any, str]:
    """The model an entry names (or names as the closest), with the report's parameters."""
    name = entry["model"] or entry["best"]
    if entry.get("model_kind") == "area model":
        return get_area_model(name)(), f"`{name}` {entry['mode']} (area model)"
    row = rep.result(name, entry["config"], entry["mode"])
    cls = get_family(name)
    params = {k: np.asarray(v, np.float64) for k, v in (row.get("params") or {}).items()}
    return cls(**params), f"`{name}` {entry['mode']}"


def rejudge(rep: Any) -> list[dict[str, Any]]:
    """Every decision-table entry with its worst case (one search per model and band)."""
    emitters = {c.name: c.emitter for c in rep.configs}
    cache: dict[tuple, Any] = {}
    out = []
    for e in rep.decisions():
        model, label = _model(rep, e)
        key = (e["config"], e["band"], label)
        if key not in cache:
            t0 = time.perf_counter()
            cache[key] = worst_case(model, emitters[e["config"]], e["band"])
            w = cache[key]
            print(
                f"  judged {label} on the {e['kind']}, {GAP_BAND_LABELS[e['band']]}: "
                f"{_pct(w.error)} ({time.perf_counter() - t0:.1f} s)",
                flush=True,
            )
        out.append({**e, "label": label, "worst": cache[key]})
    return out


def table(rows: list[dict[str, Any]]) -> str:
    """The before/after table, Markdown: claimed, worst found, where, typical, verdict."""
    lines = [
        "| light | band | tolerance | model | claimed max error | worst found | where | "
        "typical (p95) | verdict |",
        "| --- | --- | ---: | --- | ---: | ---: | --- | ---: | --- |",
    ]
    for r in rows:
        w = r["worst"]
        if r["model"] is None:
            verdict = "none meets it (closest shown)"
        elif w.error <= r["tolerance"]:
            verdict = "holds"
        else:
            verdict = "**fails**"
        lines.append(
            f"| {r['kind']} | {GAP_BAND_LABELS[r['band']]} | {_pct(r['tolerance'])} | "
            f"{r['label']} | {_pct(r['error'])} | {_pct(w.error)} | {w.where()} | "
            f"{_pct(w.typical)} | {verdict} |"
        )
    return "\n".join(lines)


def brute_force(model: Any, emitter: Any, light: str, band: str, rset: str, fine: tuple):
    """The search (default grid) against the maximum of a finer grid of the same receivers."""
    m = _f64(_as_model(model))
    em = attenfit.emitter_from_dict(emitter.to_dict())
    (piece,) = pieces(light, rset, band)
    t0 = time.perf_counter()
    _, found, grid_max, evals = _search(m, em, piece, None, 12)
    t_search = time.perf_counter() - t0
    t0 = time.perf_counter()
    xs = _grid(fine)
    brute = float(np.max(_eval(m, em, piece, xs)))
    t_brute = time.perf_counter() - t0
    return {
        "case": f"{model.name if hasattr(model, 'name') else model} on the {light}, "
        f"{GAP_BAND_LABELS[band]}, {rset}",
        "grid": "x".join(map(str, GRID[piece.light if piece.kind == "any" else piece.kind])),
        "grid_max": grid_max,
        "found": found,
        "evals": evals,
        "t_search": t_search,
        "fine": "x".join(map(str, fine)),
        "brute": brute,
        "brute_n": len(xs),
        "t_brute": t_brute,
    }


def main() -> None:
    import jax

    t0 = time.perf_counter()
    rep = attenfit.build_report(cost="counts")
    print(f"(default report built in {time.perf_counter() - t0:.0f} s)", flush=True)
    with jax.enable_x64(True):
        rows = rejudge(rep)
    print("\nThe decision table, re-judged by its worst case\n")
    print(table(rows))
    named = [r for r in rows if r["model"] is not None]
    fails = [r for r in named if r["worst"].error > r["tolerance"]]
    above = [r for r in rows if r["worst"].error > r["error"] * (1 + 1e-6)]
    print(
        f"\n{len(fails)} of {len(named)} entries that name a model fail their tolerance at "
        f"the worst case; {len(above)} of {len(rows)} claimed errors are exceeded."
    )
    print("\nThe search against brute force (a finer grid of the same receivers; |error|):\n")
    print("| case | search grid | grid max | search | evaluated | brute grid | brute max |"
          " evaluated | search − brute |")  # fmt: skip
    print("| --- | --- | ---: | ---: | ---: | --- | ---: | ---: | ---: |")
    sphere = next(c.emitter for c in rep.configs if c.kind == "sphere")
    disk = next(c.emitter for c in rep.configs if c.kind == "disk")
    cases = [
        (get_area_model("godot_wrap")(), sphere, "sphere", "contact", "any", (1025, 1537)),
        (get_area_model("hdrp_sphere")(), sphere, "sphere", "contact", "any", (1025, 1537)),
        (get_family("inverse_square")(), sphere, "sphere", "near", "any", (1025, 1537)),
        (get_area_model("vector_disk")(), disk, "disk", "contact", "any", (41, 33, 65, 17)),
        (get_area_model("vector_disk")(), disk, "disk", "far", "any", (41, 33, 65, 17)),
    ]
    with jax.enable_x64(True):
        for case in cases:
            b = brute_force(*case)
            print(
                f"| {b['case']} | {b['grid']} | {b['grid_max']:.9f} | {b['found']:.9f} | "
                f"{b['evals']} ({b['t_search']:.1f} s) | {b['fine']} | {b['brute']:.9f} | "
                f"{b['brute_n']} ({b['t_brute']:.1f} s) | {b['found'] - b['brute']:.2e} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
