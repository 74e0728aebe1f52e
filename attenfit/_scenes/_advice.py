"""What `recommend` returns: a `Candidate` per family and the `Recommendation` (its Markdown,
JSON, shader files and error figure)."""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import atomic_dir
from .._curves import Family, SpotFalloff
from .._judge import Contender
from ._scene import Scene


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

    def contender(self, light: int | Sequence[int] | None = None) -> Contender[Candidate]:
        """This candidate for `attenfit._judge.rank`: over every light (`light` None, allowed
        when its status is "pass"), or at one light or several (its largest error there;
        allowed unless it is excluded or failed for a reason other than an error: a
        precision failure, a non-finite value, a broken constraint)."""
        if light is None:
            error, allowed = self.error, self.status == "pass"
        else:
            lights = [light] if isinstance(light, int) else list(light)
            errs = [self.error_by_light[i] for i in lights if i < len(self.error_by_light)]
            error = max(errs) if errs and len(errs) == len(lights) else None
            allowed = self.status == "pass" or (
                self.status == "fail" and self.reason.startswith("error ")
            )
        n = len(self.params[0]) if self.params else 0
        return Contender(self.family, error, self.shader_cost, n, allowed, item=self)

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
    then failing ones by error, then excluded ones. Every order is `attenfit._judge.rank`'s
    (cost, then error, then name; docs/report.md, "How a model is chosen"). `shaders` maps "glsl", "hlsl", "wgsl",
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
    cost_label: str = ""
    #: When no family meets the tolerance at every light: the area-light models judged for
    #: each light no family meets on its own (`_escalate.AreaAnswer`).
    area: Any = None
    #: Per judged receiver (the order of `curves`): its angle from its spot's axis in degrees,
    #: NaN for a light that is not a spot (`plot_errors` draws spots' errors against it).
    angles: np.ndarray | None = dataclasses.field(default=None, repr=False, compare=False)

    @property
    def tolerance(self) -> float:
        return self.scene.tolerance

    def summary(self) -> str:
        """One line: the winner with its error and cost, or that nothing is within tolerance."""
        tol = pct(self.tolerance)
        if self.winner is not None:
            w = self.winner
            return (
                f"recommended: {w.label} (max error {pct(w.error)} <= tolerance {tol}, "
                f"shader cost {w.shader_cost:g})"
            )
        c = self.closest
        closest = f"; closest: {c.label} with max error {pct(c.error)}" if c else ""
        families = f"no family meets the tolerance {tol}{closest}"
        return families if self.area is None else self.area.summary(families)

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
            "ranking": "shader_cost (compiled cost of the shader form), then error (errors "
            "equal to 3 significant digits: fewer parameters first), then family name",
            "cost": self.cost_label,
            "measured": self.measured,
            "winner": None if self.winner is None else self.winner.to_dict(),
            "runner_up": None if self.runner_up is None else self.runner_up.to_dict(),
            "closest": None if self.closest is None else self.closest.to_dict(),
            "candidates": [c.to_dict() for c in self.candidates],
            "truth": list(self.truth),
            "directional_fits": list(self.directional_fits),
            "shaders": dict(self.shaders),
            "area": None if self.area is None else self.area.to_dict(),
        }

    def to_markdown(self, *, together: bool = False) -> str:
        """A human-readable report: verdict, the winner's shader code, a table of every family.

        `together`: a section of a scene file's answer, whose headline is per light (its
        per-light choices): this one is titled as the one family for all lights together,
        its verdict not a headline, its headings one level down."""
        s = self.scene
        if together:
            lines = ["## All lights together: one family for every light", "",
                     f"With one family for every light: {self.summary()}.", ""]  # fmt: skip
        else:
            lines = [f"# Recommendation for {s.name or s.source}", ""]
            if s.description:
                lines += [s.description.strip(), ""]
            lines += [f"**{self.summary()}**", ""]
        lines += self._setup_lines()
        lines += self._pick_lines()
        if self.area is not None:
            lines += self.area.markdown()
        if self.shaders:
            lines += ["## The winner as GLSL", "", "```glsl", self.shaders["glsl"].rstrip(),
                      "```", ""]  # fmt: skip
        lines += self._spot_lines()
        lines += ["## Every family", "", "| family | status | max error | shader cost | ns/eval | why |",
                  "|---|---|---|---|---|---|"]  # fmt: skip
        for c in self.candidates:
            ns = f"{c.ns_per_eval:.3g}" if c.ns_per_eval is not None else "-"
            cost = f"{c.shader_cost:g}" if c.shader_cost is not None else "-"
            lines.append(
                f"| {c.label} | {c.status} | {pct(c.error)} | {cost} | {ns} | {c.reason} |"
            )
        lines.append("")
        if together:
            lines = [f"#{x}" if x.startswith("##") and i > 0 else x for i, x in enumerate(lines)]
        return "\n".join(lines)

    def _setup_lines(self) -> list[str]:
        """The tolerance, constraints and ranking, and what was generated per light."""
        s = self.scene
        floor = f", error floor {pct(s.error_floor)} of each light's peak" if s.error_floor else ""
        cons = [c for c, on in (("reach 0 at the range", s.reach_zero_at_range),
                                (f"{s.precision} shading", s.precision != "float64")) if on]  # fmt: skip
        lines = [
            f"Tolerance {pct(s.tolerance)} (max relative error of the irradiance){floor}; "
            f"constraints: {', '.join(cons) or 'none'}. Ranked by the compiled cost of the shader "
            f"form ({self.cost_label or 'not computed'}), then error (equal to 3 digits: fewer "
            "parameters first), then name.",
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
        return [*lines, ""]

    def _pick_lines(self) -> list[str]:
        """The winner and runner-up (or the closest), with their parameters per light."""
        lines: list[str] = []
        radii = [getattr(light, "radius", None) for light in self.scene.lights]
        for label, c in (("Winner", self.winner), ("Runner-up", self.runner_up)):
            if c is None:
                continue
            note = "" if c.status == "pass" else " (not within tolerance)"
            ns = f", {c.ns_per_eval:.3g} ns/eval measured" if c.ns_per_eval is not None else ""
            lines += [f"## {label}: {c.label}{note}", "",
                      f"max error {pct(c.error)}, shader cost {c.shader_cost:g}{ns}", ""]  # fmt: skip
            lines += [*_param_lines(c, radii), ""]
        if self.winner is None and self.closest is not None:
            c = self.closest
            lines += [f"## Closest: {c.label}", "", f"max error {pct(c.error)}: {c.reason}", ""]
            lines += [*_param_lines(c, radii), ""]
        return lines

    def _spot_lines(self) -> list[str]:
        if not self.directional_fits:
            return []
        lines = ["## Spot falloff fits", "",
                 "| light | variant | umbra (deg) | penumbra (deg) | falloff error | shader cost |",
                 "|---|---|---|---|---|---|"]  # fmt: skip
        for f in self.directional_fits:
            lines.append(
                f"| {f['light']} | {f['variant']} | {f['umbra']:.3f} | {f['penumbra']:.3f} "
                f"| {pct(f['error'])} | {f['shader_cost']:g} |"
            )
        return [*lines, ""]

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
            for stem, shaders in self._shader_files():
                for lang, text in shaders.items():
                    (tmp / f"{stem}.{lang}").write_text(text, encoding="utf-8")
            fig, _ = self.plot_errors()
            fig.savefig(tmp / "errors.png", dpi=110)
            import matplotlib.pyplot as plt

            plt.close(fig)
        return out

    def _shader_files(self) -> list[tuple[str, Mapping[str, str]]]:
        """(file stem, function per language) of what `save` writes: the winner's; with no
        winner, each area model recommended (`attenfit_area_<model>`, and its light's index
        when several lights have one) and the family the other lights keep."""
        if self.winner is not None:
            return [(_ident(self.winner.family), self.shaders)]
        if self.area is None:
            return []
        won = [e for e in self.area.escalations if e.winner is not None]
        out: list[tuple[str, Mapping[str, str]]] = [
            (_ident(f"area_{e.winner.model}" + (f"_light{e.lights[0]}" if len(won) > 1 else "")),
             e.shaders)
            for e in won
        ]  # fmt: skip
        if self.area.others is not None:
            out.append((_ident(self.area.others.family), self.area.others_shaders))
        return out


def _ident(name: str) -> str:
    return f"attenfit_{name}"


def _param_lines(c: Candidate, radii: list[float | None] | None = None) -> list[str]:
    out = []
    for i, p in enumerate(c.params):
        radius = radii[i] if radii is not None and i < len(radii) else None
        vals = ", ".join(param_text(k, v, radius) for k, v in p.items()) or "no parameters"
        spot = ""
        if c.directional_params and i < len(c.directional_params) and c.directional_params[i]:
            dp = c.directional_params[i]
            spot = f"; spot umbra = {dp['umbra']:.4g} deg, penumbra = {dp['penumbra']:.4g} deg"
        out.append(f"- light {i}: {vals}{spot}")
    return out


#: A fitted `r` (the sources' light radius) this many times from the light's own radius is a
#: shape parameter of the curve, and is reported as one.
SHAPE_RATIO = 2.0


def param_text(name: str, value: Any, radius: float | None) -> str:
    """`name = value`; for a family's `r` (its source's light radius) fitted outside
    [1/SHAPE_RATIO, SHAPE_RATIO] times the light's `radius`, said to be a shape parameter of
    the curve, not the light's radius (a 0.08 m bulb's curve may want r = 2.66 m)."""
    text = f"{name} = {_fmt(value)}"
    if name != "r" or not radius or not isinstance(value, int | float) or not value > 0:
        return text
    ratio = float(value) / float(radius)
    if 1 / SHAPE_RATIO <= ratio <= SHAPE_RATIO:
        return text
    return (f"{text} (a shape parameter of the curve, {ratio:.3g}x the light's radius "
            f"{radius:g}: not the light's radius)")  # fmt: skip


def _fmt(v: Any) -> str:
    if isinstance(v, list):
        return "[" + ", ".join(f"{x:.6g}" for x in v) + "]"
    return f"{v:.6g}"


def pct(x: float | None) -> str:
    if x is None:
        return "-"
    if not math.isfinite(x):
        return str(x)
    return f"{100 * x:.3g}%"


# ----------------------------------------------------------------------------- figure
def plot_scene_errors(rec: Recommendation, ax=None, *, others: int = 3):
    """Judged error against d/r for the winner, runner-up and `others` more candidates.

    Every judged receiver of every light is a point; the tolerance is a dashed line.
    Returns `(fig, ax)`; never calls `show()`.
    """
    import matplotlib  # here, not at the top: a scene without --out draws nothing
    import matplotlib.pyplot as plt

    picks = _picks(rec, others)
    angles = rec.angles
    spots = angles is not None and bool(np.any(np.isfinite(angles)))
    with matplotlib.rc_context({"font.size": 9, "axes.grid": True, "grid.alpha": 0.3}):
        if ax is None:
            fig, axes = plt.subplots(
                1, 2 if spots else 1, figsize=(11.5 if spots else 8.2, 4.4), squeeze=False,
                layout="constrained",
            )  # fmt: skip
            ax, ax_spot = axes[0, 0], (axes[0, 1] if spots else None)
        else:  # one given axes: the spot receivers are drawn against d/r too
            fig, ax_spot = ax.figure, None
        markers = "os^vDP*X"
        floor = rec.tolerance * 1e-4  # smaller errors (exact to rounding) are drawn here
        for k, c in enumerate(picks):
            x, e = rec.curves[c.family]
            e = np.maximum(e, floor)
            on_spot = np.isfinite(angles) if ax_spot is not None else np.zeros(x.shape, bool)
            role = (
                "winner"
                if c is rec.winner
                else "runner-up"
                if c is rec.runner_up
                else "closest"
                if c is rec.closest
                else c.status
            )
            style = dict(marker=markers[k % len(markers)], ls="none", ms=3, alpha=0.7,
                         color=f"C{k}")  # fmt: skip
            order = np.argsort(x)
            ax.plot(x[order], e[order], label=f"{c.label} ({role}, max {pct(c.error)})",
                    **style)  # fmt: skip
            if ax_spot is not None:
                ax_spot.plot(angles[on_spot], e[on_spot], **style)
        _finish(rec, fig, ax, ax_spot, floor)
    return fig, ax


def _picks(rec: Recommendation, others: int) -> list[Candidate]:
    """The winner, runner-up and closest, then `others` more judged candidates."""
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
    return picks


def _finish(rec: Recommendation, fig, ax, ax_spot, floor: float) -> None:
    """The tolerance line, log axes, labels, titles and the legend outside the data."""
    for a in (ax, ax_spot):
        if a is None:
            continue
        a.axhline(rec.tolerance, color="k", ls="--", lw=1)
        a.set_yscale("log")
        a.set_ylabel(f"judged error of the irradiance (< {floor:.0e} drawn at it)")
    ax.plot([], [], color="k", ls="--", lw=1, label=f"tolerance {pct(rec.tolerance)}")
    ax.set_xscale("log")
    from .._report import plain_log_ticks

    for a in (ax, ax_spot):
        if a is not None:
            plain_log_ticks(a.yaxis)
    plain_log_ticks(ax.xaxis)
    ax.set_xlabel("d / r (distance from the light's centre over its radius)")
    name = str(rec.scene.name or rec.scene.source).replace("$", r"\$")  # a name, not mathtext
    title = f"{name}: error at the scene's receivers"
    if ax_spot is not None:
        ax.set_title("every light: error against distance")
        ax_spot.set_xlabel("angle from the spot's axis (degrees)")
        ax_spot.set_title("spotlights: error against angle")
        fig.suptitle(title, fontsize=10)
    else:
        ax.set_title(title)
    # outside the data: to the right of the last axes
    (ax_spot or ax).legend(*ax.get_legend_handles_labels(), fontsize=7,
                           loc="upper left", bbox_to_anchor=(1.02, 1.0), frameon=False)  # fmt: skip
