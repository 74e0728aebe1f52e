"""Recommend the cheapest attenuation family that a scene's receivers cannot tell from the truth.

`recommend(scene)`:

1. **Truth, only where the scene looks.** `Scene.ground_truth()`: the exact irradiance of
   each of the scene's lights at exactly the scene's receivers (no other radius, distance
   or angle is generated).
2. **Fit every family the scene's constraints allow**, per light, in one `fit_many` solve
   per shape of fit, families of the same structure together (`_family_solves`; lights
   grouped by whether they have a range). The residual of a receiver is
   its judged error (below), so the least-squares fit aims at what is judged. Length
   parameters start at the light's radius; a light's `range` is pinned into the family's
   range parameter (`r_max`, `cutoff`, `range`; Madams' surface-distance `d_max = range - r`
   and `madams_cutoff`'s `cutoff = (r/range)^2` are tied to the fitted `r`); a light with no
   range leaves a window's range free. `spline` puts its knots over the scene's distances.
3. **Spots** fit their angular falloff too: `spot_frostbite` (t^2) and `spot_threejs`
   (smoothstep) of `attenfit.directional`, each with the scene's umbra and penumbra as given
   and with both angles fitted (weighted like the distance fit). Each family is paired with
   the cheapest falloff variant that keeps it within tolerance (else the most accurate).
4. **Judge** each candidate by its largest error over the judged receivers of every light:
   `|E_model - E_true| / max(E_true, error_floor * E_peak)`, with `E_peak` the light's
   brightest judged receiver; receivers whose truth is 0 (outside a spot's cone) are judged
   relative to `E_peak` (or to the floor, if one is set). Receivers beyond a light's range
   are not judged (the engine culls them), nor are receivers facing away from the light's
   centre (every point-light model gives 0 there; the count of those that the truth still
   lights is reported). With `float32`, candidates are evaluated in float32.
5. **Rank** the candidates within tolerance by the compiled cost of their shader form, the
   code `attenfit export` writes (`attenfit.cost.structural_cost`: SPIR-V instructions from
   glslangValidator and `spirv-opt -O`, else NVIDIA SASS instructions, else the labelled
   traced-operation estimate; counted with generic parameter values, so a family costs the
   same for every light, as in an engine that reads them from the light), then by error,
   with `attenfit._judge.rank`, the tie-break of every verdict (errors equal to 3
   significant digits go to the family with fewer parameters, then the smaller error, then
   the name; docs/report.md, "How a model is chosen"). The measured time
   (`attenfit.cost.measure_throughput`, when `measure=True`) is reported for every
   candidate, never ranked: the compiled count is deterministic and describes the shader
   the user will ship, while the measured time is of XLA on this machine and moves by
   10-30% between runs on a shared machine. A scene's `precision` (float32, float16)
   evaluates every shader form in that precision at the judged receivers: a family that
   overflows or flushes to 0 there is refused with the reason, one that loses accuracy is
   judged on what it computes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import jax.numpy as jnp
import numpy as np

from .. import _progress
from .._curves import Family, get_family, list_families
from .._errors import AttenfitError, BadTypeError, BadValueError
from .._float64 import in_float64
from .._judge import Contender, rank
from .._shaders import LANGUAGES, export, in_parallel, measure_throughput, structural_cost
from ._advice import Candidate, Recommendation, pct
from ._light_fits import (
    LightData,
    SpotVariant,
    _range_param,
    fit_families,
    fit_plan,
    judged_errors,
    light_data,
    shade,
    spot_variants,
)
from ._scene import Scene, receiver_count
from ._types import LightTruth

__all__ = ["recommend"]


# ----------------------------------------------------------------------------- recommend
def _candidate_names(scene: Scene) -> list[str]:
    return list(scene.families) if scene.families is not None else list_families()


def check_reaches_zero(model: Family, R: float) -> str | None:
    """None if `model` is 0 beyond `R` and at `R` (to rounding: 1e-9 of f(R/2)), else why not."""
    x = np.array([R, R * (1 + 1e-6), 2 * R, R / 2])
    v = np.asarray(model(jnp.asarray(x)), dtype=np.float64)
    if v[1] == 0 and v[2] == 0 and abs(v[0]) <= 1e-9 * abs(v[3]):
        return None
    where = v[0] if v[1] == 0 and v[2] == 0 else v[1]
    return f"does not reach 0 at the range {R:g} (f = {where:.3g} there)"


@in_float64
def recommend(
    scene: Scene, *, measure: bool = False, truths: Sequence[LightTruth] | None = None
) -> Recommendation:
    """Fit and judge every family on `scene`; recommend the cheapest within tolerance.

    See the module docstring for how the truth is generated, fitted, judged and ranked.
    `measure=True` also times each candidate on this machine (reported beside the compiled
    cost, which ranks; a few seconds more). `truths`: the scene's `ground_truth()`, when
    the caller has it already.
    """
    if not isinstance(scene, Scene):
        raise BadTypeError(f"recommend takes an attenfit.Scene, got {type(scene).__name__}")
    truths, datas = _judged_truth(scene, truths)
    variants, directional_fits = spot_variants(scene, datas, measure)
    fitted, candidates = _fit_families(scene, datas)
    _progress.stage("shader costs")
    costs, cost_label = _shader_costs(fitted)
    ns = _measured(fitted) if measure and fitted else {}
    curves: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, fit in fitted.items():
        cand, curves[name] = _judge_family(scene, name, fit, datas, variants, costs[name], ns)
        candidates.append(cand)
    ordered, winner, runner_up, closest = order(candidates, scene.tolerance)
    d_far = max(float(x.d.max()) for x in datas)
    shaders = _shaders(winner, len(datas), scene.source, d_far) if winner is not None else {}
    area = None
    if winner is None:  # no f(d) meets the tolerance: try the area models (_escalate)
        area = _escalation(scene, truths, datas, ordered)
        shaders = area.shaders or shaders
    truth = tuple(_truth_summary(scene, t, x) for t, x in zip(truths, datas, strict=True))
    return Recommendation(
        scene=scene,
        candidates=ordered,
        winner=winner,
        runner_up=runner_up,
        closest=closest,
        shaders=shaders,
        truth=truth,
        directional_fits=tuple(directional_fits),
        measured=bool(measure),
        curves=curves,
        angles=np.concatenate(  # a spot's receivers: their angle from its axis, for the plot
            [
                np.degrees(x.theta) if x.spot is not None else np.full(x.d.shape, np.nan)
                for x in datas
            ]
        ),
        cost_label=cost_label,
        area=area,
    )


def order(
    candidates: Sequence[Candidate], tolerance: float
) -> tuple[tuple[Candidate, ...], Candidate | None, Candidate | None, Candidate | None]:
    """`(ordered, winner, runner_up, closest)` of a scene's candidates, ranked over every
    light by `attenfit._judge.rank` (the tie-break of every verdict): passing ones cheapest
    first, then failing ones most accurate first, then excluded ones; the winner the first
    passing one; the runner-up the second, or the most accurate failing one; the closest
    the most accurate of all."""
    ranking = rank((c.contender() for c in candidates), tolerance)
    passing = [c.item for c in ranking.within]
    failing = [c.item for c in ranking.outside if c.item.status == "fail"]  # type: ignore[union-attr]
    excluded = [c.item for c in ranking.outside if c.item.status == "excluded"]  # type: ignore[union-attr]
    winner = passing[0] if passing else None
    runner_up = None
    if len(passing) > 1:
        runner_up = passing[1]
    elif winner is not None and failing:
        runner_up = failing[0]
    closest = ranking.closest.item if ranking.closest is not None else None
    return (*passing, *failing, *excluded), winner, runner_up, closest  # type: ignore[return-value]


def _escalation(
    scene: Scene,
    truths: Sequence[LightTruth],
    datas: Sequence[LightData],
    candidates: Sequence[Candidate],
) -> Any:
    """The area answer of a scene no family meets at every light (`_escalate.AreaAnswer`):
    each light no family meets on its own escalated alone, and the family the other lights
    keep, ranked as every verdict (`Candidate.contender` over those lights)."""
    from ._escalate import escalate_lights

    _progress.stage("no family meets the tolerance: area-light models")
    fitted = [c for c in candidates if c.models]
    need, closest = [], {}
    for i in range(len(datas)):
        ranking = rank((c.contender(i) for c in fitted), scene.tolerance)
        if ranking.best is None:
            need.append(i)
            if ranking.closest is not None:
                closest[i] = (ranking.closest.item.label, float(ranking.closest.error))
    area = escalate_lights(scene, truths, datas, need, closest)
    rest = [i for i in range(len(datas)) if i not in need]
    if not rest or not need:
        return area
    best = rank((c.contender(rest) for c in fitted), scene.tolerance).best
    if best is None:
        return area
    pick = best.item
    pick = dataclasses.replace(  # the family as the other lights keep it
        pick,
        status="pass",
        reason="within tolerance at the other lights",
        error=best.error,
        error_by_light=tuple(pick.error_by_light[i] for i in rest),
        directional_params=tuple(pick.directional_params[i] for i in rest)
        if pick.directional_params
        else (),
        params=tuple(pick.params[i] for i in rest),
        models=tuple(pick.models[i] for i in rest),
        spot_models=tuple(pick.spot_models[i] for i in rest) if pick.spot_models else (),
    )
    shaders = _shaders(pick, len(rest), scene.source, max(float(datas[i].d.max()) for i in rest))
    return dataclasses.replace(
        area, others=pick, others_error=float(best.error), others_shaders=shaders
    )


# ----------------------------------------------------------------------------- the steps
_Fitted = tuple[list[Family], list[bool], list[str]]


def _judged_truth(
    scene: Scene, truths: Sequence[LightTruth] | None
) -> tuple[tuple[LightTruth, ...], list[LightData]]:
    """The scene's ground truth (computed unless given) and each light's judged receivers;
    a light with none is an error naming it."""
    n_receivers = receiver_count(scene.receivers)
    _progress.stage(f"ground truth: {len(scene.lights)} lights, up to {n_receivers} receivers each")
    truths = scene.ground_truth() if truths is None else tuple(truths)
    datas = [light_data(scene, t) for t in truths]
    for k, x in enumerate(datas):
        if x.d.size == 0:
            raise BadValueError(
                f"{scene.source}: [[lights]][{k}]: no receiver can be judged for this light "
                "(all are beyond its range or face away from it)"
            )
    return truths, datas


def _fit_families(
    scene: Scene, datas: Sequence[LightData]
) -> tuple[dict[str, _Fitted], list[Candidate]]:
    """Every candidate family fitted to every light (`_family_requests`, in few solves): the fitted ones, and
    the candidates of those excluded or not fitted."""
    d_all = np.concatenate([x.d for x in datas])
    d_lo, d_hi = float(d_all.min()), float(d_all.max())
    knots = (
        tuple(float(k) for k in np.geomspace(d_lo, d_hi, 6)) if d_hi > d_lo else (d_lo, d_lo * 2)
    )
    fitted: dict[str, _Fitted] = {}
    candidates: list[Candidate] = []
    names = _candidate_names(scene)
    _progress.stage(f"fitting {len(names)} families")
    requests: list[tuple[str, list[int], Any]] = []
    for name in names:
        requests += _family_requests(scene, name, datas, d_hi, knots, candidates)
    solved = fit_families([req for _, _, req in requests])
    for name in dict.fromkeys(name for name, _, _ in requests):
        results: list[Any] = [None] * len(datas)
        error = None
        for (nm, group, _), out in zip(requests, solved, strict=True):
            if nm != name:
                continue
            if isinstance(out, AttenfitError):
                error = error or out
                continue
            for k, r in zip(group, out, strict=True):
                results[k] = r
        if error is not None:
            candidates.append(Candidate(name, "fail", f"could not be fitted: {error}"))
            continue
        fitted[name] = (
            [r[0] for r in results],
            [bool(r[1]) for r in results],
            [r[2] for r in results],
        )
    return fitted, candidates


def _shader_costs(fitted: dict[str, _Fitted]) -> tuple[dict[str, float], str]:
    """Each fitted family's compiled cost (with the first light's parameters baked, or its
    defaults where those cannot be), and the label of how it was counted."""

    def cost(item: tuple[str, _Fitted]) -> Any:
        name, (models, _, _) = item
        try:
            return structural_cost(models[0])
        except (AttenfitError, ValueError):  # parameters a shader cannot bake (non-finite)
            return structural_cost(get_family(name)())

    counted = in_parallel(cost, list(fitted.items()))
    costs = {name: c.cost for name, c in zip(fitted, counted, strict=True)}
    return costs, counted[-1].label() if counted else ""


def _measured(fitted: dict[str, _Fitted]) -> dict[str, float]:
    """Nanoseconds per evaluation of each fitted family with finite parameters, measured."""
    _progress.stage("measuring each candidate on this machine")
    to_time = []
    for models, _, _ in fitted.values():
        m = models[0]
        if all(np.all(np.isfinite(np.asarray(v))) for v in m.params().values()):
            to_time.append(m)
    if not to_time:
        return {}
    timed = measure_throughput(to_time, n=1 << 16, repeats=5)
    return {k: v[0] for k, v in timed.items()}


def _judge_family(
    scene: Scene,
    name: str,
    fit: _Fitted,
    datas: Sequence[LightData],
    variants: Sequence[SpotVariant],
    cost: float,
    ns: dict[str, float],
) -> tuple[Candidate, tuple[np.ndarray, np.ndarray]]:
    """A fitted family judged on the scene with its best spot falloff variant: its
    `Candidate`, and its judged errors against d/r over every light (for the figure)."""
    models, conv, msgs = fit
    f_by_light, bad = _shade(scene, models, datas)
    v, errs, e = _pick_variant(variants, datas, f_by_light, scene.tolerance)
    converged = all(conv)
    status, reason = _verdict(scene, e, errs, datas, models, msgs, converged, bad)
    cand = Candidate(
        family=name,
        status=status,
        reason=reason,
        error=e,
        error_by_light=tuple(float(er.max()) for er in errs),
        shader_cost=cost + v.cost,
        ns_per_eval=(ns[name] + v.ns) if (name in ns and v.ns is not None) else None,
        params=tuple(_plain_params(m) for m in models),
        converged=converged,
        message="; ".join(dict.fromkeys(msgs)),
        directional=v.name or None,
        directional_params=_angles(v) if v.name else (),
        models=tuple(models),
        spot_models=v.models,
    )
    curve = (np.concatenate([x.d / x.radius for x in datas]), np.concatenate(errs))
    return cand, curve


def _shade(
    scene: Scene, models: Sequence[Family], datas: Sequence[LightData]
) -> tuple[list[np.ndarray], str | None]:
    """Each light's model evaluated in the scene's precision at its judged distances, and
    why the shader form fails there (None if it does not)."""
    f_by_light = []
    bad = None
    for x, m in zip(datas, models, strict=True):
        try:
            f = shade(m, x.d, scene.precision)
            bad = bad or _precision_problem(m, x.d, f, scene.precision)
            f_by_light.append(f)
        except AttenfitError as exc:
            bad = str(exc)
            f_by_light.append(np.full_like(x.d, np.nan))
    return f_by_light, bad


def _pick_variant(
    variants: Sequence[SpotVariant],
    datas: Sequence[LightData],
    f_by_light: Sequence[np.ndarray],
    tolerance: float,
) -> tuple[SpotVariant, list[np.ndarray], float]:
    """The spot falloff variant to pair a family with: the cheapest within `tolerance`, else
    the most accurate (`attenfit._judge.rank`); with its judged errors per light and their
    maximum."""
    judged = []
    for v in variants:
        errs = [judged_errors(x, f, g) for x, f, g in zip(datas, f_by_light, v.g, strict=True)]
        e = max(float(er.max()) for er in errs)
        judged.append(Contender(v.name, e, v.cost, item=(v, errs, e)))
    ranking = rank(judged, tolerance)
    pick = ranking.best or ranking.closest or judged[0]
    return pick.item  # type: ignore[return-value]


def _verdict(
    scene: Scene,
    e: float,
    errs: Sequence[np.ndarray],
    datas: Sequence[LightData],
    models: Sequence[Family],
    msgs: Sequence[str],
    converged: bool,
    bad: str | None,
) -> tuple[str, str]:
    """`(status, reason)` of a fitted family: "pass" within tolerance with every constraint
    kept, else "fail" with the first reason (a precision failure, the error and where it
    is, a range it does not reach 0 at)."""
    if bad is not None or not math.isfinite(e):
        return "fail", bad or "non-finite values at the scene's receivers"
    if e > scene.tolerance:
        reason = f"error {pct(e)} > tolerance {pct(scene.tolerance)}"
        worst = int(np.argmax([er.max() for er in errs]))
        x = datas[worst]
        at = float(x.d[int(np.argmax(errs[worst]))])
        reason += f" (worst at d = {at:.3g} m, d/r = {at / x.radius:.3g}, light {worst})"
        if not converged:
            reason += f"; the fit did not converge ({_short(msgs)})"
        return "fail", reason
    if scene.reach_zero_at_range:
        for x, m in zip(datas, models, strict=True):
            problem = check_reaches_zero(m, float(x.range))  # type: ignore[arg-type]
            if problem:
                return "fail", problem
    if not converged:
        return "pass", f"within tolerance, though the fit did not converge ({_short(msgs)})"
    return "pass", "within tolerance"


def _angles(v: SpotVariant) -> tuple[dict[str, float] | None, ...]:
    """A spot variant's umbra and penumbra per light, in degrees (None: not a spot)."""
    return tuple(
        None
        if m is None
        else {"umbra": math.degrees(float(m.umbra)), "penumbra": math.degrees(float(m.penumbra))}
        for m in v.models
    )


def _family_requests(
    scene: Scene,
    name: str,
    datas: Sequence[LightData],
    d_hi: float,
    knots: tuple[float, ...],
    candidates: list[Candidate],
) -> list[tuple[str, list[int], Any]]:
    """What fitting family `name` to every light takes: `(name, lights, request)` per set of
    free parameters (`_light_fits.fit_families`), or none, with a `Candidate` that says
    why it was excluded or failed in `candidates`."""
    cls = get_family(name)
    if scene.reach_zero_at_range and cls.window == "none":
        candidates.append(Candidate(name, "excluded", "no window: it cannot reach 0 at the range"))
        return []
    try:
        plans = [fit_plan(cls, x, d_hi, knots) for x in datas]
    except AttenfitError as exc:
        candidates.append(Candidate(name, "fail", f"could not be fitted: {exc}"))
        return []
    pins = (scene.fixed or {}).get(name, {})
    if pins:  # what the engine fixes is not fitted
        plans = [({**v, **pins}, tuple(p for p in f if p not in pins)) for v, f in plans]
    out = []
    for free in dict.fromkeys(p[1] for p in plans):
        group = [k for k, p in enumerate(plans) if p[1] == free]
        out.append((name, group, (cls, [datas[k] for k in group], [plans[k] for k in group])))
    return out


def _precision_problem(model: Family, d: np.ndarray, f: np.ndarray, precision: str) -> str | None:
    """Why the shader form fails in `precision` at the distances `d` (None if it does not):
    it overflows, or flushes to 0 where its float64 value is not 0."""
    if precision == "float64":
        return None
    ref = shade(model, d, "float64")
    for what, where in (
        ("overflows (inf)", ~np.isfinite(f) & np.isfinite(ref)),
        ("flushes to 0", (f == 0) & (ref > 0)),
    ):
        if where.any():
            lo, hi = float(d[where].min()), float(d[where].max())
            return f"fails in {precision}: {what} for d in [{lo:.3g}, {hi:.3g}] m"
    return None


def _short(messages: Sequence[str]) -> str:
    """The first sentence of the first message that is not plain "converged"."""
    for m in messages:
        if m.strip() != "converged":
            first = m.replace("optimistix: ", "").split(". ")[0].strip().rstrip(".")
            return first
    return "converged"


def _plain_params(model: Family) -> dict[str, Any]:
    out = {}
    for k, v in model.params().items():
        a = np.asarray(v, dtype=np.float64)
        out[k] = float(a) if a.ndim == 0 else a.tolist()
    return out


def _truth_summary(scene: Scene, t: LightTruth, x: LightData) -> dict[str, Any]:
    light = scene.lights[t.light]
    d = np.asarray(t.dataset.distance(), dtype=np.float64)
    return {
        "light": t.light,
        "kind": light.kind,
        "radius": light.radius,
        "range": light.range,
        "receivers": len(t.dataset),
        "judged": int(t.judged.sum()),
        "d_min": float(d.min()),
        "d_max": float(d.max()),
        "judged_d_min": float(x.d.min()),
        "judged_d_max": float(x.d.max()),
        "beyond_range": t.beyond_range,
        "unlit": t.unlit,
        "peak_irradiance": x.peak,
    }


#: A range that ran away in a fit is written at this many times the farthest receiver: a
#: window's departure from 1 there (at most d/R, a linear window's) is below float32's
#: rounding, so the curve is the fitted one, and the value is a finite float32.
_FAR_CAP = 1e8


def _shaders(winner: Candidate, n_lights: int, source: str, d_far: float) -> dict[str, str]:
    """The winner's exported shader form per language (baked for one light, uniforms for
    several), its header quoting the error over the scene. `d_far`: the farthest receiver
    (m); a range that ran away past `_FAR_CAP` times it is written at that cap."""
    out = {}
    model = winner.models[0]
    spot = next((m for m in winner.spot_models if m is not None), None)
    params, where = _plain_params(model), f"the scene {source}"
    rp = _range_param(type(model))
    if rp is not None and not params[rp] <= _FAR_CAP * d_far:  # also catches inf and nan
        params[rp] = _FAR_CAP * d_far
        where += (
            f"; the fitted range ran away and is written at {_FAR_CAP:g} x the farthest "
            f"receiver ({params[rp]:.3g} m), where the window is 1 to float32 rounding"
        )
    for lang in LANGUAGES:
        parts = []
        fit = {  # the header quotes the fitted error (through the export's sanitiser)
            "family": model.name,
            "params": params,
            "metrics": {"max_error_over_the_scene": winner.error},
            "converged": winner.converged,
            "configuration": where,
        }
        if n_lights > 1:
            parts.append(
                "// several lights: parameters are uniforms (C: arguments); per-light values are in recommendation.md\n"
            )
            parts.append(export(fit, lang, uniforms=True))
        else:
            parts.append(export(fit, lang))
        if spot is not None:
            parts.append(
                "\n// spot falloff: the argument d is cos(angle between the spot direction and the light-to-receiver direction)\n"
            )
            parts.append(export(spot, lang, name="attenfit_spot_falloff", uniforms=n_lights > 1))
        out[lang] = "".join(parts)
    return out
