"""Fit many different families in one compiled solve (the report's "fitted" mode).

`attenfit.fit_many` batches problems of one family; the report fits every family on every
configuration, and compiling one Levenberg-Marquardt solve per family costs ~3 s of CPU each
(20 families: a minute on the reference 2-core machine). Here every (family, configuration)
problem becomes one row of a single `fit_many` call on a `(fn, params)` model:

* `params["u"]` holds the family's free parameters, flattened and mapped to unconstrained
  coordinates with the family's own constraints (`attenfit._fit._reparam`), zero-padded to the
  longest; `params["c"]` the fixed ones; `params["fam"]` the family's index;
* `fn` picks the family with `jax.lax.switch` (under `vmap`, a select over all branches, so
  each row evaluates only its own family's value and derivative).

Padding coordinates do not enter any residual, so they do not move and do not change the
solution; the solution is the same least-squares problem `attenfit.fit` solves for that
family (relative loss, its `default_free`, started at the published values), solved once.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping, Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _cache
from .._fit import fit_many, to_internal, to_param


@dataclasses.dataclass(frozen=True)
class _Layout:
    names: tuple[str, ...]
    shapes: tuple[tuple[int, ...], ...]
    kinds: tuple[str, ...]
    free: tuple[bool, ...]
    offsets: tuple[int, ...]  # into u (free) or c (fixed)


def _layout(cls: type, template: Any, fixed: Collection[str] = ()) -> _Layout:
    names = cls.param_names()
    free = set(cls.default_free) - set(fixed)
    shapes, kinds, isfree, offs = [], [], [], []
    nu = nc = 0
    for n in names:
        shape = tuple(np.shape(getattr(template, n)))
        size = int(np.prod(shape)) if shape else 1
        shapes.append(shape)
        kinds.append(cls.constraint(n))
        isfree.append(n in free)
        if n in free:
            offs.append(nu)
            nu += size
        else:
            offs.append(nc)
            nc += size
    return _Layout(tuple(names), tuple(shapes), tuple(kinds), tuple(isfree), tuple(offs))


def _size(shape: tuple[int, ...]) -> int:
    return int(np.prod(shape)) if shape else 1


def _to_internal(kind: str, p: np.ndarray) -> np.ndarray:

    return np.asarray(to_internal(kind, np.asarray(p, np.float64)), np.float64)


def _to_param(kind: str, u: np.ndarray) -> np.ndarray:

    return np.asarray(to_param(kind, np.asarray(u, np.float64)), np.float64)


def _on_bound(kind: str, v: np.ndarray) -> bool:
    """A fitted value on its constraint's edge (as `attenfit.fit` flags it): 0, or 0/1 for a unit."""
    eps = float(np.finfo(np.float64).eps)
    if kind == "positive":  # exp(u) never reaches 0: ran towards it
        return bool(np.any(v < eps**1.5))
    if kind == "nonnegative":
        return bool(np.any(v == 0))
    if kind == "unit":
        return bool(np.any((v < eps) | (v > 1 - eps)))
    return False


class _Switch:
    """The `(fn, params)` model of every family at once: `fn(d, {"fam", "u", "c"})` is the
    family `fam` with free coordinates `u` and fixed values `c` (`jax.lax.switch`)."""

    def __init__(self, classes: list[type], templates: dict, layouts: dict[type, _Layout]):
        self.classes, self.templates, self.layouts = classes, templates, layouts
        self.branches = [self._branch(cls) for cls in classes]

    def _branch(self, cls: type):
        lay, template = self.layouts[cls], self.templates[cls]

        def branch(u, c, d):
            vals = []
            for shape, kind, isfree, off in zip(
                lay.shapes, lay.kinds, lay.free, lay.offsets, strict=True
            ):
                src = u if isfree else c
                v = src[off : off + _size(shape)].reshape(shape)
                vals.append(to_param(kind, v) if isfree else v)
            m = eqx.tree_at(
                lambda m: [getattr(m, n) for n in lay.names],
                template,
                vals,
                is_leaf=lambda x: x is None,
            )
            return jnp.asarray(m(d), d.dtype)

        return branch

    def __call__(self, d, p):
        idx = jnp.asarray(p["fam"]).astype(jnp.int32)
        return jax.lax.switch(idx, self.branches, p["u"], p["c"], d)

    def cache_key(self) -> str | None:
        """What this model computes (its families, their structure and layout), for the fit
        stage's cache across processes; None when a family is not attenfit's own."""
        if not all(_cache.covers(cls) for cls in self.classes):
            return None
        parts = [
            f"{cls.__module__}.{cls.__qualname__}:{jax.tree_util.tree_structure(self.templates[cls])}"
            f":{self.layouts[cls]}"
            for cls in self.classes
        ]
        return "report-switch:" + ";".join(parts)


def fit_all(
    problems: Sequence[tuple[type, dict[str, Any], np.ndarray, np.ndarray, np.ndarray]],
    *,
    max_steps: int = 256,
    fixed: Mapping[type, Collection[str]] | None = None,
) -> list[tuple[dict[str, Any] | None, dict[str, Any]]]:
    """Fit each problem `(cls, start_params, d, target, weights)` (all `d` of one length).

    Each family's `default_free` parameters are free except those in `fixed[cls]` (the
    report keeps ranges fixed), which keep their start values.

    Returns, per problem, `(params or None, info)`: the fitted parameters (family values,
    None when the fit did not converge) and `info` (converged, message, steps, loss, free).
    Call inside `jax.enable_x64(True)` for a float64 fit.
    """
    classes: list[type] = []
    for cls, *_ in problems:
        if cls not in classes:
            classes.append(cls)
    templates = {cls: cls(**problems[[p[0] for p in problems].index(cls)][1]) for cls in classes}
    fixed = fixed or {}
    layouts = {cls: _layout(cls, templates[cls], fixed.get(cls, ())) for cls in classes}
    K = max([1] + [_count(lay, True) for lay in layouts.values()])
    C = max([1] + [_count(lay, False) for lay in layouts.values()])
    model = _Switch(classes, templates, layouts)
    us, cs = zip(*(_packed(layouts[cls], start, K, C) for cls, start, *_ in problems), strict=True)
    fams = [float(classes.index(cls)) for cls, *_ in problems]
    d = np.stack([p[2] for p in problems])
    target = np.stack([p[3] for p in problems])
    weights = np.stack([p[4] for p in problems])
    params = {"fam": np.asarray(fams), "u": np.stack(us), "c": np.stack(cs)}
    res = fit_many(
        (model, params, {"fam": "real", "u": "real", "c": "real"}),
        d,
        target,
        weights=weights,
        free=("u",),
        loss="relative",
        max_steps=max_steps,
        guess=False,
    )
    return [
        _unpacked(layouts[cls], res[i], np.asarray(res.params["u"][i], np.float64), cs[i])
        for i, (cls, *_rest) in enumerate(problems)
    ]


def _count(lay: Any, free: bool) -> int:
    """How many numbers a layout's free (or fixed) parameters take."""
    return sum(_size(s) for s, f in zip(lay.shapes, lay.free, strict=True) if f == free)


def _packed(lay: Any, start: Mapping[str, Any], K: int, C: int) -> tuple[np.ndarray, np.ndarray]:
    """A problem's start values packed: the free ones (internal form) into `u` (length K),
    the fixed ones into `c` (length C)."""
    u, c = np.zeros(K), np.zeros(C)
    for n, shape, kind, isfree, off in zip(
        lay.names, lay.shapes, lay.kinds, lay.free, lay.offsets, strict=True
    ):
        v = np.broadcast_to(np.asarray(start[n], np.float64), shape).ravel()
        if isfree:
            u[off : off + v.size] = _to_internal(kind, v)
        else:
            c[off : off + v.size] = v
    return u, c


def _unpacked(lay: Any, fr: Any, u: np.ndarray, c: np.ndarray):
    """One problem's result: `(params or None, info)` from its fit result and packed values."""
    fitted: dict[str, Any] = {}
    for n, shape, kind, isfree, off in zip(
        lay.names, lay.shapes, lay.kinds, lay.free, lay.offsets, strict=True
    ):
        v = (
            _to_param(kind, u[off : off + _size(shape)]) if isfree else c[off : off + _size(shape)]
        ).reshape(shape)
        fitted[n] = float(v) if shape == () else v
    ok = bool(fr.converged) and all(np.all(np.isfinite(np.asarray(v))) for v in fitted.values())
    info = {
        "converged": ok,
        "message": fr.message.splitlines()[0] if fr.message else "",
        "steps": int(fr.steps),
        "loss": float(fr.loss),
        "free": [n for n, f in zip(lay.names, lay.free, strict=True) if f],
        "at_bound": [
            n
            for n, kind, isfree in zip(lay.names, lay.kinds, lay.free, strict=True)
            if isfree and _on_bound(kind, np.asarray(fitted[n], np.float64))
        ],
        "solver": "attenfit.fit_many, levenberg_marquardt, relative loss (all families in one solve)",
        "last_params": {
            k: (v if isinstance(v, float) else np.asarray(v).tolist()) for k, v in fitted.items()
        },
    }
    return (fitted if ok else None, info)
