"""Each family's parameters "as published" for a light of radius r: the rules the report
states, applied to the facts each family class declares (`at_radius`, `range_param` and
`range_tie`, `knots_param`)."""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from ._configs import PUBLISHED_CUTOFF, WINDOWED, published_range


def range_of(model: Any) -> float | None:
    """The centre distance at which a windowed family reaches 0 (None without a window)."""
    if type(model).window not in WINDOWED:
        return None
    rng = model.range_distance()
    return None if rng is None else float(np.asarray(rng))


def range_params(cls: type) -> tuple[str, ...]:
    """The parameter that sets a family's range (r_max, cutoff, range, d_max, and
    `madams_cutoff`'s irradiance cutoff: `Family.range_setter`), if any: the user's budget,
    which the report never fits."""
    p = cls.range_setter()
    return () if p is None else (p,)


def shape_free(cls: type) -> tuple[str, ...]:
    """The parameters the report fits: the family's default free ones less its range."""
    fixed = set(range_params(cls))
    return tuple(p for p in cls.default_free if p not in fixed)


#: How `published_params` chooses each family's parameters, as written into report.md.
PUBLISHED_RULES: tuple[str, ...] = (
    'a light radius (`r`; `r_min` of `clamped` and `cryengine_linear`, "the radius of the '
    "physical object emitting the light\", RTR4) is the emitter's radius r;",
    f"a window's range is r/√{PUBLISHED_CUTOFF:g} = {1 / math.sqrt(PUBLISHED_CUTOFF):.3g} r, where "
    "the facing irradiance has fallen to 1/1000 of its value at the light's surface (Madams "
    "2011's example cutoff); Madams' warps take d_max = range − r (surface distance) and "
    "`madams_cutoff` the cutoff 1e-3 itself;",
    "`polynomial` takes Madams' kc = 1, kl = 2/r, kq = 1/r² applied to centre distance and "
    "divided by r² (kc = r², kl = 2r, kq = 1), as a renderer plugging its centre distance into "
    "Madams' factors would;",
    "a free `scale` (Just Cause 2, Unreal's exponential mode) matches the truth at d = r;",
    "engine constants (Unreal's eps = 1 cm², Frostbite's 1 cm clamp, Godot's exponent 1, "
    "three.js's decay 2, Unreal's exponent) and the spline's knots keep the family defaults.",
)


def published_params(cls: type, r: float, truth_at: Callable[[float], float] | None = None):
    """Parameters of family `cls` "as published" for a light of radius `r` (m).

    Returns `(params, note)`. The rules, from each family's source:

    * a light radius (`r`; `r_min` of `clamped` and CryEngine, "the radius of the physical
      object emitting the light", RTR4) is the emitter's radius;
    * a range (`range_param`) is `published_range(r)` = r / sqrt(1e-3), where the facing
      irradiance has fallen to 1/1000 of its value at the light's surface (Madams 2011's
      example cutoff); the Madams warps take it as d_max = range - r (surface distance);
      `madams_cutoff` takes the cutoff 1e-3 itself (so its range is the same);
    * `polynomial` takes Madams' kc = 1, kl = 2/r, kq = 1/r^2 applied to centre distance and
      divided by r^2 (kc = r^2, kl = 2 r, kq = 1), as a renderer plugging its centre
      distance into Madams' factors would;
    * a free `scale` (Just Cause 2, Unreal's exponential mode) matches the truth at d = r (the
      reference distance of RTR4 eq. 5.11 at the light's surface), via `truth_at`;
    * engine constants (Unreal's eps = 1 cm^2, Frostbite's 1 cm clamp, Godot's exponent 1,
      three.js's decay 2, Unreal's exponent) and the spline's knots keep the family defaults.
    """
    defaults = cls.defaults()
    params: dict[str, Any] = {}
    notes = []
    rng = published_range(r)
    for p, v in defaults.items():
        if p in cls.at_radius:
            c, k = cls.at_radius[p]
            params[p] = c * math.prod((r,) * k)  # c r^k (r * r, as the rules write it)
        elif p == cls.range_setter():
            # the cutoff itself where it sets the range (exactly, at every radius)
            cutoff = cls.range_tie is not None and cls.range_tie[1] == "cutoff"
            params[p] = PUBLISHED_CUTOFF if cutoff else cls.range_value(rng, r)
        else:
            params[p] = v
    if "scale" in params:
        model = cls(**{**params, "scale": 1.0})
        if truth_at is not None:
            params["scale"] = float(truth_at(r)) / float(np.asarray(model(np.float64(r))))
            notes.append("scale matches the truth at d = r")
    if cls.knots_param is not None:
        notes.append("an authored curve: no published values, defaults shown")
    return params, "; ".join(notes)
