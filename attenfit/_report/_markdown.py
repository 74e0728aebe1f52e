"""Formatting for report.md and report.json: table rows, numbers, percentages, parameters."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from ._configs import Config


# ============================================================================ formatting
def md_row(cells: Iterable[Any]) -> str:
    return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"


def fmt_num(x: Any, digits: int = 3, inf_text: str = "∞") -> str:
    if x is None:
        return "—"
    x = float(x)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return inf_text if x > 0 else "−∞"
    return f"{x:.{digits}g}"


def fmt_stops(rel: Any) -> str:
    """The most stops (`log2` of the ratio) a relative error of at most `rel` can be off:
    `-log2(1 - rel)`, the dark side (docs/report.md)."""
    if rel is None or not math.isfinite(float(rel)):
        return "—"
    rel = float(rel)
    if rel >= 1:
        return "∞ stops"
    s = -math.log2(1 - rel)
    return f"{s:.2g} stops" if s >= 1e-3 else "< 0.001 stops"


def fmt_pct(x: Any) -> str:
    if x is None:
        return "—"
    x = float(x)
    if math.isinf(x):
        return "∞"
    if math.isnan(x):
        return "—"
    p = 100.0 * x
    if p == 0:
        return "0%"
    if abs(p) < 0.01:
        return f"{p:.1e}%"
    return f"{p:.3g}%"


def fmt_reach(x: Any) -> str:
    return "—" if x is None else f"{float(x):.2f} × range"


def cell_error(r: dict[str, Any] | None) -> str:
    if r is None:
        return "—"
    if r["status"] != "ok":
        return "fit failed"
    sw = r.get("sweep") or {}
    if sw.get("inner_half") is not None:
        return fmt_pct(sw["inner_half"].get("max_abs")) + " ᵂ"
    return fmt_pct((sw.get("overall") or {}).get("max_abs"))


def fmt_params(p: Mapping[str, Any] | None) -> str:
    if not p:
        return "none"
    parts = []
    for k, v in p.items():
        if isinstance(v, list):
            parts.append(f"{k}=[{', '.join(f'{x:.3g}' for x in v)}]")
        else:
            parts.append(f"{k}={v:.4g}")
    return ", ".join(parts)


def describe_emitter(c: Config) -> str:
    e = c.emitter
    if c.kind == "sphere":
        return f"A Lambertian sphere of radius r = {c.radius:g} m, unit intensity (L = 1/(π r²)). Truth: {c.source}."
    if c.kind == "disk":
        return f"A one-sided Lambertian disk of radius r = {c.radius:g} m facing {tuple(float(x) for x in np.asarray(e.normal))}, unit on-axis intensity. Truth: {c.source}."
    return f"A {c.kind} light of radius r = {c.radius:g} m. Truth: {c.source}."


def emitter_dict(e: Any) -> Any:
    to = getattr(e, "to_dict", None)
    if callable(to):
        try:
            return to()
        except Exception:
            pass
    return {"kind": type(e).__name__, "radius": float(np.asarray(e.radius))}


def jsonable(x: Any) -> Any:
    """Replace non-finite floats by strings ("inf", "-inf", "nan") and arrays by lists."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else str(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x
