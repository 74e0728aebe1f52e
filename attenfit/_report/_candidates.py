"""What the decision table chooses among (docs/report.md): a `Candidate` (a distance curve's
result row, or an area model) with its largest error per band of distance, and `judge`, which
reads those errors from `_metrics.receiver_errors` per receiver set.

`_decide` builds the distance curves' candidates and `_area_candidates` the area models';
both rank through `attenfit._judge.rank` (`Candidate.contender`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

from .._judge import Contender
from ._metrics import GAP_BANDS

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
    function of the light's radius, in words, and `n_params` how many it takes; `cost` its
    compiled cost (None: unknown); `mode` "published" (an area model: as shipped) or
    "fitted"; `kind` "distance curve" or "area model"."""

    model: str
    mode: str
    params: str
    cost: float | None
    errors: Mapping[str, float | None]
    worst: Mapping[str, tuple[str, float] | None]
    kind: str = "distance curve"
    #: Per receiver set, the largest |error| per band (what `errors` is the maximum of).
    set_errors: Mapping[str, Mapping[str, float | None]] = dataclasses.field(default_factory=dict)
    n_params: int = 0
    #: Makes the model itself (for its worst case, `_verify`); None where it cannot be made.
    build: Callable[[], Any] | None = dataclasses.field(default=None, compare=False, repr=False)

    @property
    def label(self) -> str:
        """Its name in a ranking: the model, `"<model> (fitted)"` for a fitted one (so that
        at a full tie the published one, a prefix of it, comes first)."""
        return self.model if self.mode == "published" else f"{self.model} ({self.mode})"

    def contender(self, band: str) -> Contender[Candidate]:
        """This candidate in `band` for `attenfit._judge.rank` (its error there, its cost)."""
        return Contender(self.label, self.errors.get(band), self.cost, self.n_params, item=self)


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
