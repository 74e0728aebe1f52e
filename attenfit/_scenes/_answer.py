"""`answer_file`: a USD or glTF scene from file to per-light choices (read, sample, truth,
fit and judge every family the engine allows, choose per light, trade ranges)."""

from __future__ import annotations

import dataclasses
import json
import os
from pathlib import Path
from typing import Any

from .. import _progress
from .._float64 import in_float64
from ._advice import Recommendation, pct
from ._choices import LightChoice, choices_markdown, light_choices, plot_choices
from ._files import ImportedScene, load_mesh_scene
from ._light_fits import light_data
from ._recommend import recommend

__all__ = ["FileAnswer", "answer_file", "answer_scene"]


@dataclasses.dataclass(frozen=True)
class FileAnswer:
    """A scene file's answer: the imported scene, the recommendation over all its lights
    (`recommendation.winner`: one family for every light), and the per-light `choices`."""

    imported: ImportedScene
    recommendation: Recommendation
    choices: tuple[LightChoice, ...]

    def summary(self) -> str:
        """The headline, one answer per light: its family (and range), and the error of what
        is written, the final curve checked against the exact irradiance; for a light no
        family meets, the area model it needs (its worst-case error over the light's judged
        receivers and its compiled cost), or why it has none."""
        return "; ".join(self._headline(c) for c in self.choices)

    def _headline(self, c: LightChoice) -> str:
        """One light's part of the headline (`summary`)."""
        w = c.area_model
        if w is not None:
            own = (
                ""
                if self.imported.engine is None
                else "; a shader of its own, not light properties"
            )
            rendered = " as the engine renders it" if c.engine_error is not None else ""
            return (
                f"{c.name}: area model {w.label} (max error {pct(w.error)}, shader cost "
                f"{w.cost:g}{own}; no curve within tolerance: the closest, {c.answered_as}, is "
                f"{pct(c.claimed_error)} off{rendered})"
            )
        curve = self._curve_headline(c)
        if c.area is not None:
            near = c.area.closest
            near = f", closest area model {near.label} at {pct(near.error)}" if near else ""
            return f"{curve}; no area model meets it either{near}"
        area = self.recommendation.area
        why = dict(area.skipped).get(c.light) if area is not None and c.status == "fail" else None
        return curve if why is None else f"{curve}; not escalated ({why})"

    @staticmethod
    def _curve_headline(c: LightChoice) -> str:
        """The light's curve answer: its family (and range), and the error of what is written,
        the final curve checked against the exact irradiance (with an engine: as it renders)."""
        rng = ""
        if c.range is not None and c.range.get("range"):
            rng = f", range {c.range['range']:.3g} m"
        mark = "" if c.status == "pass" else " (closest, over tolerance)"
        error = f", checked error {pct(c.checked_error)}"  # the error of what is written
        if c.engine_error is not None:
            word = "" if c.status == "pass" else "fail, closest "
            mark = f" ({word}{pct(c.engine_error)} as the engine renders it)"
            error = ""
        return f"{c.name}: {c.answered_as}{mark}{rng}{error}"

    def to_markdown(self) -> str:
        """The answer per light (the headline), then the one family for all lights together."""
        head = f"# Answer for {self.imported.path.name}\n\n**{self.summary()}**\n\n"
        return (
            head
            + choices_markdown(self.imported, self.choices)
            + "\n"
            + self.recommendation.to_markdown(together=True)
        )

    def to_dict(self) -> dict[str, Any]:
        rec = self.recommendation.to_dict()
        im = self.imported
        rec["scene"] = {  # the sampled receivers are not repeated (thousands per light)
            "file": im.path.name,
            "format": im.format,
            "lights": [
                {"name": n, "file_kind": k, **light.to_dict()}
                for n, k, light in zip(im.names, im.file_kinds, im.scene.lights, strict=True)
            ],
            "samples_per_light": im.samples,
            "tolerance": im.scene.tolerance,
            "precision": im.scene.precision,
            "threshold": im.threshold,
            "engine": None if im.engine is None else im.engine.name,
            "notices": list(im.notices),
        }
        return {
            "format": "attenfit.scene-file-answer",
            "version": 1,
            "lights": [c.to_dict() for c in self.choices],
            "recommendation": rec,
        }

    def save(self, out: str | os.PathLike, *, force: bool = False) -> Path:
        """Write answer.md and answer.json (per light, then all lights together) and
        lights.png (each light's checked error against distance) into folder `out`, and the all-lights recommendation's files (`Recommendation.save`: shaders,
        errors.png) into `out/all-lights`; atomic, an existing non-empty folder is replaced
        only with `force`."""
        from .._atomic import atomic_dir

        rec = self.recommendation
        light = dataclasses.replace(rec, scene=dataclasses.replace(rec.scene, receivers=()))
        out = Path(out)
        with atomic_dir(out, force=force, inputs=self.imported.inputs) as tmp:
            (tmp / "answer.md").write_text(self.to_markdown(), encoding="utf-8")
            (tmp / "answer.json").write_text(
                json.dumps(self.to_dict(), indent=2) + "\n", encoding="utf-8"
            )
            light.save(tmp / "all-lights")
            import matplotlib.pyplot as plt

            fig, _ = plot_choices(self.imported, self.choices)
            fig.savefig(tmp / "lights.png", dpi=110)
            plt.close(fig)
        return out

    def write_back(self, out: str | os.PathLike, *, force: bool = False) -> Path:
        """A copy of the scene file with the answers written in (`attenfit._scenes._writeback`)."""
        from ._writeback import write_back

        return write_back(self.imported, self.choices, out, force=force)


@in_float64
def answer_file(path: str | os.PathLike, *, measure: bool = False, **options: Any) -> FileAnswer:
    """Read the USD or glTF scene `path` and answer it per light.

    `options` are those of `load_mesh_scene` (side, tolerance, precision, threshold,
    samples, radius, engine, strict, seed, time, notice). Computed in float64 whatever the caller's
    `jax_enable_x64`.
    """
    imported = load_mesh_scene(path, **options)
    scene = imported.scene
    _progress.stage(f"ground truth: {len(scene.lights)} lights, {imported.samples} receivers each")
    truths = scene.ground_truth()
    rec = recommend(scene, measure=measure, truths=truths)
    datas = [light_data(scene, t) for t in truths]
    _progress.stage("per-light choices" + (" and ranges" if imported.threshold else ""))
    return FileAnswer(imported, rec, light_choices(imported, rec, datas))


@in_float64
def answer_scene(
    scene, engine: str, *, threshold: float | None = None, measure: bool = False
) -> FileAnswer:
    """A TOML `Scene` answered per light for `engine` as a file is (`answer_file`): each
    light's family, range and engine properties, judged through the engine's own shading
    (`attenfit scene FILE.toml --engine E`)."""
    from ._engine import get_engine
    from ._files import engine_scene

    eng = get_engine(engine)
    scene = engine_scene(scene, eng)
    truths = scene.ground_truth()
    rec = recommend(scene, measure=measure, truths=truths)
    datas = [light_data(scene, t) for t in truths]
    n = len(scene.lights)
    source = Path(scene.source) if scene.source else None
    imported = ImportedScene(
        scene=scene,
        path=Path(scene.source or scene.name or "scene.toml"),
        format="toml",
        names=tuple(f"light {k} ({x.kind})" for k, x in enumerate(scene.lights)),
        refs=tuple(range(n)),
        file_kinds=tuple(x.kind for x in scene.lights),
        published_ranges=tuple(x.range for x in scene.lights),
        samples=max(len(x.d) for x in datas),
        drawn=(),
        threshold=threshold,
        engine=eng,
        notices=(),
        inputs=(str(source.resolve()),) if source is not None and source.exists() else (),
    )
    return FileAnswer(imported, rec, light_choices(imported, rec, datas))
