"""Shared helpers for the family tests: cases, scaled instances, jitted batched evaluation.

Every registered family is a case (plus CryEngine's plain-linear option), so a new family is
tested everywhere by registering it. Each (case, dtype) compiles once: the whole grid of
radii x distances is one vmapped, jitted call.
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np

import attenfit

#: (registry name, static options) for every registered family, plus static variants.
CASES = [(name, ()) for name in attenfit.list_families()] + [
    ("cryengine_linear", (("squared", False),))
]
CASE_IDS = [name + "".join(f"-{k}={v}" for k, v in static) for name, static in CASES]

#: The issue's radii: every length parameter scales with R / 0.1 (0.1 m is the default r).
RADII = (1e-6, 1e-3, 0.1, 1.0, 1e3)
#: The issue's distances (the entry None stands for the instance's radius R).
BASE_D = (0.0, 1e-30, 1e-12, 1e-6, 1e-3, None, 1.0, 1e3, 1e6, 1e12)
#: Relative offsets around a window's range (0 for a family without one: extra far points).
NEAR_RANGE = (-3e-2, -5e-3, -2e-3, -5e-4, -1e-6, 0.0, 1e-3)


def scaled_params(cls, s: float) -> dict[str, np.ndarray]:
    """Default parameters with every dimensional parameter scaled by s^(its length power)."""
    out = {}
    for name, value in cls.defaults().items():
        out[name] = np.asarray(value, dtype=np.float64) * s ** cls.length_power(name)
    return out


def instances(
    name: str, static: tuple, dtype=np.float64
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Stacked parameters (leading axis = RADII, rounded to `dtype`, held as float64) and the
    (radii, points) distance grid in `dtype`. The points around the range use the range as the
    instance computes it in `dtype`, so "at the range" is exact in either precision."""
    cls = attenfit.get_family(name)
    params = [
        {k: v.astype(dtype).astype(np.float64) for k, v in scaled_params(cls, r / 0.1).items()}
        for r in RADII
    ]
    stacked = {k: np.stack([p[k] for p in params]) for k in params[0]}
    grid = []
    for r, p in zip(RADII, params, strict=True):
        fam = cls(**{k: jnp.asarray(v, dtype=dtype) for k, v in p.items()}, **dict(static))
        rng = fam.range_distance()
        row = [dtype(r if d is None else d) for d in BASE_D]
        if rng is None:
            row += [dtype(r * 10.0**k) for k in (-1, 0.5, 1, 2, 4, 7, 15)]
        else:
            rng = np.asarray(rng, dtype=dtype)
            row += [rng * dtype(1 + e) if e else rng for e in NEAR_RANGE]
        grid.append(row)
    return stacked, np.asarray(grid, dtype=dtype)


def range_of(name: str, static: tuple, params: dict[str, np.ndarray]) -> np.ndarray | None:
    """The range distance of each stacked instance (float64), or None."""
    cls = attenfit.get_family(name)
    n = len(RADII)
    out = []
    for i in range(n):
        fam = cls(
            **{k: np.float64(v[i]) if v.ndim == 1 else v[i] for k, v in params.items()},
            **dict(static),
        )
        rng = fam.range_distance()
        if rng is None:
            return None
        out.append(float(rng))
    return np.asarray(out)


@functools.cache
def evaluator(name: str, static: tuple):
    """jit of (params, d) -> (f, df/dd, {df/dp}) at every point of the (instances, points) grid.

    The stacked parameters are broadcast to the grid's shape, so the family evaluates
    elementwise and one reverse pass (a vjp with unit cotangents) gives every point's
    gradients: much cheaper to compile than vmap(grad).
    """
    cls = attenfit.get_family(name)
    opts = dict(static)

    def run(p, d):
        def pointwise(p_full, d):
            return cls(**p_full, **opts)(d)

        p_full = {
            k: jnp.broadcast_to(v.reshape((*v.shape[:1], 1, *v.shape[1:])), d.shape + v.shape[1:])
            for k, v in p.items()
        }
        vals, pullback = jax.vjp(pointwise, p_full, d)
        gp, gd = pullback(jnp.ones_like(vals))
        return vals, gd, gp

    return jax.jit(lambda *pairs: [run(pairs[i], pairs[i + 1]) for i in range(0, len(pairs), 2)])


def evaluate(name: str, static: tuple, *runs) -> list:
    """Values, d-gradients and parameter gradients of stacked instances, as numpy.

    `runs` are (params, d, dtype) triples, evaluated in one compiled program (one compile per
    family for all dtypes).
    """
    args = []
    for params, d, dtype in runs:
        args += [
            {k: jnp.asarray(v, dtype=dtype) for k, v in params.items()},
            jnp.asarray(d, dtype=dtype),
        ]
    out = evaluator(name, static)(*args)
    return [
        (np.asarray(vals), np.asarray(gd), {k: np.asarray(v) for k, v in gp.items()})
        for vals, gd, gp in out
    ]


@functools.cache
def scalar_fn(name: str, static: tuple = ()):
    """jit of (params dict, d) -> f, for hypothesis tests (fixed shapes: compiles once)."""
    cls = attenfit.get_family(name)
    opts = dict(static)
    return jax.jit(lambda p, d: cls(**p, **opts)(d))
