"""The decision table's verdicts held to their worst case (docs/judging.md, docs/report.md).

A candidate's errors in `_candidates` are the largest over the report's sampled receivers: a
lower bound of its worst case, enough to rule a model out, not to name it. A verdict names a
model only once `attenfit._judge.worst_case` has searched the band's whole receiver space
(from contact, every orientation) and found its largest error within the tolerance; the
"closest" where nothing holds is the smallest worst case of the few closest by sample.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from typing import Any

import numpy as np

from .. import _cache
from .._errors import BadValueError
from .._judge import worst_case
from ._candidates import Candidate

__all__ = ["Found", "Verifier"]


@dataclasses.dataclass(frozen=True)
class Found:
    """A model's worst case on a band as the table quotes it: the error and where it lies,
    and its typical error (`typical`: the 95th percentile of |error| over random receivers of
    the band, the largest over the receiver sets; `attenfit._judge.worst_case`).

    Kept in attenfit's cache (kind "worst", keyed by the model's class and parameter values,
    the light and the band, for this code version), so a warm report searches nothing again.
    """

    error: float
    place: str
    typical: float | None = None

    def where(self) -> str:
        return self.place


def _decode(cached: bytes) -> Found | None:
    got = json.loads(cached)
    return None if got is None else Found(got["error"], got["where"], got.get("typical"))


#: How many of the closest candidates by sample have their worst case searched for "closest".
CLOSEST_SEARCHED = 3


class Verifier:
    """Worst cases of one configuration's candidates, each searched once per band."""

    def __init__(self, cfg: Any):
        self.cfg = cfg
        self._memo: dict[tuple[str, str, str], Found | None] = {}

    def worst(self, c: Candidate, band: str) -> Found | None:
        """`c`'s worst case on `band` of the configuration's light (None: it cannot be judged
        there, a window whose range/2 ends inside the band, or no model to build)."""
        key = (c.label, c.params, band)
        if key not in self._memo:
            model = c.build() if c.build is not None else None
            self._memo[key] = None if model is None else self._search(model, band)
        return self._memo[key]

    def known(self, c: Candidate, band: str) -> Found | None:
        """`c`'s worst case on `band` where a report searched it already (kept in the cache),
        else None: nothing is searched."""
        key = (c.label, c.params, band)
        if key not in self._memo:
            model = c.build() if c.build is not None else None
            cached = None if model is None else _cache.read("worst", self._key(model, band))
            if cached is None:
                return None
            self._memo[key] = _decode(cached)
        return self._memo[key]

    def _key(self, model: Any, band: str) -> str:
        return json.dumps(
            {
                "model": type(model).__name__,
                "params": {k: np.asarray(v).tolist() for k, v in model.params().items()},
                "light": self.cfg.emitter.to_dict(),
                "band": band,
                "typical": "p95, worst_case's default sample",
            },
            sort_keys=True,
        )

    def _measure(self, model: Any, band: str) -> Found | None:
        """The search itself (`attenfit._judge.worst_case`; None: not judged there)."""
        try:
            w = worst_case(model, self.cfg.emitter, band)
        except BadValueError:
            return None
        return Found(float(w.error), w.where(), float(w.typical))

    def _search(self, model: Any, band: str) -> Found | None:
        key = self._key(model, band)
        cached = _cache.read("worst", key)
        if cached is not None:
            return _decode(cached)
        found = self._measure(model, band)
        entry = None if found is None else {"error": found.error, "where": found.place,
                                             "typical": found.typical}  # fmt: skip
        _cache.write("worst", key, json.dumps(entry).encode())
        return found

    def first_holding(
        self, ranked: Sequence[Any], band: str, tol: float
    ) -> tuple[Candidate, Found] | None:
        """The first of `ranked` (contenders, cheapest first) whose worst case is within `tol`."""
        for contender in ranked:
            w = self.worst(contender.item, band)
            if w is not None and w.error <= tol:
                return contender.item, w
        return None

    def closest(
        self, ranked_by_error: Sequence[Candidate], band: str
    ) -> tuple[Candidate, Found] | None:
        """The smallest worst case among the `CLOSEST_SEARCHED` closest candidates by sample."""
        found = [(c, self.worst(c, band)) for c in ranked_by_error[:CLOSEST_SEARCHED]]
        found = [(c, w) for c, w in found if w is not None]
        return min(found, key=lambda cw: (cw[1].error, cw[0].cost or 0.0)) if found else None
