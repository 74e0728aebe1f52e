"""When no distance curve meets a scene's tolerance: escalate to an area-light model.

The point-light model `E = I g f(d) max(0, n.l)` has an angular error no `f(d)` removes
(docs/area.md). When every family fails a scene, `escalate` judges the area-light models of
`attenfit.area` written for the scene's lights on the same receivers with the same judged
error (`|E_model - E_true| / max(E_true, error_floor * E_peak)`), fits the ones with free
parameters to the scene (one parameter set for all its lights: a wrap amount is
dimensionless), and recommends the cheapest one within tolerance by the compiled cost of
its shader form (`attenfit._shaders.function_source`), saying why: the error of the light's
exact facing curve `f*(d)` (the best any `f(d)` can do per distance) and where it is.
Spot lights are not escalated (an area model has no spot profile).

`escalate_lights` escalates each light of a scene that no family meets on its own (the
all-lights answer and the per-light answers of a scene file share it): each light is judged
alone against the area models of its shape, so a scene of a bulb, a spot, a disk and a
rectangle gets an area model for exactly the lights that need one (`AreaAnswer`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import jax
import numpy as np

from .. import _cache
from .._curves import AreaModel, get_area_model, list_area_models
from .._errors import AttenfitError
from .._fit import fit, reuse_results
from .._judge import Contender, rank
from .._shaders import LANGUAGES, area_compiled_cost, function_source
from .._truth import (
    CapsuleEmitter,
    DiskEmitter,
    RectEmitter,
    TubeEmitter,
    area_inputs,
    facing_sweep,
    model_inputs,
)
from ._advice import pct
from ._light_fits import LightData
from ._lighting import bucketed
from ._scene import Scene
from ._types import LightTruth

__all__ = ["AreaAnswer", "AreaCandidate", "AreaEscalation", "escalate", "escalate_lights"]


@dataclasses.dataclass(frozen=True)
class AreaCandidate:
    """One area model judged on a scene: its error (max over lights), compiled cost, status."""

    model: str
    fitted: bool
    params: dict[str, float]
    error: float
    error_by_light: tuple[float, ...]
    cost: float
    status: str  # "pass" | "fail"

    @property
    def label(self) -> str:
        return self.model + (" (fitted)" if self.fitted else "")

    def contender(self) -> Contender[AreaCandidate]:
        """This candidate for `attenfit._judge.rank` (allowed when its status is "pass")."""
        return Contender(
            self.label, self.error, self.cost, len(self.params), self.status == "pass", item=self
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "model": self.model,
            "fitted": self.fitted,
            "params": dict(self.params),
            "error": self.error,
            "error_by_light": list(self.error_by_light),
            "shader_cost": self.cost,
            "status": self.status,
        }


@dataclasses.dataclass(frozen=True)
class AreaEscalation:
    """What the area models do on a scene no family meets: `why` (no f(d) can, and where),
    `candidates` (passing by cost, then failing by error), `winner` (the cheapest within
    tolerance, or None), `closest` (the most accurate), `shaders` (the winner's function per
    language, one for every light: the radius is its argument `r`)."""

    why: str
    candidates: tuple[AreaCandidate, ...]
    winner: AreaCandidate | None
    closest: AreaCandidate | None
    cost_label: str
    shaders: dict[str, str]
    tolerance: float
    #: the scene's lights it was judged on (their indices)
    lights: tuple[int, ...] = ()

    def summary(self, families: str = "no family meets the tolerance") -> str:
        """One line: the area model recommended and why, or that none meets the tolerance
        (after `families`, what the recommendation says of the families)."""
        if self.winner is not None:
            w = self.winner
            return (
                f"recommended: the area model {w.label} (max error {pct(w.error)} <= tolerance "
                f"{pct(self.tolerance)}, shader cost {w.cost:g}): {self.why}"
            )
        c = self.closest
        near = f"; closest: the area model {c.label} with max error {pct(c.error)}" if c else ""
        return f"{families}; no area model meets it either{near}; {self.why}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "lights": list(self.lights),
            "why": self.why,
            "summary": self.summary(),
            "cost": self.cost_label,
            "winner": None if self.winner is None else self.winner.to_dict(),
            "closest": None if self.closest is None else self.closest.to_dict(),
            "candidates": [c.to_dict() for c in self.candidates],
        }

    def markdown(self, heading: str = "## Beyond a distance curve: area-light models") -> list[str]:
        """The recommendation's section on the area models (lines), under `heading`."""
        out = [
            heading,
            "",
            self.why[0].upper() + self.why[1:] + ".",
            "",
            f"Area models judged on the same receivers; cost: {self.cost_label}.",
            "",
            "| area model | status | max error | shader cost | parameters |",
            "|---|---|---|---|---|",
        ]
        for c in self.candidates:
            params = ", ".join(f"{k} = {v:.5g}" for k, v in c.params.items()) if c.fitted else ""
            out.append(f"| {c.label} | {c.status} | {pct(c.error)} | {c.cost:g} | {params} |")
        return [*out, ""]


def _facing_curve(light: Any) -> Any:
    """The light's exact facing attenuation f*(d) (numpy): the best f(d) at each distance."""
    r = float(light.radius)
    if isinstance(light, DiskEmitter):
        return lambda d: 1 / (d * d + r * r)
    if isinstance(light, CapsuleEmitter | TubeEmitter | RectEmitter):  # on a sweep facing it
        # clear of the surface (`facing_sweep` refuses receivers float32 cannot place)
        # (2^-16 of the sweep's 1e4 r scale: 0.15% of r past the surface; 1.0001 r was refused)
        d_min = (0.01 if isinstance(light, RectEmitter) else 1.01) * r

        def sweep() -> np.ndarray:
            ds = facing_sweep(light, d_min, 1e4 * r, 512, dtype=np.float64)
            return np.stack([ds.distance(), ds.attenuation()])

        parts = ("facing-curve", light, d_min)
        dist, att = _cache.cached_array("values", parts, sweep, shape=(2, 512))
        ld, lf = np.log(dist), np.log(att)
        return lambda d: np.exp(np.interp(np.log(np.maximum(d, dist[0])), ld, lf))
    return lambda d: 1 / np.maximum(d, r) ** 2


#: The area models a scene's lights can be escalated to, by the set of their kinds: a
#: rectangle's (and the disk's, reading it as its equal-area disk), a tube's (and the
#: sphere's, at the closest point of its axis times its projected-area factor).
_WANT: tuple[tuple[frozenset[str], frozenset[str]], ...] = (
    (frozenset({"disk"}), frozenset({"disk"})),
    (frozenset({"rect"}), frozenset({"rect", "disk"})),
    (frozenset({"tube"}), frozenset({"tube", "sphere"})),
)


def _models_for(kinds: set[str]) -> list[AreaModel]:
    want: set[str] = set()
    for have, models in _WANT:
        if kinds == have:
            want = set(models)
    if not want and kinds <= {"sphere", "capsule"}:
        want = {"sphere"}
    return [
        get_area_model(n)()
        for n in list_area_models()
        if n != "point_light" and get_area_model(n).light in want
    ]


def escalate(
    scene: Scene,
    truths: Sequence[LightTruth],
    datas: Sequence[LightData],
    best_family: tuple[str, float] | None = None,
) -> AreaEscalation | None:
    """Judge the area models on the lights of `truths` in `scene` (whose families all fail
    there; `best_family`: the most accurate one's label and error there); None when none
    applies (spot lights, or lights of kinds no area model is written for together)."""
    lights = [scene.lights[t.light] for t in truths]
    if any(light.is_spot for light in lights):
        return None
    models = _models_for({light.kind for light in lights})
    if not models:
        return None
    with jax.enable_x64(True):
        receivers = []
        worst = (-1.0, "")
        for t, x in zip(truths, datas, strict=True):
            em = t.dataset.emitter
            j = t.judged
            pts = np.asarray(t.dataset.points, dtype=np.float64)[j]
            nrm = np.asarray(t.dataset.normals, dtype=np.float64)[j]
            receivers.append((em, pts, nrm))
            stacked = np.stack([np.asarray(v, dtype=np.float64) for v in area_inputs(em, pts, nrm)])
            best = x.wpt * _facing_curve(em)(x.d)
            err = np.abs(best - x.E_true) / x.denom
            i = int(np.argmax(err))
            if err[i] > worst[0]:
                p = ", ".join(f"{v:.3g}" for v in pts[i])
                worst = (
                    float(err[i]),
                    f"receiver ({p}) of light {t.light} (d = {x.d[i]:.3g} m, n.l = {stacked[1, i]:.2f})",
                )
        why = (
            f"no f(d) can: the error is angular, the best f(d) (the light's exact facing "
            f"curve) is {pct(worst[0])} off at {worst[1]}"
        )
        if best_family is not None:
            why += (
                f"; the most accurate fitted family, {best_family[0]}, is {pct(best_family[1])} off"
            )
        unlit = sum(t.unlit for t in truths)
        if unlit:
            why += f"; {unlit} receivers facing away from the light's centre are lit and get 0 from any f(d)"
        candidates = []
        for m in models:
            inputs = [
                (np.stack([np.asarray(v, np.float64) for v in model_inputs(m, em, pts, nrm)]),
                 float(em.intensity))
                for em, pts, nrm in receivers
            ]  # fmt: skip
            for variant, fitted in _variants(m, inputs, datas):
                errs = []
                for (stacked, intensity), x in zip(inputs, datas, strict=True):
                    pred = intensity * _evaluated(variant, stacked)
                    errs.append(float(np.max(np.abs(pred - x.E_true) / x.denom)))
                e = max(errs)
                ok = math.isfinite(e) and e <= scene.tolerance
                candidates.append(
                    AreaCandidate(
                        variant.name,
                        fitted,
                        {k: float(np.asarray(v)) for k, v in variant.params().items()},
                        e,
                        tuple(errs),
                        area_compiled_cost(variant).cost,
                        "pass" if ok else "fail",
                    )
                )
    label = area_compiled_cost(models[0]).label()
    ranking = rank((c.contender() for c in candidates), scene.tolerance)
    passing = [c.item for c in ranking.within]
    failing = [c.item for c in ranking.outside]
    winner = passing[0] if passing else None
    closest = ranking.closest.item if ranking.closest is not None else None
    shaders = _shaders(winner, truths) if winner else {}
    lights, tol = tuple(t.light for t in truths), float(scene.tolerance)
    return AreaEscalation(why, (*passing, *failing), winner, closest, label, shaders, tol, lights)


def _evaluated(model: AreaModel, stacked: np.ndarray) -> np.ndarray:
    """`model` at the stacked inputs, in float64; for attenfit's own models, from attenfit's
    cache when this code evaluated the same model at the same inputs before."""

    def compute() -> np.ndarray:
        return bucketed(model.evaluate, stacked).astype(np.float64)

    if not _cache.covers(type(model)):
        return compute()
    parts = ("area-model", model, stacked)
    return _cache.cached_array("values", parts, compute, shape=stacked.shape[1:])


def _variants(
    model: AreaModel, inputs: Sequence[tuple[np.ndarray, float]], datas: Sequence[LightData]
) -> list[tuple[AreaModel, bool]]:
    """The model as shipped, and fitted to the scene's judged errors where it has free
    parameters (absolute loss weighted by I / denominator: the residual is the judged error)."""
    out: list[tuple[AreaModel, bool]] = [(model, False)]
    if not model.free_by_default():
        return out
    x = np.concatenate([s for s, _ in inputs], axis=1)
    target = np.concatenate([x_.E_true / i for (_, i), x_ in zip(inputs, datas, strict=True)])
    w = np.concatenate([i / x_.denom for (_, i), x_ in zip(inputs, datas, strict=True)])
    try:
        with reuse_results():  # an unchanged scene asked again: no solve
            res = fit(model, x, target, loss="absolute", weights=w)
    except AttenfitError:
        return out
    if all(np.all(np.isfinite(np.asarray(v))) for v in res.model.params().values()):
        out.append((res.model, True))
    return out


def _sizes(model: AreaModel, emitter: Any) -> str:
    """The light's size as the function's arguments read it (`r`; a rectangle's `hw, hh`,
    a tube's `hl, r`)."""
    x = model_inputs(model, emitter, np.zeros((1, 3)), np.array([[0.0, 0.0, 1.0]]))
    names = type(model).input_names
    return ", ".join(
        f"{k} = {float(np.asarray(x[names.index(k)]).reshape(-1)[0]):.6g}"
        for k in type(model).form_sizes.values()
    )


def _shaders(winner: AreaCandidate, truths: Sequence[LightTruth]) -> dict[str, str]:
    """The winner's function per language (`attenfit_<model>`, one for every light: the
    light's size is its argument: `r`, or a rectangle's `hw, hh`), with the export's header
    and the scene's lines."""
    model = get_area_model(winner.model)(**(winner.params if winner.fitted else {}))
    with jax.enable_x64(True):
        sizes = [f"{_sizes(model, t.dataset.emitter)} (light {t.light})" for t in truths]
    radius = type(model).form_sizes == {"radius": "r"}
    lights = (", " if radius else "; ").join(sizes)
    fitted = " (fitted to it)" if winner.fitted else ""
    notes = [
        f"scene   : the area model recommended for this scene{fitted}: max error "
        f"{pct(winner.error)} over its judged receivers",
        f"lights  : {lights}; "
        + (
            "pass each light's radius as r"
            if radius
            else "pass each light's size as these arguments"
        ),
    ]
    fname = f"attenfit_{model.name}"
    return {lang: function_source(model, lang, fname, notes=notes)[0] for lang in LANGUAGES}


# ----------------------------------------------------------------------------- per light
@dataclasses.dataclass(frozen=True)
class AreaAnswer:
    """The area part of a scene's answer when no family meets the tolerance at every light.

    `escalations`: one per light that no family meets on its own, judged alone against the
    area models of its shape (`escalate`), in the lights' order; `skipped`: the lights that
    need one but cannot have one, with why (a spot: no area model has a spot profile).
    `others`: the family the remaining lights keep (the cheapest within tolerance at all of
    them, ranked as every verdict; a `Candidate`), its error there `others_error` and its
    shader functions `others_shaders`; None when every light needs an area form, or when no
    one family meets the rest (their per-light answers then differ)."""

    kinds: tuple[str, ...]
    escalations: tuple[AreaEscalation, ...]
    skipped: tuple[tuple[int, str], ...]
    tolerance: float
    others: Any = None
    others_error: float | None = None
    others_shaders: dict[str, str] = dataclasses.field(default_factory=dict)

    def for_light(self, light: int) -> AreaEscalation | None:
        """The escalation of scene light `light` (None: it needs none, or cannot have one)."""
        return next((e for e in self.escalations if light in e.lights), None)

    @property
    def need(self) -> tuple[int, ...]:
        """The lights no family meets on its own."""
        return tuple(
            sorted([*(e.lights[0] for e in self.escalations), *(i for i, _ in self.skipped)])
        )

    @property
    def shaders(self) -> dict[str, str]:
        """Every recommended area model's function per language, one light after another."""
        winners = [e for e in self.escalations if e.winner is not None]
        return (
            {lang: "\n".join(e.shaders[lang] for e in winners) for lang in LANGUAGES}
            if winners
            else {}
        )

    def _light(self, i: int) -> str:
        return f"light {i} ({self.kinds[i]})"

    def summary(self, families: str) -> str:
        """One line: what `families` says, then which lights need an area form and the model
        each gets, with its worst-case error and compiled cost, and what the others keep.
        A scene whose one light needs it reads as the escalation's own summary."""
        if len(self.kinds) == 1 and len(self.escalations) == 1:
            return self.escalations[0].summary(families)
        parts = [families]
        for e in self.escalations:
            w, c, who = e.winner, e.closest, self._light(e.lights[0])
            if w is not None:
                parts.append(
                    f"{who} needs an area form: the area model {w.label} (max error "
                    f"{pct(w.error)} <= tolerance {pct(self.tolerance)}, shader cost {w.cost:g})"
                )
            else:
                near = (
                    f", closest: the area model {c.label} with max error {pct(c.error)}"
                    if c
                    else ""
                )
                parts.append(f"{who}: no area model meets it either{near}")
        parts += [f"{self._light(i)}: not escalated ({why})" for i, why in self.skipped]
        rest = len(self.kinds) - len(self.need)
        others = "the other light" if rest == 1 else f"the other {rest} lights"
        if self.others is not None:
            o = self.others
            parts.append(
                f"{others} keep{'s' if rest == 1 else ''} {o.label} (max error "
                f"{pct(self.others_error)} <= tolerance {pct(self.tolerance)}, shader cost "
                f"{o.shader_cost:g})"
            )
        elif rest:
            parts.append(f"no one family meets {others} together (see each light's answer)")
        return "; ".join(parts)

    def to_dict(self) -> dict[str, Any]:
        o = self.others
        return {
            "need": list(self.need),
            "lights": {str(e.lights[0]): e.to_dict() for e in self.escalations},
            "skipped": [{"light": i, "why": why} for i, why in self.skipped],
            "others": None if o is None else {"family": o.label, "error": self.others_error,
                                              "shader_cost": o.shader_cost},
        }  # fmt: skip

    def markdown(self) -> list[str]:
        """The recommendation's section on the area models (lines): one light's escalation
        as it always read; several, one subsection per light."""
        if len(self.kinds) == 1 and len(self.escalations) == 1:
            return self.escalations[0].markdown()
        out = [
            "## Beyond a distance curve: area-light models",
            "",
            f"No family meets the tolerance at {len(self.need)} of the {len(self.kinds)} lights "
            "on its own: each of those is judged alone against the area models of its shape.",
            "",
        ]
        out += [f"- {self._light(i)}: not escalated ({why})." for i, why in self.skipped]
        out += [""] if self.skipped else []
        for e in self.escalations:
            out += e.markdown(f"### {self._light(e.lights[0])}")
        return out


#: Why a light no family meets gets no area model.
_SPOT = "a spot: no area model has a spot profile"


def escalate_lights(
    scene: Scene,
    truths: Sequence[LightTruth],
    datas: Sequence[LightData],
    need: Sequence[int],
    closest: dict[int, tuple[str, float]],
) -> AreaAnswer:
    """Each light of `need` (those no family meets on its own) escalated alone (`escalate`),
    with `closest[i]` the most accurate family's label and error at light `i`."""
    escalations, skipped = [], []
    for i in need:
        light = scene.lights[i]
        if light.is_spot:
            skipped.append((i, _SPOT))
            continue
        e = escalate(scene, [truths[i]], [datas[i]], closest.get(i))
        if e is None:
            skipped.append((i, f"no area model is written for a {light.kind} light"))
        else:
            escalations.append(e)
    return AreaAnswer(
        tuple(light.kind for light in scene.lights),
        tuple(escalations),
        tuple(skipped),
        float(scene.tolerance),
    )
