"""Recommend the cheapest attenuation family that a scene's receivers cannot tell from the truth.

`recommend(scene)`:

1. **Truth, only where the scene looks.** `Scene.ground_truth()`: the exact irradiance of
   each of the scene's lights at exactly the scene's receivers (no other radius, distance
   or angle is generated).
2. **Fit every family the scene's constraints allow**, per light, in one `fit_many` solve
   per family (lights grouped by whether they have a range). The residual of a receiver is
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
5. **Rank** the candidates within tolerance by shader cost (`attenfit.cost.shader_cost`:
   the per-evaluation operation count of the traced expression, weighted by GPU issue
   rates), then by error, then by measured time (`attenfit.cost.measure_throughput`, when
   `measure=True`; reported for every candidate). The operation count is the primary key
   because it is deterministic and describes the GPU shader the user will ship, while the
   measured time is of XLA on this machine's CPU (or GPU) and moves by 10-30% between runs on
   a shared machine; families with the same operation count (`disk_facing`,
   `unreal_epsilon`, `yuksel_adhoc` are one expression, 1/(d^2 + c)) are then told apart by
   accuracy, not by timing noise.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, ClassVar

import equinox as eqx
import jax.numpy as jnp
import matplotlib
import numpy as np
from jaxtyping import Array, ArrayLike, Float

from . import cost as _cost
from . import directional
from . import export as _export
from ._atomic import atomic_dir
from ._errors import AttenfitError, BadTypeError
from ._family import Family, get_family, list_families
from ._fit import fit, fit_many
from ._trace import _float32_family
from .scene import LightTruth, Scene

__all__ = [
    "Candidate",
    "Recommendation",
    "SpotFalloff",
    "SpotFrostbite",
    "SpotThreeJS",
    "plot_scene_errors",
    "recommend",
]


# ----------------------------------------------------------------------------- spot falloffs
class SpotFalloff(Family):
    """A spot's directional falloff as a (non-registered) family of `d = cos(theta_s)`.

    Abstract: `SpotFrostbite` and `SpotThreeJS` wrap `attenfit.directional` so that
    `attenfit.cost` can count their operations and `attenfit.export` can print them.
    `umbra` and `penumbra` are half-angles in radians; `d` is the cosine of the angle
    between the spot's direction and the direction from the light to the receiver.
    """

    umbra: eqx.AbstractVar[Float[ArrayLike, "*batch"]]
    penumbra: eqx.AbstractVar[Float[ArrayLike, "*batch"]]


class SpotFrostbite(SpotFalloff):
    """Frostbite's spot falloff t^2 (`attenfit.directional.spot_frostbite`, RTR4 eq. 5.19)."""

    umbra: Float[ArrayLike, "*batch"] = 0.5
    penumbra: Float[ArrayLike, "*batch"] = 0.4

    name = "spot_frostbite"
    formula = "t^2, t = clamp((d - cos umbra)/(cos penumbra - cos umbra), 0, 1), d = cos(theta_s)"
    source = "RTR4 eq. 5.19; Lagarde and de Rousiers 2014, getAngleAtt"
    default_free = ("umbra", "penumbra")
    constraints: ClassVar = {"penumbra": "nonnegative"}

    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        return directional.spot_frostbite(d, self.umbra, self.penumbra)


class SpotThreeJS(SpotFalloff):
    """three.js's spot falloff smoothstep(t) (`attenfit.directional.spot_threejs`, RTR4 eq. 5.20)."""

    umbra: Float[ArrayLike, "*batch"] = 0.5
    penumbra: Float[ArrayLike, "*batch"] = 0.4

    name = "spot_threejs"
    formula = "t^2 (3 - 2t), t = clamp((d - cos umbra)/(cos penumbra - cos umbra), 0, 1), d = cos(theta_s)"
    source = "RTR4 eq. 5.20; three.js LightUtils.js getSpotAttenuation"
    default_free = ("umbra", "penumbra")
    constraints: ClassVar = {"penumbra": "nonnegative"}

    def __call__(self, d: Float[ArrayLike, "*shape"]) -> Float[Array, "*shape"]:
        return directional.spot_threejs(d, self.umbra, self.penumbra)


_SPOT_CLASSES: dict[str, type[SpotFalloff]] = {"frostbite": SpotFrostbite, "threejs": SpotThreeJS}


# ----------------------------------------------------------------------------- records
@dataclasses.dataclass(frozen=True)
class Candidate:
    """One family judged on a scene.

    `status` is "pass" (within tolerance), "fail" (error over tolerance, a non-finite value,
    or a constraint broken after the fit) or "excluded" (a constraint rules the family out
    before fitting); `reason` says why in one line. `error` is the largest judged error over
    every light, `error_by_light` per light. `params` are the fitted parameters per light;
    for spots `directional` names the chosen falloff variant and `directional_params` its
    angles (degrees) per light (None for lights that are not spots). `shader_cost` (and
    `ns_per_eval`, when measured) include the falloff's.
    """

    family: str
    status: str
    reason: str
    error: float | None = None
    error_by_light: tuple[float, ...] = ()
    shader_cost: float | None = None
    ns_per_eval: float | None = None
    params: tuple[dict[str, Any], ...] = ()
    converged: bool | None = None
    message: str = ""
    directional: str | None = None
    directional_params: tuple[dict[str, float] | None, ...] = ()
    models: tuple[Family, ...] = dataclasses.field(default=(), repr=False, compare=False)
    spot_models: tuple[SpotFalloff | None, ...] = dataclasses.field(
        default=(), repr=False, compare=False
    )

    @property
    def label(self) -> str:
        """The family, with its spot falloff if any."""
        return self.family if self.directional is None else f"{self.family} + {self.directional}"

    def to_dict(self) -> dict[str, Any]:
        return {
            "family": self.family,
            "status": self.status,
            "reason": self.reason,
            "error": _plain(self.error),
            "error_by_light": [_plain(e) for e in self.error_by_light],
            "shader_cost": self.shader_cost,
            "ns_per_eval": self.ns_per_eval,
            "params": list(self.params),
            "converged": self.converged,
            "message": self.message,
            "directional": self.directional,
            "directional_params": list(self.directional_params),
        }


def _plain(x: float | None) -> float | str | None:
    if x is None:
        return None
    return float(x) if math.isfinite(x) else str(float(x))


@dataclasses.dataclass(frozen=True)
class Recommendation:
    """What `recommend` found for a scene.

    `winner` is the cheapest candidate within tolerance (None when none is), `runner_up` the
    next cheapest within tolerance (or, when only the winner passes, the most accurate of
    the rest, with `runner_up.status` "fail"), `closest` the most accurate candidate (the one
    to look at when nothing passes). `candidates` lists every family: passing ones by cost,
    then failing ones by error, then excluded ones. `shaders` maps "glsl", "hlsl", "wgsl",
    "c" to the winner's exported function(s). `truth` summarises the generated
    configurations per light; `directional_fits` the spot falloff fits.
    """

    scene: Scene
    candidates: tuple[Candidate, ...]
    winner: Candidate | None
    runner_up: Candidate | None
    closest: Candidate | None
    shaders: Mapping[str, str]
    truth: tuple[dict[str, Any], ...]
    directional_fits: tuple[dict[str, Any], ...]
    measured: bool
    curves: Mapping[str, tuple[np.ndarray, np.ndarray]] = dataclasses.field(
        default_factory=dict, repr=False, compare=False
    )

    @property
    def tolerance(self) -> float:
        return self.scene.tolerance

    def summary(self) -> str:
        """One line: the winner with its error and cost, or that nothing is within tolerance."""
        tol = _pct(self.tolerance)
        if self.winner is not None:
            w = self.winner
            return (
                f"recommended: {w.label} (max error {_pct(w.error)} <= tolerance {tol}, "
                f"shader cost {w.shader_cost:g})"
            )
        c = self.closest
        closest = f"; closest: {c.label} with max error {_pct(c.error)}" if c else ""
        return f"no family meets the tolerance {tol}{closest}"

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready dict (the scene, the generated configurations, every candidate)."""
        return {
            "format": "attenfit.recommendation",
            "version": 1,
            "scene": self.scene.to_dict(),
            "source": self.scene.source,
            "tolerance": self.tolerance,
            "error_floor": self.scene.error_floor,
            "summary": self.summary(),
            "ranking": "shader_cost, then error, then measured ns_per_eval",
            "measured": self.measured,
            "winner": None if self.winner is None else self.winner.to_dict(),
            "runner_up": None if self.runner_up is None else self.runner_up.to_dict(),
            "closest": None if self.closest is None else self.closest.to_dict(),
            "candidates": [c.to_dict() for c in self.candidates],
            "truth": list(self.truth),
            "directional_fits": list(self.directional_fits),
            "shaders": dict(self.shaders),
        }

    def to_markdown(self) -> str:
        """A human-readable report: verdict, the winner's shader code, a table of every family."""
        s = self.scene
        title = s.name or s.source
        lines = [f"# Recommendation for {title}", ""]
        if s.description:
            lines += [s.description.strip(), ""]
        lines += [f"**{self.summary()}**", ""]
        floor = f", error floor {_pct(s.error_floor)} of each light's peak" if s.error_floor else ""
        cons = [
            c
            for c, on in (
                ("reach 0 at the range", s.reach_zero_at_range),
                ("float32 shading", s.float32),
            )
            if on
        ]
        lines += [
            f"Tolerance {_pct(s.tolerance)} (max relative error of the irradiance){floor}; "
            f"constraints: {', '.join(cons) or 'none'}. Ranked by shader cost (operation count), "
            f"then error{', then measured time' if self.measured else ''}.",
            "",
            "## What was generated (only the scene's configurations)",
            "",
            "| light | kind | radius | range | receivers | judged | d min | d max | beyond range | unlit |",
            "|---|---|---|---|---|---|---|---|---|---|",
        ]
        for t in self.truth:
            lines.append(
                f"| {t['light']} | {t['kind']} | {t['radius']:g} | {t['range'] if t['range'] is not None else '-'} "
                f"| {t['receivers']} | {t['judged']} | {t['d_min']:.4g} | {t['d_max']:.4g} "
                f"| {t['beyond_range']} | {t['unlit']} |"
            )
        lines.append("")
        for label, c in (("Winner", self.winner), ("Runner-up", self.runner_up)):
            if c is None:
                continue
            note = "" if c.status == "pass" else " (not within tolerance)"
            lines += [f"## {label}: {c.label}{note}", ""]
            lines += [
                f"max error {_pct(c.error)}, shader cost {c.shader_cost:g}"
                + (f", {c.ns_per_eval:.3g} ns/eval measured" if c.ns_per_eval is not None else ""),
                "",
            ]
            lines += _param_lines(c)
            lines.append("")
        if self.winner is None and self.closest is not None:
            c = self.closest
            lines += [f"## Closest: {c.label}", "", f"max error {_pct(c.error)}: {c.reason}", ""]
            lines += _param_lines(c)
            lines.append("")
        if self.shaders:
            lines += [
                "## The winner as GLSL",
                "",
                "```glsl",
                self.shaders["glsl"].rstrip(),
                "```",
                "",
            ]
        if self.directional_fits:
            lines += [
                "## Spot falloff fits",
                "",
                "| light | variant | umbra (deg) | penumbra (deg) | falloff error | shader cost |",
                "|---|---|---|---|---|---|",
            ]
            for f in self.directional_fits:
                lines.append(
                    f"| {f['light']} | {f['variant']} | {f['umbra']:.3f} | {f['penumbra']:.3f} "
                    f"| {_pct(f['error'])} | {f['shader_cost']:g} |"
                )
            lines.append("")
        lines += [
            "## Every family",
            "",
            "| family | status | max error | shader cost | ns/eval | why |",
            "|---|---|---|---|---|---|",
        ]
        for c in self.candidates:
            ns = f"{c.ns_per_eval:.3g}" if c.ns_per_eval is not None else "-"
            cost = f"{c.shader_cost:g}" if c.shader_cost is not None else "-"
            lines.append(
                f"| {c.label} | {c.status} | {_pct(c.error)} | {cost} | {ns} | {c.reason} |"
            )
        lines.append("")
        return "\n".join(lines)

    def plot_errors(self, ax=None, *, others: int = 3):
        """Judged error against distance for the winner, runner-up and `others` more; `(fig, ax)`."""
        return plot_scene_errors(self, ax=ax, others=others)

    def save(self, out: str | os.PathLike, *, force: bool = False) -> Path:
        """Write recommendation.md/.json, the winner's shaders and errors.png into folder `out`.

        Atomic: the folder appears complete or not at all; an existing non-empty folder is
        replaced only with `force`.
        """
        out = Path(out)
        with atomic_dir(out, force=force) as tmp:
            (tmp / "recommendation.md").write_text(self.to_markdown(), encoding="utf-8")
            (tmp / "recommendation.json").write_text(
                json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8"
            )
            if self.winner is not None:
                stem = _ident(self.winner.family)
                for lang, text in self.shaders.items():
                    (tmp / f"{stem}.{lang}").write_text(text, encoding="utf-8")
            fig, _ = self.plot_errors()
            fig.savefig(tmp / "errors.png", dpi=110)
            import matplotlib.pyplot as plt

            plt.close(fig)
        return out


def _ident(name: str) -> str:
    return f"attenfit_{name}"


def _param_lines(c: Candidate) -> list[str]:
    out = []
    for i, p in enumerate(c.params):
        vals = ", ".join(f"{k} = {_fmt(v)}" for k, v in p.items()) or "no parameters"
        spot = ""
        if c.directional_params and i < len(c.directional_params) and c.directional_params[i]:
            dp = c.directional_params[i]
            spot = f"; spot umbra = {dp['umbra']:.4g} deg, penumbra = {dp['penumbra']:.4g} deg"
        out.append(f"- light {i}: {vals}{spot}")
    return out


def _fmt(v: Any) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"
    return f"{v:.6g}"


def _pct(x: float | None) -> str:
    if x is None:
        return "-"
    if not math.isfinite(x):
        return str(x)
    return f"{100 * x:.3g}%"


# ----------------------------------------------------------------------------- per-light data
@dataclasses.dataclass(frozen=True)
class _LightData:
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


def _light_data(scene: Scene, truth: LightTruth) -> _LightData:
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
    return _LightData(
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
    )


# ----------------------------------------------------------------------------- fitting
_TIES = {
    # family -> (tied parameter, its value from (r, range))
    "madams_tan": ("d_max", lambda r, R: R - r),
    "madams_rational": ("d_max", lambda r, R: R - r),
    "madams_cutoff": ("cutoff", lambda r, R: (r / R) ** 2),
}


def _range_param(cls: type[Family]) -> str | None:
    if cls.name in _TIES:
        return _TIES[cls.name][0]
    return cls.range_param


#: A light with no range gives windowed families a range this many times the farthest
#: receiver (where their window is below 1e-4 of relative effect), unless the family's
#: own default frees its range (`just_cause_2`, whose shape needs it).
FAR_RANGE = 10.0


def _plan(
    cls: type[Family], data: _LightData, d_hi: float, knots: tuple[float, ...]
) -> tuple[dict[str, Any], tuple[str, ...]]:
    """Start values and free parameters of `cls` for one light."""
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
    if cls.name == "spline":
        k = np.asarray(knots)
        vals["knot_values"] = -np.log(k * k + data.radius**2)
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
            vals[rp] = _TIES[cls.name][1](data.radius, R) if cls.name in _TIES else R
    return vals, free


def _tied_fn(cls: type[Family]):
    tied, rule = _TIES[cls.name]

    def fn(d, p):
        return cls(r=p["r"], **{tied: rule(p["r"], p["R"])})(d)

    return fn


_TIED_FNS: dict[str, Any] = {}


def _bucket(n: int, lo: int) -> int:
    """The next power of two >= max(n, lo): padded shapes reuse compiled solves."""
    return max(lo, 1 << max(0, (n - 1).bit_length()))


def _fit_group(
    cls: type[Family],
    datas: Sequence[_LightData],
    plans: Sequence[tuple[dict[str, Any], tuple[str, ...]]],
) -> list[tuple[Family, bool, str]]:
    """Fit `cls` to lights sharing one set of free parameters; (model, converged, message)."""
    free = plans[0][1]
    starts = [p[0] for p in plans]
    if not free:
        return [
            (cls(**{k: s[k] for k in cls.param_names()}), True, "no free parameter") for s in starts
        ]
    knots_kw = {"knots": tuple(starts[0]["knots"])} if cls.name == "spline" else {}
    n = _bucket(max(len(x.d) for x in datas), 64)
    b = _bucket(len(datas), 2)
    # pad every light to n receivers with zero-weight copies, and the batch to b problems with
    # copies of the first light (their results are dropped)
    D, T, W = (np.empty((b, n)) for _ in range(3))
    rows = [*range(len(datas)), *([0] * (b - len(datas)))]
    for k, src in enumerate(rows):
        x = datas[src]
        m = len(x.d)
        ok = x.E_irr > 0
        target = np.where(ok, x.E_irr / x.wpt, 1.0)
        w = np.where(ok, x.E_true / x.denom, 0.0)
        D[k] = np.concatenate([x.d, np.full(n - m, x.d[0])])
        T[k] = np.concatenate([target, np.full(n - m, target[0])])
        W[k] = np.concatenate([w, np.zeros(n - m)])
    starts = [starts[src] for src in rows]
    if cls.name in _TIES:
        fn = _TIED_FNS.setdefault(cls.name, _tied_fn(cls))
        params = {"r": np.array([s["r"] for s in starts]), "R": np.array([s["R"] for s in starts])}
        res = fit_many(
            (fn, params, {"r": "positive", "R": "positive"}), D, T, weights=W, free=("r",)
        )
        tied, rule = _TIES[cls.name]
        out = []
        for k in range(len(datas)):
            r, R = float(res[k].params["r"]), float(starts[k]["R"])
            out.append((cls(r=r, **{tied: rule(r, R)}), res[k].converged, res[k].message))
        return out
    batched = {p: np.array([s[p] for s in starts]) for p in cls.param_names()}
    model = cls(**batched, **knots_kw)
    res = fit_many(model, D, T, weights=W, free=free)
    return [(res[k].model, res[k].converged, res[k].message) for k in range(len(datas))]


def _evaluate(model: Family, x: np.ndarray, float32: bool) -> np.ndarray:
    if float32:
        return np.asarray(_float32_family(model)(jnp.asarray(x, jnp.float32)), dtype=np.float64)
    return np.asarray(model(jnp.asarray(x)), dtype=np.float64)


def _errors(data: _LightData, f: np.ndarray, g: np.ndarray) -> np.ndarray:
    E = data.wpt * f * g
    with np.errstate(invalid="ignore", over="ignore"):
        err = np.abs(E - data.E_true) / data.denom
    return np.where(np.isfinite(err), err, np.inf)


# ----------------------------------------------------------------------------- spot falloffs
@dataclasses.dataclass(frozen=True)
class _Variant:
    name: str  # e.g. "spot_threejs (fitted angles)"
    curve: str
    models: tuple[SpotFalloff | None, ...]  # per light
    g: tuple[np.ndarray, ...]  # per light (ones for non-spots)
    cost: float
    ns: float | None


def _fit_falloff(x: _LightData, curve: str) -> SpotFalloff:
    """Fit umbra and penumbra of a spot falloff to a light's true profile."""
    umbra, penumbra = x.spot  # type: ignore[misc]
    profile = x.E_true / np.where(x.E_irr > 0, x.E_irr, 1)
    w = x.E_irr / x.denom
    frac = min(max(penumbra / umbra, 0.02), 0.98)
    fn = _FALLOFF_FNS[curve]
    res = fit(
        (fn, {"umbra": umbra, "frac": frac}, {"umbra": "positive", "frac": "unit"}),
        x.theta,
        profile,
        loss="absolute",
        weights=w,
    )
    u = float(res.params["umbra"])
    return _SPOT_CLASSES[curve](umbra=u, penumbra=u * float(res.params["frac"]))


def _falloff_fn(curve: str):
    spot = directional.spot_frostbite if curve == "frostbite" else directional.spot_threejs

    def fn(theta, p):
        u = p["umbra"]
        return spot(jnp.cos(theta), u, u * p["frac"])

    return fn


_FALLOFF_FNS = {c: _falloff_fn(c) for c in ("frostbite", "threejs")}


def _variants(
    scene: Scene, datas: Sequence[_LightData], measure: bool
) -> tuple[list[_Variant], list[dict[str, Any]]]:
    spots = [k for k, x in enumerate(datas) if x.spot is not None]
    if not spots:
        return [
            _Variant(
                "",
                "",
                tuple(None for _ in datas),
                tuple(np.ones_like(x.d) for x in datas),
                0.0,
                0.0 if measure else None,
            )
        ], []
    variants, fits = [], []
    costs = {c: _cost.shader_cost(cls()) for c, cls in _SPOT_CLASSES.items()}
    ns: dict[str, float] = {}
    if measure:
        timed = _cost.measure_throughput([SpotFrostbite(), SpotThreeJS()], n=1 << 16, repeats=5)
        ns = {c: timed[cls.name][0] for c, cls in _SPOT_CLASSES.items()}
    for curve in ("frostbite", "threejs"):
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
                        g = _evaluate(m, x.cos_s, scene.float32)
                    except AttenfitError:
                        m, g = None, np.full_like(x.d, np.nan)
                else:
                    m = _SPOT_CLASSES[curve](umbra=x.spot[0], penumbra=x.spot[1])
                    g = _evaluate(m, x.cos_s, scene.float32)
                models.append(m)
                gs.append(g)
                err = _errors(x, x.E_irr / x.wpt, g)
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
                _Variant(name, curve, tuple(models), tuple(gs), costs[curve], ns.get(curve))
            )
    return variants, fits


# ----------------------------------------------------------------------------- recommend
def _candidate_names(scene: Scene) -> list[str]:
    return list(scene.families) if scene.families is not None else list_families()


def _check_reaches_zero(model: Family, R: float) -> str | None:
    """None if `model` is 0 beyond `R` and at `R` (to rounding: 1e-9 of f(R/2)), else why not."""
    x = np.array([R, R * (1 + 1e-6), 2 * R, R / 2])
    v = np.asarray(model(jnp.asarray(x)), dtype=np.float64)
    if v[1] == 0 and v[2] == 0 and abs(v[0]) <= 1e-9 * abs(v[3]):
        return None
    where = v[0] if v[1] == 0 and v[2] == 0 else v[1]
    return f"does not reach 0 at the range {R:g} (f = {where:.3g} there)"


def recommend(scene: Scene, *, measure: bool = True) -> Recommendation:
    """Fit and judge every family on `scene`; recommend the cheapest within tolerance.

    See the module docstring for how the truth is generated, fitted, judged and ranked.
    `measure=False` skips the timing (the ranking then uses the operation count and the
    error only; that takes a few seconds less).
    """
    if not isinstance(scene, Scene):
        raise BadTypeError(f"recommend takes an attenfit.Scene, got {type(scene).__name__}")
    truths = scene.ground_truth()
    datas = [_light_data(scene, t) for t in truths]
    for k, x in enumerate(datas):
        if x.d.size == 0:
            from ._errors import BadValueError

            raise BadValueError(
                f"{scene.source}: [[lights]][{k}]: no receiver can be judged for this light "
                "(all are beyond its range or face away from it)"
            )
    d_all = np.concatenate([x.d for x in datas])
    d_lo, d_hi = float(d_all.min()), float(d_all.max())
    knots = (
        tuple(float(k) for k in np.geomspace(d_lo, d_hi, 6)) if d_hi > d_lo else (d_lo, d_lo * 2)
    )
    variants, directional_fits = _variants(scene, datas, measure)

    fitted: dict[str, tuple[list[Family], list[bool], list[str]]] = {}
    candidates: list[Candidate] = []
    for name in _candidate_names(scene):
        cls = get_family(name)
        if scene.reach_zero_at_range and cls.window == "none":
            candidates.append(
                Candidate(name, "excluded", "no window: it cannot reach 0 at the range")
            )
            continue
        try:
            results: list[Any] = [None] * len(datas)
            plans = [_plan(cls, x, d_hi, knots) for x in datas]
            for free in dict.fromkeys(p[1] for p in plans):
                group = [k for k, p in enumerate(plans) if p[1] == free]
                out = _fit_group(cls, [datas[k] for k in group], [plans[k] for k in group])
                for k, r in zip(group, out, strict=True):
                    results[k] = r
        except AttenfitError as exc:
            candidates.append(Candidate(name, "fail", f"could not be fitted: {exc}"))
            continue
        fitted[name] = (
            [r[0] for r in results],
            [bool(r[1]) for r in results],
            [r[2] for r in results],
        )

    costs: dict[str, float] = {}
    for name, (models, _, _) in fitted.items():
        try:
            costs[name] = _cost.shader_cost(models[0])
        except (AttenfitError, ValueError):
            costs[name] = _cost.shader_cost(get_family(name)())
    ns: dict[str, float] = {}
    if measure and fitted:
        to_time = []
        for models, _, _ in fitted.values():
            m = models[0]
            if all(np.all(np.isfinite(np.asarray(v))) for v in m.params().values()):
                to_time.append(m)
        if to_time:
            timed = _cost.measure_throughput(to_time, n=1 << 16, repeats=5)
            ns = {k: v[0] for k, v in timed.items()}

    curves: dict[str, tuple[np.ndarray, np.ndarray]] = {}
    for name, (models, conv, msgs) in fitted.items():
        f_by_light = []
        bad = None
        for x, m in zip(datas, models, strict=True):
            try:
                f_by_light.append(_evaluate(m, x.d, scene.float32))
            except AttenfitError as exc:
                bad = str(exc)
                f_by_light.append(np.full_like(x.d, np.nan))
        # choose the spot falloff variant for this family
        best = None
        for v in variants:
            errs = [_errors(x, f, g) for x, f, g in zip(datas, f_by_light, v.g, strict=True)]
            e = max(float(er.max()) for er in errs)
            key_pass = e <= scene.tolerance
            rank = (0, v.cost, e) if key_pass else (1, e, v.cost)
            if best is None or rank < best[0]:
                best = (rank, v, errs, e)
        assert best is not None
        _, v, errs, e = best
        total_cost = costs[name] + v.cost
        total_ns = (ns[name] + v.ns) if (name in ns and v.ns is not None) else None
        params = tuple(_plain_params(m) for m in models)
        dparams = tuple(
            None
            if m is None
            else {
                "umbra": math.degrees(float(m.umbra)),
                "penumbra": math.degrees(float(m.penumbra)),
            }
            for m in v.models
        )
        converged = all(conv)
        message = "; ".join(dict.fromkeys(msgs))
        status, reason = "pass", "within tolerance"
        if bad is not None or not math.isfinite(e):
            status, reason = (
                "fail",
                f"non-finite values at the scene's receivers{': ' + bad if bad else ''}",
            )
        elif e > scene.tolerance:
            status = "fail"
            reason = f"error {_pct(e)} > tolerance {_pct(scene.tolerance)}"
            worst = int(np.argmax([er.max() for er in errs]))
            x = datas[worst]
            at = float(x.d[int(np.argmax(errs[worst]))])
            reason += f" (worst at d = {at:.3g} m, d/r = {at / x.radius:.3g}, light {worst})"
            if not converged:
                reason += f"; the fit did not converge ({_short(msgs)})"
        elif not converged:
            reason = f"within tolerance, though the fit did not converge ({_short(msgs)})"
        if status == "pass" and scene.reach_zero_at_range:
            for x, m in zip(datas, models, strict=True):
                problem = _check_reaches_zero(m, float(x.range))  # type: ignore[arg-type]
                if problem:
                    status, reason = "fail", problem
                    break
        candidates.append(
            Candidate(
                family=name,
                status=status,
                reason=reason,
                error=e,
                error_by_light=tuple(float(er.max()) for er in errs),
                shader_cost=total_cost,
                ns_per_eval=total_ns,
                params=params,
                converged=converged,
                message=message,
                directional=v.name or None,
                directional_params=dparams if v.name else (),
                models=tuple(models),
                spot_models=v.models,
            )
        )
        curves[name] = (
            np.concatenate([x.d / x.radius for x in datas]),
            np.concatenate(errs),
        )

    def cost_key(c: Candidate):
        return (
            c.shader_cost,
            c.error,
            c.ns_per_eval if c.ns_per_eval is not None else 0.0,
            c.family,
        )

    passing = sorted((c for c in candidates if c.status == "pass"), key=cost_key)
    failing = sorted(
        (c for c in candidates if c.status == "fail"),
        key=lambda c: (
            c.error if c.error is not None and math.isfinite(c.error) else math.inf,
            c.family,
        ),
    )
    excluded = [c for c in candidates if c.status == "excluded"]
    ordered = (*passing, *failing, *excluded)
    winner = passing[0] if passing else None
    runner_up = None
    if len(passing) > 1:
        runner_up = passing[1]
    elif winner is not None and failing:
        runner_up = failing[0]
    judged = [c for c in candidates if c.error is not None and math.isfinite(c.error)]
    closest = min(judged, key=lambda c: (c.error, c.shader_cost)) if judged else None
    shaders = _shaders(winner, len(datas)) if winner is not None else {}
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
    )


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


def _truth_summary(scene: Scene, t: LightTruth, x: _LightData) -> dict[str, Any]:
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


def _shaders(winner: Candidate, n_lights: int) -> dict[str, str]:
    """The winner's exported function per language (baked for one light, uniforms for several)."""
    out = {}
    model = winner.models[0]
    spot = next((m for m in winner.spot_models if m is not None), None)
    for lang in _export.LANGUAGES:
        parts = []
        if n_lights > 1:
            parts.append(
                "// several lights: parameters are uniforms (C: arguments); per-light values are in recommendation.md\n"
            )
            parts.append(_export.export(model, lang, uniforms=True))
        else:
            parts.append(_export.export(model, lang))
        if spot is not None:
            parts.append(
                "\n// spot falloff: the argument d is cos(angle between the spot direction and the light-to-receiver direction)\n"
            )
            parts.append(
                _export.export(spot, lang, name="attenfit_spot_falloff", uniforms=n_lights > 1)
            )
        out[lang] = "".join(parts)
    return out


# ----------------------------------------------------------------------------- figure
def plot_scene_errors(rec: Recommendation, ax=None, *, others: int = 3):
    """Judged error against d/r for the winner, runner-up and `others` more candidates.

    Every judged receiver of every light is a point; the tolerance is a dashed line.
    Returns `(fig, ax)`; never calls `show()`.
    """
    import matplotlib.pyplot as plt

    picks: list[Candidate] = []
    for c in (rec.winner, rec.runner_up, rec.closest):
        if c is not None and c not in picks and c.family in rec.curves:
            picks.append(c)
    for c in rec.candidates:
        if len(picks) >= 2 + others + (rec.winner is None):
            break
        if (
            c not in picks
            and c.family in rec.curves
            and c.error is not None
            and math.isfinite(c.error)
        ):
            picks.append(c)
    with matplotlib.rc_context({"font.size": 9, "axes.grid": True, "grid.alpha": 0.3}):
        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 4.2))
        else:
            fig = ax.figure
        markers = "os^vDP*X"
        floor = rec.tolerance * 1e-4  # smaller errors (exact to rounding) are drawn here
        for k, c in enumerate(picks):
            x, e = rec.curves[c.family]
            order = np.argsort(x)
            e = np.maximum(e[order], floor)
            role = (
                "winner"
                if c is rec.winner
                else "runner-up"
                if c is rec.runner_up
                else "closest"
                if c is rec.closest
                else c.status
            )
            ax.plot(
                x[order], e, markers[k % len(markers)], ms=3, alpha=0.7,
                label=f"{c.label} ({role}, max {_pct(c.error)})",
            )  # fmt: skip
        ax.axhline(
            rec.tolerance, color="k", ls="--", lw=1, label=f"tolerance {_pct(rec.tolerance)}"
        )
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("d / r (distance from the light's centre over its radius)")
        ax.set_ylabel(f"judged error of the irradiance (< {floor:.0e} drawn at it)")
        ax.set_title(f"{rec.scene.name or rec.scene.source}: error at the scene's receivers")
        ax.legend(fontsize=7, loc="best")
        fig.tight_layout()
    return fig, ax
