"""Every area model's worst case on each band of the lights it is written for (docs/area.md,
generated): the judge's numbers, as the decision table quotes them."""

from __future__ import annotations

from typing import Any

from ._area_candidates import area_candidates
from ._decide import TYPICAL_HEADER
from ._markdown import fmt_num, fmt_pct, fmt_stops, md_row
from ._metrics import GAP_BAND_LABELS, GAP_BANDS
from ._verify import Verifier

__all__ = ["area_worst_markdown"]


def area_worst_markdown(report: Any) -> str:
    """Every area model's worst case on each band of the lights it is written for, with its
    typical error and cost: the judge's numbers, as the decision table quotes them (the same
    search, `_verify.Verifier`, the same cache)."""
    lines = [
        md_row(["area model", "light", "distance from its surface", "worst case", "in stops",
                TYPICAL_HEADER, "where", "cost"]),
        md_row(["---", "---", "---", "---:", "---:", "---:", "---", "---:"]),
    ]  # fmt: skip
    for cfg in report.configs:
        check = Verifier(cfg)
        for c in area_candidates(cfg, report):
            for band in GAP_BANDS:
                w = check.worst(c, band) if c.errors.get(band) is not None else None
                if w is None:
                    continue
                typical = "—" if w.typical is None else fmt_pct(w.typical)
                lines.append(
                    md_row([f"`{c.model}`", cfg.kind, GAP_BAND_LABELS[band], fmt_pct(w.error),
                            fmt_stops(w.error), typical, w.where(), fmt_num(c.cost)])
                )  # fmt: skip
    return "\n".join(lines) + "\n"
