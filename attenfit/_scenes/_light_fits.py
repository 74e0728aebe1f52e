"""Each family fitted to a scene's lights, and the spot falloff variants: the arrays of each
light's judged receivers, the start and free parameters of a fit, and the judged error."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .. import _cache, _progress
from .._curves import (
    SPOT_FALLOFFS,
    Family,
    SpotFalloff,
    SpotFrostbite,
    SpotThreeJS,
    float32_family,
    spot_frostbite,
    spot_threejs,
)
from .._errors import AttenfitError
from .._fit import fit, fit_many, reuse_results
from .._shaders import compiled_cost, measure_throughput, shade_in
from ._family_solves import (
    FAR_RANGE as FAR_RANGE,
)
from ._family_solves import (
    Member,
    Problem,
    group_of,
    member,
    solve_group,
    tied_fn,
)
from ._family_solves import (
    _range_param as _range_param,
)
from ._family_solves import (
    fit_plan as fit_plan,
)
from ._lighting import bucket, bucketed
from ._scene import Scene
from ._types import LightTruth


# ----------------------------------------------------------------------------- per-light data
@dataclasses.dataclass(frozen=True)
class LightData:
    """Arrays of one light's judged receivers (float64 numpy)."""

    d: np.ndarray  # distance (capsule: to the segment)
    wpt: np.ndarray  # point-light weight I g max(0, n.l)
    E_true: np.ndarray
    E_irr: np.ndarray  # the emitter's irradiance before a spot's profile
    cos_s: np.ndarray  # cos of the angle from a spot's axis (1 otherwise)
    theta: np.ndarray
    denom: np.ndarray  # the judged error's denominator
    peak: float
    radius: float
    range: float | None
    spot: tuple[float, float] | None  # (umbra, penumbra) radians
    #: the receivers' world points and unit normals (for an engine's own shading)
    points: np.ndarray | None = None
    normals: np.ndarray | None = None


def light_data(scene: Scene, truth: LightTruth) -> LightData:
    light = scene.lights[truth.light]
    ds = truth.dataset
    j = truth.judged
    d = np.asarray(ds.distance(), dtype=np.float64)[j]
    wpt = np.asarray(ds.weight(), dtype=np.float64)[j]
    E_irr = np.asarray(ds.E, dtype=np.float64)[j]
    E_true = E_irr * truth.profile[j]
    peak = float(E_true.max()) if E_true.size else 0.0
    denom = np.maximum(E_true, scene.error_floor * peak)
    denom = np.where(denom > 0, denom, peak if peak > 0 else 1.0)
    spot = (light.umbra_rad, light.penumbra_rad) if light.is_spot else None
    return LightData(
        d=d,
        wpt=wpt,
        E_true=E_true,
        E_irr=E_irr,
        cos_s=np.cos(truth.theta[j]),
        theta=truth.theta[j],
        denom=denom,
        peak=peak,
        radius=light.radius,
        range=light.range,
        spot=spot,  # type: ignore[arg-type]
        points=np.asarray(ds.points, dtype=np.float64)[j],
        normals=np.asarray(ds.normals, dtype=np.float64)[j],
    )


# ----------------------------------------------------------------------------- fitting
#: Problems per group solve, at least (padded): a scene's and a range search's solves of
#: one group then share one compiled program.
_BATCH = 16

Plan = tuple[dict[str, Any], tuple[str, ...]]
#: One family fitted to lights sharing one set of free parameters.
Request = tuple[type[Family], Sequence[LightData], Sequence[Plan]]
Fitted = list[tuple[Family, bool, str]]


def _problems(cls: type[Family], datas: Sequence[LightData], plans: Sequence[Plan], n: int):
    """A request's problems, each light's samples padded to `n` with zero-weight copies."""
    out = []
    m = member(cls, plans[0][1])
    for x, (start, _) in zip(datas, plans, strict=True):
        ok = x.E_irr > 0
        target = np.where(ok, x.E_irr / x.wpt, 1.0)
        w = np.where(ok, x.E_true / x.denom, 0.0)
        pad = n - len(x.d)
        out.append(
            Problem(
                m,
                start,
                np.concatenate([x.d, np.full(pad, x.d[0])]),
                np.concatenate([target, np.full(pad, target[0])]),
                np.concatenate([w, np.zeros(pad)]),
            )
        )
    return out


def _model(m: Member, start: dict[str, Any], fitted: dict[str, np.ndarray]) -> Family:
    """The family `m.cls` at its start values with the fitted ones in."""
    cls = m.cls
    if m.tied:
        r = float(fitted["r"])
        return cls(r=r, **{cls.range_setter(): cls.range_value(float(start["R"]), r)})
    knots_kw = {"knots": tuple(start["knots"])} if cls.knots_param is not None else {}
    template = cls(**{p: start[p] for p in cls.param_names()}, **knots_kw)
    # as `fit_many` builds its models: a value on its bound (a radius at 0) is kept
    return eqx.tree_at(
        lambda t: t.param_leaves(),
        template,
        [fitted.get(p, start[p]) for p in cls.param_names()],
        is_leaf=lambda x: x is None,
    )


def fit_families(requests: Sequence[Request]) -> list[Fitted | AttenfitError]:
    """Fit each request, in as few compiled solves as their structure allows
    (`_family_solves`): per request, each light's (model, converged, message), or the
    error that kept the family from being fitted."""
    out: list[Fitted | AttenfitError | None] = [None] * len(requests)
    groups: dict[Any, list[int]] = {}
    for i, (cls, datas, plans) in enumerate(requests):
        if not plans[0][1]:
            out[i] = [
                (cls(**{k: s[k] for k in cls.param_names()}), True, "no free parameter")
                for s, _ in plans
            ]
            continue
        key = group_of(member(cls, plans[0][1]))
        n = bucket(max(len(x.d) for x in datas), 64)
        groups.setdefault((key, n) if key is not None else ("alone", i), []).append(i)
    # a bar for several solves; one (a light's range trade, a spot's falloff) goes under the
    # caller's stage line, which a bar of one would repeat for every call
    with _progress.count(len(groups), f"{len(groups)} solves", show=len(groups) > 1) as bar:
        for (key, n), idx in groups.items():
            if key == "alone":
                out[n] = _fit_alone(*requests[n])
            else:
                _solve(key, n, [(i, requests[i]) for i in idx], out)
            bar.update()
    return out  # type: ignore[return-value]


def _solve(members, n: int, requests, out) -> None:
    """Requests of one group in one solve (each alone where that fails: its own error)."""
    problems, owner = [], []
    for i, (cls, datas, plans) in requests:
        problems += _problems(cls, datas, plans, n)
        owner += [i] * len(datas)
    try:
        solved = solve_group(members, problems, _BATCH)
    except AttenfitError:
        for i, req in requests:
            out[i] = _fit_alone(*req)
        return
    for i, _ in requests:
        out[i] = [
            (_model(p.member, p.start, fitted), ok, msg)
            for p, o, (fitted, ok, msg) in zip(problems, owner, solved, strict=True)
            if o == i
        ]


def fit_group(cls: type[Family], datas: Sequence[LightData], plans: Sequence[Plan]) -> Fitted:
    """Fit `cls` to lights sharing one set of free parameters; (model, converged, message)."""
    (res,) = fit_families([(cls, datas, plans)])
    if isinstance(res, AttenfitError):
        raise res
    return res


def _fit_alone(cls: type[Family], datas: Sequence[LightData], plans: Sequence[Plan]):
    """`cls` fitted in a solve of its own (a family no group holds): results, or the error."""
    try:
        return _fit_alone_raising(cls, datas, plans)
    except AttenfitError as exc:
        return exc


def _fit_alone_raising(
    cls: type[Family], datas: Sequence[LightData], plans: Sequence[Plan]
) -> Fitted:
    free = plans[0][1]
    starts = [p[0] for p in plans]
    knots_kw = {"knots": tuple(starts[0]["knots"])} if cls.knots_param is not None else {}
    n = bucket(max(len(x.d) for x in datas), 64)
    b = bucket(len(datas), 2)
    # pad the batch to b problems with copies of the first light (their results are dropped)
    rows = [*range(len(datas)), *([0] * (b - len(datas)))]
    probs = _problems(cls, [datas[k] for k in rows], [plans[k] for k in rows], n)
    D, T, W = (np.stack([getattr(p, a) for p in probs]) for a in ("d", "target", "weights"))
    starts = [starts[src] for src in rows]
    if cls.range_tie is not None:
        fn = tied_fn(cls)
        params = {"r": np.array([s["r"] for s in starts]), "R": np.array([s["R"] for s in starts])}
        with reuse_results():  # an unchanged scene asked again: no solve
            res = fit_many(
                (fn, params, {"r": "positive", "R": "positive"}), D, T, weights=W, free=("r",)
            )
        out = []
        for k in range(len(datas)):
            r, R = float(res[k].params["r"]), float(starts[k]["R"])
            tied = {fn.tied: cls.range_value(R, r)}
            out.append((cls(r=r, **tied), res[k].converged, res[k].message))
        return out
    batched = {p: np.array([s[p] for s in starts]) for p in cls.param_names()}
    model = cls(**batched, **knots_kw)
    with reuse_results():
        res = fit_many(model, D, T, weights=W, free=free)
    return [(res[k].model, res[k].converged, res[k].message) for k in range(len(datas))]


def shade(model: Family, x: np.ndarray, precision: str) -> np.ndarray:
    """`model` at `x` as the scene shades it: in float64 the JAX reference form; in float32
    or float16 the shader form (what `attenfit export` writes), every operation rounded to
    that precision. A family without a shader form ships its stable form: float32 evaluates
    that; in float16 it cannot be judged (an `AttenfitError`)."""
    if precision == "float64":
        return _reference(model, x)
    values = shade_in(model, np.asarray(x, np.float64), precision)
    if values is not None:
        return values.astype(np.float64)
    if precision == "float32":
        f32 = float32_family(model)
        return bucketed(lambda d: f32(jnp.asarray(d, jnp.float32)), x).astype(np.float64)
    raise AttenfitError(f"{model.name} has no shader form to evaluate in {precision}")


def _reference(model: Family, x: np.ndarray) -> np.ndarray:
    """`model` at `x` in float64, its JAX form; for attenfit's own families, from attenfit's
    cache when this code evaluated the same model at the same points before (an unchanged
    scene asked again compiles and runs no program for it)."""
    x = np.asarray(x, np.float64)

    def compute() -> np.ndarray:
        return bucketed(lambda d: model(jnp.asarray(d)), x).astype(np.float64)

    if not _cache.covers(type(model)):
        return compute()
    parts = (model, x, jax.config.jax_enable_x64)
    return _cache.cached_array("values", parts, compute, shape=x.shape)


def judged_errors(data: LightData, f: np.ndarray, g: np.ndarray) -> np.ndarray:
    E = data.wpt * f * g
    with np.errstate(invalid="ignore", over="ignore"):
        err = np.abs(E - data.E_true) / data.denom
    return np.where(np.isfinite(err), err, np.inf)


# ----------------------------------------------------------------------------- spot falloffs
@dataclasses.dataclass(frozen=True)
class SpotVariant:
    name: str  # e.g. "spot_threejs (fitted angles)"
    curve: str
    models: tuple[SpotFalloff | None, ...]  # per light
    g: tuple[np.ndarray, ...]  # per light (ones for non-spots)
    cost: float
    ns: float | None


def _fit_falloff(x: LightData, curve: str) -> SpotFalloff:
    """Fit umbra and penumbra of a spot falloff to a light's true profile."""
    umbra, penumbra = x.spot  # type: ignore[misc]
    profile = x.E_true / np.where(x.E_irr > 0, x.E_irr, 1)
    w = x.E_irr / x.denom
    frac = min(max(penumbra / umbra, 0.02), 0.98)
    fn = _FALLOFF_FNS[curve]
    with reuse_results():  # an unchanged scene asked again: no solve
        res = fit(
            (fn, {"umbra": umbra, "frac": frac}, {"umbra": "positive", "frac": "unit"}),
            x.theta,
            profile,
            loss="absolute",
            weights=w,
        )
    u = float(res.params["umbra"])
    return SPOT_FALLOFFS[curve](umbra=u, penumbra=u * float(res.params["frac"]))


class _Falloff:
    """A spot falloff's profile at angles `theta` as a `(fn, params)` model of its umbra and
    the penumbra's fraction of it: `fn(theta, {"umbra", "frac"})`."""

    def __init__(self, curve: str):
        self.curve = curve
        self.spot = spot_frostbite if curve == "frostbite" else spot_threejs

    def __call__(self, theta, p):
        u = p["umbra"]
        return self.spot(jnp.cos(theta), u, u * p["frac"])

    def cache_key(self) -> str:
        """What this model computes, for the fit stage's cache across processes (its
        solves, and with `reuse_results` their outputs)."""
        return f"scenes-falloff:{self.curve}"


_FALLOFF_FNS = {c: _Falloff(c) for c in ("frostbite", "threejs")}


def spot_variants(
    scene: Scene, datas: Sequence[LightData], measure: bool
) -> tuple[list[SpotVariant], list[dict[str, Any]]]:
    spots = [k for k, x in enumerate(datas) if x.spot is not None]
    if not spots:
        return [
            SpotVariant(
                "",
                "",
                tuple(None for _ in datas),
                tuple(np.ones_like(x.d) for x in datas),
                0.0,
                0.0 if measure else None,
            )
        ], []
    variants, fits = [], []
    costs = {c: compiled_cost(cls(), sass=False).cost for c, cls in SPOT_FALLOFFS.items()}
    ns: dict[str, float] = {}
    if measure:
        timed = measure_throughput([SpotFrostbite(), SpotThreeJS()], n=1 << 16, repeats=5)
        ns = {c: timed[cls.name][0] for c, cls in SPOT_FALLOFFS.items()}
    for curve in scene.spot_falloffs or ("frostbite", "threejs"):
        for fitted in (False, True):
            models: list[SpotFalloff | None] = []
            gs = []
            for k, x in enumerate(datas):
                if x.spot is None:
                    models.append(None)
                    gs.append(np.ones_like(x.d))
                    continue
                if fitted:
                    try:
                        m = _fit_falloff(x, curve)
                        g = shade(m, x.cos_s, scene.precision)
                    except AttenfitError:
                        m, g = None, np.full_like(x.d, np.nan)
                else:
                    m = SPOT_FALLOFFS[curve](umbra=x.spot[0], penumbra=x.spot[1])
                    g = shade(m, x.cos_s, scene.precision)
                models.append(m)
                gs.append(g)
                err = judged_errors(x, x.E_irr / x.wpt, g)
                fits.append(
                    {
                        "light": k,
                        "variant": f"spot_{curve} ({'fitted' if fitted else 'scene'} angles)",
                        "umbra": math.degrees(float(m.umbra)) if m is not None else math.nan,
                        "penumbra": math.degrees(float(m.penumbra)) if m is not None else math.nan,
                        "error": float(err.max()) if err.size else 0.0,
                        "shader_cost": costs[curve],
                    }
                )
            name = f"spot_{curve} ({'fitted' if fitted else 'scene'} angles)"
            variants.append(
                SpotVariant(name, curve, tuple(models), tuple(gs), costs[curve], ns.get(curve))
            )
    return variants, fits
