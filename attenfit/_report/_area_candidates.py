"""Area-light models as candidates of the decision table (docs/area.md, docs/report.md).

Where no distance curve meets a tolerance, `_decide.decide` asks its sources (`_decide.SOURCES`,
this one by default) for more candidates. This one judges every area model made for the configuration's light (a
sphere's models on a sphere, a disk's on a disk), as published, on the same three receiver
sets and with the same errors (`_metrics.receiver_errors`) as the distance curves; its cost
is the compiled cost of its shader form (`attenfit._shaders.area_compiled_cost`).
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from .._curves import get_area_model, list_area_models
from .._shaders import area_compiled_cost
from .._truth import area_irradiance
from ._candidates import Candidate, judge
from ._metrics import receiver_errors


@functools.cache
def _cost(name: str) -> float | None:
    try:
        return area_compiled_cost(get_area_model(name)()).cost
    except Exception:  # no shader form: the table shows the cost as unknown
        return None


def _params(model: Any) -> str:
    values = model.params()
    if not values:
        return "none (reads r, d and the cosines)"
    return ", ".join(
        f"{k} = {float(np.asarray(v)):.4g}" for k, v in values.items() if np.ndim(v) == 0
    )


def area_candidates(cfg: Any, report: Any) -> list[Candidate]:
    """The area models for `cfg`'s light, judged on its receiver sets (none for datasets)."""
    import jax

    if cfg.kind not in ("sphere", "disk") or not cfg.receivers:
        return []
    out = []
    for name in list_area_models():
        cls = get_area_model(name)
        if getattr(cls, "light", None) != cfg.kind:
            continue
        model = cls()
        rx = {}
        with jax.enable_x64(True):
            for s, rec in cfg.receivers.items():
                if rec.points is None:
                    continue
                Em = np.asarray(area_irradiance(model, cfg.emitter, rec.points, rec.normals))
                rx[s] = receiver_errors(Em, rec.E, rec.ref, rec.d, rec.gap, cfg.radius)
        errors, worst, per_set = judge(rx)
        cost = _cost(name)
        out.append(
            Candidate(
                model=name,
                mode="published",
                params=_params(model),
                cost=cost,
                errors=errors,
                worst=worst,
                kind="area model",
                set_errors=per_set,
                n_params=len(model.params()),
                build=lambda model=model: model,
            )
        )
    return out
