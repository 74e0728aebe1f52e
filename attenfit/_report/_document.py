"""`Report`: every number of a built report, its tables as Markdown, and writing it out."""

from __future__ import annotations

import csv
import dataclasses
import io
import json
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .._atomic import atomic_dir, check_output_path
from .._curves import get_family
from .._errors import UnknownNameError
from . import _figures
from . import _metrics as M
from ._area_shapes import shapes_markdown
from ._configs import MODES, WINDOWED, Config
from ._decide import decide, decision_markdown
from ._markdown import (
    describe_emitter,
    emitter_dict,
    fmt_num,
    fmt_params,
    fmt_pct,
    fmt_reach,
    jsonable,
    md_row,
)
from ._published import PUBLISHED_RULES
from ._summary import FIT_WHAT
from ._summary import summary_markdown as _summary_markdown


# ============================================================================ the report
@dataclasses.dataclass
class Report:
    """A built comparison report: every number, and what the figures need.

    `results` has one dict per family x configuration x mode ("published" or "fitted") with
    the parameters, the fit's status and the metrics (`attenfit.metrics`); `findings` lists
    the numbers behind the seeds' claims; `configs` describes each configuration. Write it with
    `write(folder)`; `to_dict()` is what `report.json` holds.
    """

    families: list[str]
    configs: list[Config]
    results: list[dict[str, Any]]
    findings: list[dict[str, Any]]
    costs: dict[str, Any]
    meta: dict[str, Any]
    _models: dict[tuple[str, str, str], Any] = dataclasses.field(default_factory=dict, repr=False)
    #: (family, configuration, mode) -> the model's values on the configuration's distances.
    _values: dict[tuple[str, str, str], dict[str, np.ndarray]] = dataclasses.field(
        default_factory=dict, repr=False
    )
    #: Figures drawn while the fits ran (`_figures.prerender`): key -> (PNG, SVG).
    _prerendered: dict[str, tuple[bytes, bytes | None]] = dataclasses.field(
        default_factory=dict, repr=False
    )
    #: The Mitsuba witness (`_witness.witness_section`), set by `attenfit report`; or None.
    witness: Any = None
    #: The decision table's entries once judged (`decisions`: worst cases are searched once).
    _decisions: list[dict[str, Any]] | None = dataclasses.field(default=None, repr=False)

    # ------------------------------------------------------------------ access
    def result(self, family: str, config: str, mode: str = "published") -> dict[str, Any]:
        """The result row of `family` on configuration `config` in `mode`."""
        for row in self.results:
            if row["family"] == family and row["config"] == config and row["mode"] == mode:
                return row
        raise UnknownNameError(
            f"no result for family {family!r}, configuration {config!r}, mode {mode!r}"
        )

    def finding(self, key: str) -> dict[str, Any]:
        """The finding `key` (see `findings`)."""
        for f in self.findings:
            if f["key"] == key:
                return f
        raise UnknownNameError(
            f"no finding {key!r}; findings: {', '.join(f['key'] for f in self.findings)}"
        )

    def to_dict(self) -> dict[str, Any]:
        """Every number of the report, JSON-ready (what report.json holds)."""
        cfgs = []
        for c in self.configs:
            cfgs.append(
                {
                    "name": c.name,
                    "kind": c.kind,
                    "radius": c.radius,
                    "emitter": emitter_dict(c.emitter),
                    "source": c.source,
                    "sweep": None
                    if c.sweep is None
                    else {
                        "description": c.sweep.description,
                        "n": int(c.sweep.d.size),
                        "d_min": float(c.sweep.d.min()),
                        "d_max": float(c.sweep.d.max()),
                        "truth_at_zero": c.sweep.truth0,
                        "truth_max": c.sweep.truth_max,
                    },
                    "plane": None if c.plane is None else {"description": c.plane.description},
                }
            )
        return jsonable(
            {
                "meta": self.meta,
                "families": self.families,
                "configurations": cfgs,
                "decisions": self.decisions(),
                "witnesses": [{k: v for k, v in w.items() if k != "z"} for w in self.witnesses()],
                "findings": self.findings,
                "costs": self.costs,
                "results": self.results,
                "witness": None if self.witness is None else self.witness.data,
            }
        )

    # ------------------------------------------------------------------ tables
    def csv_rows(self) -> list[dict[str, Any]]:
        """One flat row per family x configuration x mode (what results.csv holds)."""
        rows = []
        for r in self.results:
            sw = r.get("sweep") or {}
            ov = sw.get("overall") or {}
            bands = sw.get("bands") or {}
            inr = sw.get("in_range") or {}
            z = sw.get("at_zero") or {}
            pl = r.get("plane") or {}
            img = pl.get("image") or {}
            en = pl.get("energy") or {}
            win = r.get("window") or {}
            rows.append(
                {
                    "family": r["family"],
                    "configuration": r["config"],
                    "mode": r["mode"],
                    "status": r["status"],
                    "params": json.dumps(r.get("params"), sort_keys=True),
                    "max_abs_rel_error": ov.get("max_abs"),
                    "rms_rel_error": ov.get("rms"),
                    "worst_at_d": ov.get("worst_at"),
                    **{
                        f"{b}_{k}": (bands.get(b) or {}).get(s)
                        for b in M.BANDS
                        for k, s in (("max_abs", "max_abs"), ("rms", "rms"))
                    },
                    "in_range_max_abs": inr.get("max_abs"),
                    "in_range_rms": inr.get("rms"),
                    "inner_half_max_abs": (sw.get("inner_half") or {}).get("max_abs"),
                    "reach_1pct_of_range": (sw.get("reach") or {}).get("1%"),
                    "reach_10pct_of_range": (sw.get("reach") or {}).get("10%"),
                    "f_at_0": z.get("value"),
                    "f_at_0_over_truth": z.get("ratio"),
                    "range": win.get("range"),
                    "edge_value_rel": win.get("value_rel"),
                    "edge_slope_rel": win.get("slope_rel"),
                    "plane_energy_ratio": en.get("ratio"),
                    "plane_energy_discarded": en.get("discarded_fraction"),
                    "image_max_abs": img.get("max_abs"),
                    "image_rms": img.get("rms"),
                    **{
                        f"{k}_max_abs": (
                            ((r.get("receivers") or {}).get(k) or {}).get("overall") or {}
                        ).get("max_abs")
                        for k in ("facing", "floor", "random")
                    },
                    "ns_per_eval": (self.costs.get(r["family"]) or {}).get("ns_per_eval"),
                }
            )
        return rows

    def summary_markdown(self) -> str:
        """The summary table: every family on each light's three receiver sets, published /
        fitted, the floor energy of each light and the compiled cost (`_summary`)."""
        return _summary_markdown(self)

    def decisions(self) -> list[dict[str, Any]]:
        """The decision table's entries, "Which curve for which light" (`_decide.decide`),
        each named model held to its worst case (searched on the first call)."""
        if self._decisions is None:
            from .. import _progress

            _progress.stage("decision table: each named model's worst case, searched")
            # the rectangle's and the tube's rows, decided as the report was built
            self._decisions = decide(self) + list(self.meta.get("shapes", {}).get("decisions", []))
        return self._decisions

    def decision_markdown(self) -> str:
        """The decision table as Markdown (empty without a light that has receiver sets)."""
        label = next(iter(self.costs.values())).get("cost_label", "") if self.costs else ""
        return decision_markdown(self.decisions(), label)

    def witness_markdown(self, figures: Mapping[str, str] | None = None) -> str:
        """The independent witness: Monte Carlo datasets (e.g. Mitsuba, `--mitsuba`) against
        the exact values, as z-scores; empty when the report has none (see `witnesses`)."""
        rows = self.witnesses()
        if not rows:
            return ""
        figures = figures or {}
        lines = [
            md_row(["dataset", "generator", "receivers", "median |z|", "max |z|"]),
            md_row(["---", "---", "---:", "---:", "---:"]),
        ]
        for w in rows:
            lines.append(
                md_row(
                    [
                        w["config"],
                        w["source"],
                        w["n"],
                        fmt_num(w["median_abs_z"]),
                        fmt_num(w["max_abs_z"]),
                    ]
                )
            )
        out = (
            "z = (exact − Monte Carlo) / its standard error at each receiver; for an unbiased "
            "renderer |z| has median 0.674 (a standard normal's).\n\n" + "\n".join(lines) + "\n"
        )
        for w in rows:
            k = f"{w['config']}_witness_z"
            if k in figures:
                out += f"\n![{w['config']}: z-scores]({figures[k]})\n"
        return out

    def witnesses(self) -> list[dict[str, Any]]:
        """Per dataset configuration with standard errors: the z-scores of the exact values
        against it (`config`, `source`, `n`, `median_abs_z`, `max_abs_z`, `z`)."""
        out = []
        for c in self.configs:
            z = getattr(c, "witness_z", None)
            if z is None or not np.size(z):
                continue
            a = np.abs(np.asarray(z, np.float64))
            out.append(
                {
                    "config": c.name,
                    "source": c.source,
                    "n": int(a.size),
                    "median_abs_z": float(np.median(a)),
                    "max_abs_z": float(np.max(a)),
                    "z": np.asarray(z, np.float64),
                }
            )
        return out

    def cost_markdown(self) -> str:
        """One row per family: compiled cost of the shader and stable forms, the float16 band
        within 1%, measured time per evaluation and its ratio to 1/d^2."""
        lines = [
            md_row(["family", "cost, shader form", "cost, stable form", "SASS (MUFU), shader",
                    "float16 within 1%", "ns / eval", "time / inverse_square"]),
            md_row(["---", "---:", "---:", "---:", "---", "---:", "---:"]),
        ]  # fmt: skip
        for fam in self.families:
            c = self.costs.get(fam) or {}
            comp = c.get("compiled") or {}
            sass = (comp.get("shader") or {}).get("sass")
            band = (((c.get("precision") or {}).get("float16")) or {}).get("band")
            lines.append(
                md_row(
                    [
                        f"`{fam}`",
                        fmt_num(c.get("shader_cost")),
                        fmt_num((comp.get("stable") or {}).get("cost")),
                        "-" if not sass else f"{sass['total']} ({sass['classes']['mufu']})",
                        "-" if not band else f"{band[0]:.3g} to {band[1]:.4g} m",
                        fmt_num(c.get("ns_per_eval"), digits=2),
                        fmt_num(c.get("ratio_to_inverse_square"), digits=2),
                    ]
                )
            )
        method = next(iter(self.costs.values())).get("method", "")
        return "\n".join(lines) + f"\n\n{method}; times are of this machine and this run.\n"

    def _get(self, fam: str, cfg: str, mode: str) -> dict[str, Any] | None:
        try:
            return self.result(fam, cfg, mode)
        except UnknownNameError:
            return None

    def findings_markdown(self) -> str:
        """The findings that are not about one window, with the closed-form value where known."""
        lines = [
            md_row(["quantity", "value", "closed form", "configuration"]),
            md_row(["---", "---:", "---:", "---"]),
        ]
        for f in self.findings:
            if f["key"].startswith("window_"):
                continue
            lines.append(
                md_row(
                    [
                        f["quantity"],
                        fmt_num(f["value"], digits=6),
                        fmt_num(f.get("expected"), digits=6),
                        f.get("config", ""),
                    ]
                )
            )
        return "\n".join(lines) + "\n"

    def windows_markdown(self) -> str:
        """One row per windowed family: its deviation inside the range and what it drops."""
        cfg = next(
            (
                c
                for c in self.configs
                if c.sweep is not None and c.plane is not None and c.plane.rho is not None
            ),
            None,
        )
        if cfg is None:
            return ""
        head = [
            "family",
            "window",
            "range (m)",
            "max |error|, d ≤ range/2",
            "off by > 1% from",
            "off by > 10% from",
            "f·d² at range",
            "slope vs 1/d² at range",
            "true energy beyond range",
            "plane energy / truth",
        ]
        lines = [md_row(head), md_row(["---", "---"] + ["---:"] * (len(head) - 2))]

        n = 0
        for fam in self.families:
            try:
                kind = get_family(fam).window
            except Exception:
                continue
            r = self._get(fam, cfg.name, "published")
            if kind not in WINDOWED or r is None or r["status"] != "ok":
                continue
            half = (r["sweep"] or {}).get("inner_half") or {}
            reach = (r["sweep"] or {}).get("reach") or {}
            win = r.get("window") or {}
            en = (r["plane"] or {}).get("energy") or {}
            lines.append(
                md_row(
                    [
                        f"`{fam}`",
                        kind,
                        fmt_num(win.get("range")),
                        fmt_pct(half.get("max_abs")),
                        fmt_reach(reach.get("1%")),
                        fmt_reach(reach.get("10%")),
                        fmt_num(win.get("value_rel"), digits=2),
                        fmt_num(win.get("slope_rel"), digits=2),
                        fmt_pct(en.get("discarded_fraction")),
                        fmt_num(en.get("ratio"), digits=4),
                    ]
                )
            )
            n += 1
        if not n:
            return ""
        return (
            f"Against the {cfg.name}, as published; energies on {cfg.plane.description.split(';')[0]}. "
            "'Off by > 1% from': the fraction of the range beyond which the curve is off by more "
            "than 1% all the way to the range. f·d² and the slope are taken just inside the range, relative to inverse-square there "
            "(0 and 0: the window closes smoothly; 1 and 1: no window). The energy columns "
            "integrate the irradiance over the plane.\n\n" + "\n".join(lines) + "\n"
        )

    def markdown(self, figures: Mapping[str, str] | None = None) -> str:
        """report.md: the summary table, the findings, then one section per configuration."""
        figures = figures or {}
        m = self.meta
        out = [
            "# attenfit comparison report",
            "",
            f"attenfit {m['version']}, {m['created']}; {len(self.families)} families, "
            f"{len(self.configs)} configurations; built in {m['build_seconds']:.1f} s. "
            "Every number is in `report.json`, one row per family × configuration × mode in "
            "`results.csv`. Lights have unit intensity; distances in m, attenuation in 1/m².",
            "",
        ]
        dec = self.decision_markdown()
        if dec:
            out += ["## Which curve for which light", "", dec]
        out += [
            "## Summary",
            "",
            self.summary_markdown(),
            "## Findings",
            "",
            "The numbers behind the seeds' claims (report.json `findings`).",
            "",
            self.findings_markdown(),
        ]
        wit = self.witness_markdown(figures)
        if wit:
            out += ["## Independent witness: the truth checked by a Monte Carlo renderer", "", wit]
        win = self.windows_markdown()
        if win:
            out += ["### Windows: what each range costs inside it and what it drops", "", win]
        for c in self.configs:
            out += self._config_markdown(c, figures)
        if "shapes" in self.meta:
            out += ["## Rectangle and tube lights: the ceiling", "",
                    shapes_markdown(self.meta["shapes"])]  # fmt: skip
        if self.costs:
            out += ["## Cost against error", "", self.cost_markdown(), ""]
        if "cost_vs_error" in figures:
            out += [f"![cost against error]({figures['cost_vs_error']})", ""]
        if self.witness is not None:
            out += [self.witness.markdown(figures.get("witness_z"))]
        out += [
            "## How the numbers were made",
            "",
            f"* Truth: {', '.join(sorted({c.source for c in self.configs}))}; computed in float64.",
            "* As published (`published_params`):",
            *(f"  * {rule}" for rule in PUBLISHED_RULES),
            "* Fitted: `attenfit.fit_many` (every family in one solve), started from the "
            f"published values; {FIT_WHAT[len('*fitted*: ') :]}. A family whose only parameter "
            "is its range keeps its published values. A fit that does not converge is marked "
            "and its numbers are not shown.",
            "* Bands: near d < r, mid r ≤ d ≤ 10 r, far d > 10 r. Plane images: relative error "
            "against max(truth, 1e-6 × peak).",
            "* Cost: "
            + (next(iter(self.costs.values()))["method"] if self.costs else "not measured")
            + ".",
            "",
        ]
        return "\n".join(out)

    def _config_markdown(self, c: Config, figures: Mapping[str, str]) -> list[str]:
        out = [f"## {c.name}", "", f"{describe_emitter(c)}", ""]
        if c.sweep is not None:
            out += [f"Sweep: {c.sweep.description}.", ""]
        if c.plane is not None:
            out += [f"Plane: {c.plane.description}.", ""]
        for key, alt in (
            ("attenuation_published", "attenuation, as published"),
            ("attenuation_fitted", "attenuation, fitted"),
            ("error_published", "relative error, as published"),
            ("error_fitted", "relative error, fitted"),
            ("plane_errors", "plane error maps"),
            ("plane_side_by_side", "plane renders"),
        ):
            k = f"{c.name}_{key}"
            if k in figures:
                out += [f"![{c.name}: {alt}]({figures[k]})", ""]
        out += [self._config_table(c), ""]
        return out

    def _config_table(self, c: Config) -> str:
        head = ["family", "mode", "status", "parameters"]
        if c.sweep is not None:
            head += ["max", "rms", "near", "mid", "far", "in range", "f(0)/truth"]
        if c.plane is not None:
            head += ["image max", "image rms"]
            if c.plane.rho is not None:
                head += ["energy ratio", "energy dropped"]
        head += ["edge value", "edge slope"]
        lines = [md_row(head), md_row(["---"] * 4 + ["---:"] * (len(head) - 4))]
        for fam in self.families:
            for mode in MODES:
                r = self._get(fam, c.name, mode)
                if r is None:
                    continue
                ok = r["status"] == "ok"
                row = [f"`{fam}`", mode, r["status"], fmt_params(r.get("params")) if ok else "—"]
                sw, pl, win = r.get("sweep") or {}, r.get("plane") or {}, r.get("window") or {}
                if c.sweep is not None:
                    b = sw.get("bands") or {}
                    row += [
                        fmt_pct((sw.get("overall") or {}).get("max_abs")),
                        fmt_pct((sw.get("overall") or {}).get("rms")),
                        *(fmt_pct((b.get(k) or {}).get("max_abs")) for k in M.BANDS),
                        fmt_pct((sw.get("in_range") or {}).get("max_abs")),
                        fmt_num((sw.get("at_zero") or {}).get("ratio"), inf_text="∞"),
                    ]
                if c.plane is not None:
                    img = pl.get("image") or {}
                    row += [fmt_pct(img.get("max_abs")), fmt_pct(img.get("rms"))]
                    if c.plane.rho is not None:
                        en = pl.get("energy") or {}
                        row += [fmt_num(en.get("ratio")), fmt_pct(en.get("discarded_fraction"))]
                row += [
                    fmt_num(win.get("value_rel"), digits=2),
                    fmt_num(win.get("slope_rel"), digits=2),
                ]
                if not ok:
                    row = row[:4] + ["—"] * (len(row) - 4)
                lines.append(md_row(row))
        note = (
            "max/rms/near/mid/far/in range: |relative error|; f(0)/truth: the curve at d = 0 over "
            "the true limit; edge value and slope: f and f′ just inside the range relative to "
            "inverse-square there (0 = the window closes; slope 0 = smoothly). "
            f"{FIT_WHAT[0].upper()}{FIT_WHAT[1:]}."
        )
        return "\n".join(lines) + "\n\n" + note

    # ------------------------------------------------------------------ writing
    def write(
        self,
        folder: str | Path,
        *,
        force: bool = False,
        dpi: int = 100,
        svg: bool = False,
        progress: Callable[[str], None] | None = None,
    ) -> Path:
        """Write the report into `folder` (created; replaced only with `force`).

        The files go to a temporary folder that is moved into place only when everything is
        written (`attenfit._atomic.atomic_dir`), so an interrupted run leaves any previous
        report intact. Returns the folder's path.
        """

        check_output_path(folder, force=force, folder=True)
        with atomic_dir(folder, force=force) as tmp:
            figs = self.write_figures(tmp / "figures", dpi=dpi, svg=svg, progress=progress)
            if self.witness is not None:
                figs["witness_z"] = tmp / "figures" / "witness_z.png"
                figs["witness_z"].write_bytes(self.witness.png)
            if progress is not None:
                progress("tables: report.md, report.json, results.csv")
            rel = {k: f"figures/{Path(v).name}" for k, v in figs.items()}
            md = self.markdown(rel)
            if "ceiling" in self.meta:  # the section of `_ceiling`, drawn from its numbers
                from ._ceiling import ceiling_section

                md += (
                    "\n"
                    + ceiling_section(tmp / "figures", data=self.meta["ceiling"], dpi=dpi, svg=svg)[
                        0
                    ]
                )
            (tmp / "report.md").write_text(md, encoding="utf-8")
            (tmp / "report.json").write_text(
                json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n", encoding="utf-8"
            )
            (tmp / "results.csv").write_text(self.csv_text(), encoding="utf-8")
            if progress is not None:
                progress(f"complete; moving it into place as {folder}")
        return Path(folder)

    def csv_text(self) -> str:
        rows = self.csv_rows()
        buf = io.StringIO()
        w = csv.DictWriter(
            buf, fieldnames=list(rows[0]) if rows else ["family"], lineterminator="\n"
        )
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
        return buf.getvalue()

    def write_figures(
        self,
        folder: str | Path,
        *,
        dpi: int = 100,
        svg: bool = False,
        progress: Callable[[str], None] | None = None,
    ) -> dict[str, Path]:
        """Draw every figure into `folder` (PNG, and SVG when `svg`); return key -> PNG path."""

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        pre = self._prerendered if dpi == 100 else {}
        return _figures.draw_all(self, folder, dpi=dpi, svg=svg, progress=progress, prerendered=pre)
