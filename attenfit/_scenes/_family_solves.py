"""A scene's family fits in a few compiled solves: one per shape of fit, not one per family.

Fitting each family to a scene's lights took one compiled `fit_many` solve per family (19
programs; XLA compiling them was most of a cold `attenfit scene`). Families whose fits have
the same structure share one: the same free parameters' constraints and shapes, the same of
them scaled as lengths by the start scan (`attenfit._fit._guess`) and the same range scanned
beyond the data. Such a *group* is solved as one `fit_many` call on a `(fn, params)` model:

* `params["f0"], ...` are the family's free parameters, in its `free` order (as the
  family's own fit has them: same constraint, same place in the fitted vector);
  `params["c"]` its fixed ones, flattened and zero-padded; `params["fam"]` its index;
* `fn` evaluates family `fam` (`jax.lax.switch`; under `vmap`, a select over every
  branch, so each problem's residuals and Jacobian are its own family's) and declares the
  group's length and range parameters and (a group of one family) its linear start, which
  `attenfit._fit` reads as it reads a `Model` class's.

So each problem starts from the same candidates, takes the same solver steps (to rounding)
and ends with the same final pass as its family's own solve would
(`tests/test_solve_programs.py` compares the two). The groups are fixed by attenfit's own
families (`_groups`), not by a scene's choice of them, so every scene with the same shape
buckets runs the same programs: `attenfit warm` compiles them once.

A user's own family, a fit whose structure no attenfit family has, or a linear start over a
pinned parameter are fitted alone (`fit_alone`), as before.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import re
import types
from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._curves import Family, get_family, list_families, spline_curve
from .._fit import fit_many, reuse_results

#: A fit's structure: per free parameter (constraint, shape, scaled as a length, the
#: scanned range); and the family whose linear start it takes (None: none).
Signature = tuple[tuple[tuple[str, tuple[int, ...], bool, bool], ...], str | None]


@dataclasses.dataclass(frozen=True)
class Member:
    """One way of fitting a family: its free parameters and how the others are packed."""

    cls: type[Family]
    free: tuple[str, ...]
    tied: bool  # the range parameter tied to the fitted `r` (`Family.range_tie`)

    @property
    def fixed(self) -> tuple[str, ...]:
        """What `params["c"]` holds, in order: the light's range for a tied fit, the knots
        for an authored curve, else the family's fixed parameters."""
        if self.tied:
            return ("R",)
        if self.cls.knots_param is not None:
            return ("knots",)
        return tuple(p for p in self.cls.param_names() if p not in self.free)


def _shape(cls: type[Family], p: str) -> tuple[int, ...]:
    return tuple(np.shape(cls.defaults()[p]))


def signature(m: Member) -> Signature:
    """The structure of `m`'s fit (what its compiled solve depends on besides the model)."""
    cls = m.cls
    if m.tied:  # the (fn, params) model of `_light_fits._Tied`: r positive, no facts
        return ((("positive", (), False, False),), None)
    rows = tuple(
        (cls.constraint(p), _shape(cls, p), p in cls.length_params, p == cls.range_param)
        for p in m.free
    )
    return rows, (cls.name if cls.inverse_linear is not None else None)


def member(cls: type[Family], free: tuple[str, ...]) -> Member:
    return Member(cls, tuple(free), cls.range_tie is not None)


def _own(cls: type) -> bool:
    return cls.__module__.startswith("attenfit.")


@functools.cache
def _groups() -> dict[Signature, tuple[Member, ...]]:
    """Every way attenfit's own families are fitted to a light (with a range and without:
    `fit_plan`), grouped by signature; a family with a linear start is a group of its own."""
    out: dict[Signature, list[Member]] = {}
    for name in list_families():
        cls = get_family(name)
        if not _own(cls):
            continue
        for rng in (None, 1.0):
            _, free = fit_plan(cls, plan_light(rng), 1.0, (0.1, 1.0))
            if not free:
                continue
            m = member(cls, free)
            group = out.setdefault(signature(m), [])
            if m not in group:
                group.append(m)
    return {sig: tuple(ms) for sig, ms in out.items()}


def group_of(m: Member) -> tuple[Member, ...] | None:
    """The members of `m`'s group (in a fixed order), or None: fitted alone."""
    if not _own(m.cls):
        return None
    group = _groups().get(signature(m))
    return group if group is not None and m in group else None


# ----------------------------------------------------------------------------- plans
def _range_param(cls: type[Family]) -> str | None:
    """The parameter a light's range sets (`Family.range_setter`; kept for `_choices`)."""
    return cls.range_setter()


#: A light with no range gives windowed families a range this many times the farthest
#: receiver (where their window is below 1e-4 of relative effect), unless the family's
#: own default frees its range (`just_cause_2`, whose shape needs it).
FAR_RANGE = 10.0


def fit_plan(
    cls: type[Family], data: Any, d_hi: float, knots: tuple[float, ...]
) -> tuple[dict[str, Any], tuple[str, ...]]:
    """Start values and free parameters of `cls` for one light (`data`: its `LightData`,
    of which the radius and range are read)."""
    vals = dict(cls.defaults())
    rp = _range_param(cls)
    for p in cls.param_names():
        if p == rp:
            continue
        power = cls.length_power(p)
        if power == 1:
            vals[p] = data.radius * (2.0 if p == "kl" else 1.0)
        elif power == 2:
            vals[p] = data.radius**2
    if cls.knots_param is not None:  # an authored curve: a facing disk's through the knots
        k = np.asarray(knots)
        vals[cls.knots_param] = -np.log(k * k + data.radius**2)
        vals["knots"] = knots
    free = tuple(cls.default_free)
    if rp is not None:
        R = data.range
        if R is None and rp in free:
            vals[rp] = 2.0 * d_hi
        else:
            free = tuple(p for p in free if p != rp)
            R = FAR_RANGE * d_hi if R is None else R
            vals["R"] = R
            vals[rp] = cls.range_value(R, data.radius)
    return vals, free


class _Tied:
    """`cls` with its range parameter tied to the fitted `r` and the light's range `R`
    (`Family.range_tie`), as a `(fn, params)` model: `fn(d, {"r": r, "R": R})`."""

    def __init__(self, cls: type[Family]):
        self.cls = cls
        self.tied = cls.range_setter()

    def __call__(self, d, p):
        return self.cls(r=p["r"], **{self.tied: self.cls.range_value(p["R"], p["r"])})(d)

    def cache_key(self) -> str:
        """What this model computes, for the fit stage's cache across processes."""
        return f"scenes-tied:{self.cls.__module__}.{self.cls.__qualname__}:{self.tied}"


_TIED_FNS: dict[str, _Tied] = {}


def tied_fn(cls: type[Family]) -> _Tied:
    """The one `_Tied` model of `cls` (compiled solves are cached by it)."""
    return _TIED_FNS.setdefault(cls.name, _Tied(cls))


def plan_light(range_: float | None) -> Any:
    """A light of radius 0.1 with or without a range, all `fit_plan` reads (which free
    parameters a fit has does not depend on the receivers)."""
    return types.SimpleNamespace(radius=0.1, range=range_)


# ----------------------------------------------------------------------------- the model
def _c_size(m: Member, knots: int) -> int:
    if m.tied:
        return 1
    if m.cls.knots_param is not None:
        return knots
    return sum(math.prod(_shape(m.cls, p)) for p in m.fixed)


class GroupModel:
    """The `(fn, params)` model of a group: `fn(d, {"fam", "c", "f0", ...})`."""

    def __init__(self, members: tuple[Member, ...], knots: int):
        self.members, self.knots = members, knots
        sig, il = signature(members[0])
        self.free_names = tuple(f"f{i}" for i in range(len(sig)))
        self.length_params = tuple(n for n, row in zip(self.free_names, sig, strict=True) if row[2])
        self.range_param = next(
            (n for n, row in zip(self.free_names, sig, strict=True) if row[3]), None
        )
        self.constraints = {n: row[0] for n, row in zip(self.free_names, sig, strict=True)}
        self.inverse_linear = None if il is None else self._linear(members[0])
        self.c_size = max(1, *(_c_size(m, knots) for m in members))
        self.branches = [self._branch(m) for m in members]

    def _linear(self, m: Member):
        """The family's linear start (`Model.inverse_linear`) over the group's names."""
        offset, basis = m.cls.inverse_linear
        rename = dict(zip(m.free, self.free_names, strict=True))
        return offset, {rename[p]: b for p, b in basis.items()}

    def _branch(self, m: Member):
        cls = m.cls
        if m.tied:
            fn = tied_fn(cls)
            return lambda d, p: jnp.asarray(fn(d, {"r": p["f0"], "R": p["c"][0]}), d.dtype)
        if cls.knots_param is not None:
            return lambda d, p: spline_curve(
                d, p["f0"].astype(d.dtype), p["c"][: self.knots].astype(d.dtype)
            )
        names = cls.param_names()
        template = cls()
        cuts = np.cumsum([0] + [math.prod(_shape(cls, q)) for q in m.fixed])

        def branch(d, p):
            vals = {q: p[f"f{i}"] for i, q in enumerate(m.free)}
            for q, a, b in zip(m.fixed, cuts[:-1], cuts[1:], strict=True):
                vals[q] = p["c"][a:b].reshape(_shape(cls, q))
            model = eqx.tree_at(
                lambda t: t.param_leaves(),
                template,
                [vals[q] for q in names],
                is_leaf=lambda x: x is None,
            )
            return jnp.asarray(model(d), d.dtype)

        return branch

    def __call__(self, d, p):
        if len(self.branches) == 1:
            return self.branches[0](d, p)
        return jax.lax.switch(jnp.asarray(p["fam"]).astype(jnp.int32), self.branches, d, p)

    def cache_key(self) -> str:
        """What this model computes, for the fit stage's cache across processes."""
        parts = [
            f"{m.cls.__module__}.{m.cls.__qualname__}:{m.free}:{m.fixed}:{m.tied}"
            for m in self.members
        ]
        return f"scene-group:{self.knots}:" + ";".join(parts)


@functools.cache
def group_model(members: tuple[Member, ...], knots: int) -> GroupModel:
    """One model object per group (the fit stage caches compiled solves by it)."""
    return GroupModel(members, knots)


# ----------------------------------------------------------------------------- solving
@dataclasses.dataclass
class Problem:
    """One family fitted to one light: its rows of the solve and its start values."""

    member: Member
    start: dict[str, Any]
    d: np.ndarray
    target: np.ndarray
    weights: np.ndarray


def _packed_c(m: Member, start: dict[str, Any], size: int) -> np.ndarray:
    c = np.zeros(size)
    if m.tied:
        c[0] = start["R"]
    elif m.cls.knots_param is not None:
        k = np.asarray(start["knots"], np.float64)
        c[: k.size] = k
    else:
        vals = [np.ravel(np.asarray(start[q], np.float64)) for q in m.fixed]
        if vals:
            flat = np.concatenate(vals)
            c[: flat.size] = flat
    return c


def solve_group(
    members: tuple[Member, ...], problems: Sequence[Problem], bucket: int
) -> list[tuple[dict[str, np.ndarray], bool, str]]:
    """Solve `problems` (all of `members`' group, samples padded to one length) in one
    `fit_many` call; per problem, (fitted free values by name, converged, message). The
    batch is padded to a multiple of `bucket` problems (copies of the first, dropped)."""
    knots = max(
        [2] + [len(p.start["knots"]) for p in problems if p.member.cls.knots_param is not None]
    )
    model = group_model(members, knots)
    b = max(bucket, 1 << max(0, (len(problems) - 1).bit_length()))
    rows = [*problems, *([problems[0]] * (b - len(problems)))]
    params: dict[str, np.ndarray] = {
        "fam": np.array([float(members.index(p.member)) for p in rows]),
        "c": np.stack([_packed_c(p.member, p.start, model.c_size) for p in rows]),
    }
    for i, name in enumerate(model.free_names):
        params[name] = np.stack([np.asarray(p.start[p.member.free[i]], np.float64) for p in rows])
    kinds = {"fam": "real", "c": "real", **model.constraints}
    with reuse_results():  # an unchanged scene asked again: no solve
        res = fit_many(
            (model, params, kinds),
            np.stack([p.d for p in rows]),
            np.stack([p.target for p in rows]),
            weights=np.stack([p.weights for p in rows]),
            free=model.free_names,
        )
    out = []
    for k, p in enumerate(problems):
        fitted = {
            q: np.asarray(res.params[n][k])
            for q, n in zip(p.member.free, model.free_names, strict=True)
        }
        out.append((fitted, bool(res.converged[k]), _renamed(res[k].message, p.member, model)))
    return out


def _renamed(message: str, m: Member, model: GroupModel) -> str:
    """A solve's message with the group's parameter names as the family's."""
    rename = dict(zip(model.free_names, m.free, strict=True))

    def names(match: re.Match) -> str:
        listed = match.group(2).split(", ")
        return match.group(1) + ", ".join(rename.get(n, n) for n in listed)

    return re.sub(r"(on its bound: )([^;]*)", names, message)
