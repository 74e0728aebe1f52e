"""The report's witness: a small Mitsuba render of each light's floor and random receivers.

`render_witness(emitters, budget_s=...)` builds, for each light, the receivers `attenfit
truth` would (a floor under the light: `plane_receivers`, the sphere or capsule touching it,
the disk r/4 above it; and `random_receivers` from contact to 100 r) with their exact
irradiance, renders them with Mitsuba (`llvm_ad_rgb` when it works, else `scalar_rgb`), and
returns `(label, exact, rendered)` triples for `attenfit._report._witness`. The samples per
receiver are chosen from a quick timing so the whole render takes about `budget_s`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from attenfit import BadValueError, Dataset

from .render import render_dataset
from .variants import select_variant

__all__ = ["WITNESS_FLOOR_PX", "WITNESS_RANDOM", "render_witness", "witness_templates"]

WITNESS_FLOOR_PX = 16  # floor grid points per side
WITNESS_RANDOM = 192  # random receivers per light
# 1024 at least: at 256, receivers within 1e-3 r of a disk showed |z| up to 12.6 (a rare-
# sample tail the sample variance had not seen; see tests/test_witness.py)
_MIN_SPP, _MAX_SPP = 1024, 1 << 16


def witness_templates(emitters: Mapping[str, Any], *, seed: int = 0) -> list[tuple[str, Dataset]]:
    """(label, exact dataset) per light and receiver set: the floor, then random receivers."""
    import attenfit as af

    out = []
    for name, em in emitters.items():
        r = float(np.asarray(em.radius))
        disk = isinstance(em, af.DiskEmitter | af.RectEmitter)  # flat: a floor r/4 below
        height = r / 4 if disk else r  # as the report's floor: the disk r/4 above, else touching
        floor = af.plane_receivers(em, height, 10 * r, n=WITNESS_FLOOR_PX, dtype="float64")
        lo = 1e-3 * r if disk else 1.001 * r
        rand = af.random_receivers(em, WITNESS_RANDOM, lo, 100 * r, seed=seed, dtype="float64")
        out += [(f"{name} floor", floor), (f"{name} random", rand)]
    return out


def render_witness(
    emitters: Mapping[str, Any],
    *,
    budget_s: float = 4.0,
    variant: str = "auto",
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> list[tuple[str, Dataset, Dataset]]:
    """Render the witness sets of `emitters` within about `budget_s` seconds of rendering.

    Returns `(label, exact, rendered)` for each light's floor and random receivers. The spp
    (a power of two, 1024 to 65536, the same for every set) comes from timing 1024 samples of
    every set first; those renders are used when the budget allows no more.
    """
    if not budget_s > 0:
        raise BadValueError(f"budget_s must be positive, got {budget_s!r}")
    name = select_variant(variant).name
    say = progress or (lambda _m: None)
    say(f"Mitsuba witness: exact values of {len(emitters)} lights' floors and random receivers")
    templates = witness_templates(emitters, seed=seed)
    say(f"Mitsuba witness: rendering with {name}")
    start = time.perf_counter()
    first = [render_dataset(t, spp=_MIN_SPP, seed=seed, variant=name) for _, t in templates]
    spent = time.perf_counter() - start
    spp = _MIN_SPP
    while spp < _MAX_SPP and spent * (2 * spp / _MIN_SPP) <= budget_s:
        spp *= 2
    if spp == _MIN_SPP:
        rendered = first
    else:
        say(f"Mitsuba witness: {spp} samples per receiver")
        rendered = [render_dataset(t, spp=spp, seed=seed, variant=name) for _, t in templates]
    return [(label, t, m) for (label, t), m in zip(templates, rendered, strict=True)]
