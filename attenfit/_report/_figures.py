"""The figures of the comparison report (`attenfit.report.Report.write_figures`).

Built from `attenfit.plots`; one function per figure kind, each saving PNG (and SVG) and
closing its figure. Families are split into two panels, those without a range and the
windowed ones, so that no panel carries more than ten curves.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._curves import get_family
from . import _plots as plots
from ._cost_plot import plot_cost_vs_error

WINDOWED = ("smooth", "hard")


def _save(fig, folder: Path, key: str, dpi: int, svg: bool, out: dict[str, Path]) -> None:
    import matplotlib as mpl

    png = folder / f"{key}.png"
    with mpl.rc_context(plots.STYLE):
        fig.savefig(png, dpi=dpi)
        if svg:
            fig.savefig(folder / f"{key}.svg")
    out[key] = png


def _split(report) -> tuple[list[str], list[str]]:

    plain, windowed = [], []
    for fam in report.families:
        try:
            w = get_family(fam).window
        except Exception:
            w = "none"
        (windowed if w in WINDOWED else plain).append(fam)
    return plain, windowed


def _vals(report, fam, cfg, mode, part):
    """The stored values of a family that evaluated fine (None otherwise)."""
    row = report._get(fam, cfg.name, mode)
    v = report._values.get((fam, cfg.name, mode))
    if row is None or row["status"] != "ok" or v is None:
        return None
    return v.get(part)


def _curves(report, cfg, fams, mode, part="sweep") -> dict[str, np.ndarray]:
    out = {}
    for fam in fams:
        v = _vals(report, fam, cfg, mode, part)
        if v is not None:
            out[fam] = v
    return out


def _two_panel(report, cfg, mode: str, kind: str):
    import matplotlib as mpl

    plain, windowed = _split(report)
    groups = [(g, t) for g, t in ((plain, "without a range"), (windowed, "windowed")) if g]
    styles = plots.curve_styles(plain)
    styles.update(plots.curve_styles(windowed))
    sw = cfg.sweep
    with mpl.rc_context(plots.STYLE):
        fig = plots.new_figure((5.2 * len(groups), 5.0))
        axes = fig.subplots(1, len(groups), squeeze=False)
        mode_text = "as published" if mode == "published" else "fitted"
        for ax, (fams, what) in zip(axes[0], groups, strict=True):
            dense = kind == "attenuation" and sw.dense_d is not None
            curves = _curves(report, cfg, fams, mode, "dense" if dense else "sweep")
            title = f"{cfg.name}, {mode_text}: families {what}"
            if kind == "attenuation":
                pts = None
                if sw.stderr is not None or dense:
                    pts = (sw.d, sw.truth, sw.stderr)
                plots.plot_attenuation(
                    sw.dense_d if dense else sw.d,
                    curves,
                    None if pts is not None else sw.truth,
                    r=cfg.radius,
                    truth_label=f"truth ({cfg.source.split(' ')[0]})",
                    truth_points=pts,
                    truth_points_label=f"truth ({cfg.source}{', ±2σ' if sw.stderr is not None else ''})",
                    styles=styles,
                    title=title,
                    legend="below",
                    ax=ax,
                )
                lo = max(float(np.nanmin(sw.truth)) * 0.3, 1e-12)
                hi = float(np.nanmax(sw.truth)) * 30
                ax.set_ylim(lo, hi)
            else:
                plots.plot_relative_error(
                    sw.d,
                    curves,
                    sw.truth,
                    r=cfg.radius,
                    styles=styles,
                    title=title,
                    legend="below",
                    ax=ax,
                )
    return fig


def _plane_errors(report, cfg):
    pl = cfg.plane
    models = {}
    for fam in report.families:
        v = _vals(report, fam, cfg, "published", "plane")
        if v is not None:
            models[fam] = pl.weight * v
    fig, _ = plots.plot_plane_comparison(
        pl.E, models, pl.extent, truth_label=pl.truth_label, ncols=5
    )
    fig.suptitle(f"{cfg.name}: error of each family as published on the plane", fontsize=10)
    return fig


def _side_by_side(report, cfg):
    import matplotlib as mpl

    pl = cfg.plane
    rows: list[tuple[str, np.ndarray, str]] = []
    if pl.E_exact is not None:
        rows.append(("exact (attenfit.irradiance)", pl.E_exact, ""))
    for fam in ("inverse_square", "yuksel", "unreal_window", "madams_cutoff"):
        if len(rows) >= 3:
            break
        v = _vals(report, fam, cfg, "published", "plane")
        if v is not None:
            rows.append((f"{fam} (published)", pl.weight * v, fam))
    if not rows:
        return None
    with mpl.rc_context(plots.STYLE):
        fig = plots.new_figure((11.5, 3.1 * len(rows)))
        subs = np.atleast_1d(fig.subfigures(len(rows), 1))
        for sub, (label, img, _) in zip(subs, rows, strict=True):
            plots.plot_side_by_side(
                pl.E, img, pl.extent, label=label, truth_label=pl.truth_label, fig=sub
            )
    return fig


def _cost_vs_error(report):
    """Error against shader cost per sweep configuration, as published and fitted, with the
    Pareto front (`attenfit.cost.plot_cost_vs_error`)."""
    import matplotlib as mpl

    sweeps = [c for c in report.configs if c.sweep is not None]
    costs = {
        k: v["shader_cost"] for k, v in report.costs.items() if v.get("shader_cost") is not None
    }
    if not costs or not sweeps:
        return None
    panels = []  # (row, column, config, mode, errors)
    modes = [m for m in ("published", "fitted") if any(r["mode"] == m for r in report.results)]
    for j, cfg in enumerate(sweeps):
        for i, mode in enumerate(modes):
            errors = {}
            for fam in report.families:
                row = report._get(fam, cfg.name, mode)
                if fam not in costs or row is None or row["status"] != "ok":
                    continue
                sw = row["sweep"] or {}
                st = sw.get("in_range") or sw.get("overall") or {}
                if st.get("max_abs") is not None:
                    errors[fam] = float(st["max_abs"])
            if errors:
                panels.append((i, j, cfg, mode, errors))
    if not panels:
        return None
    with mpl.rc_context(plots.STYLE):
        fig = plots.new_figure((6.2 * len(sweeps), 4.3 * len(modes)))
        axes = fig.subplots(len(modes), len(sweeps), squeeze=False)
        used = set()
        for i, j, cfg, mode, errors in panels:
            mode_text = "as published" if mode == "published" else "fitted"
            plot_cost_vs_error(
                errors,
                {k: costs[k] for k in errors},
                by="shader_cost",
                ax=axes[i, j],
                xlabel=next(iter(report.costs.values())).get("cost_label", "shader cost"),
                title=f"{cfg.name}, {mode_text}: max |relative error| (in range) against cost",
            )
            used.add((i, j))
        for i in range(len(modes)):
            for j in range(len(sweeps)):
                if (i, j) not in used:
                    axes[i, j].set_visible(False)
    return fig


def figure_jobs(report, *, published_only: bool = False):
    """(configuration, key, make) for every figure, in report order; `make()` returns a figure
    or None. With `published_only`, only those that need nothing beyond the published results
    (what `prerender` can draw while the fits run)."""
    jobs = []
    for cfg in report.configs:
        if cfg.sweep is not None:
            for mode in ("published",) if published_only else ("published", "fitted"):
                if not any(report._get(f, cfg.name, mode) for f in report.families):
                    continue
                for kind, name in (("attenuation", "attenuation"), ("error", "error")):
                    jobs.append(
                        (
                            cfg,
                            f"{cfg.name}_{name}_{mode}",
                            lambda cfg=cfg, mode=mode, kind=kind: _two_panel(
                                report, cfg, mode, kind
                            ),
                        )
                    )
        if cfg.plane is not None:
            jobs.append(
                (cfg, f"{cfg.name}_plane_errors", lambda cfg=cfg: _plane_errors(report, cfg))
            )
            jobs.append(
                (cfg, f"{cfg.name}_plane_side_by_side", lambda cfg=cfg: _side_by_side(report, cfg))
            )
    if not published_only:
        jobs.append((None, "cost_vs_error", lambda: _cost_vs_error(report)))
    return jobs


def prerender(
    report, *, dpi: int = 100, svg: bool = False
) -> dict[str, tuple[bytes, bytes | None]]:
    """Draw the figures that need only the published results into memory: key -> (PNG, SVG).

    `build_report` runs this in a thread while the fits compile (XLA releases the GIL), so the
    two cores work at once; `draw_all` then writes these bytes instead of drawing again.
    """
    import io

    import matplotlib as mpl

    out: dict[str, tuple[bytes, bytes | None]] = {}
    for _cfg, key, make in figure_jobs(report, published_only=True):
        fig = make()
        if fig is None:
            continue
        with mpl.rc_context(plots.STYLE):
            png = io.BytesIO()
            fig.savefig(png, dpi=dpi, format="png")
            svg_bytes = None
            if svg:
                buf = io.BytesIO()
                fig.savefig(buf, format="svg")
                svg_bytes = buf.getvalue()
        out[key] = (png.getvalue(), svg_bytes)
    return out


def draw_all(
    report,
    folder: Path,
    *,
    dpi: int = 100,
    svg: bool = False,
    progress=None,
    prerendered: dict[str, tuple[bytes, bytes | None]] | None = None,
) -> dict[str, Path]:
    """Draw every figure of `report` into `folder`; return figure key -> PNG path.

    Figures in `prerendered` (from `prerender`, same dpi and formats) are written, not redrawn.
    """
    out: dict[str, Path] = {}
    say = progress or (lambda s: None)
    prerendered = prerendered or {}
    current = None
    for cfg, key, make in figure_jobs(report):
        if cfg is not None and cfg is not current:
            current = cfg
            say(f"figures: {cfg.name}")
        if key in prerendered and (prerendered[key][1] is not None or not svg):
            png, svg_bytes = prerendered[key]
            (folder / f"{key}.png").write_bytes(png)
            if svg:
                (folder / f"{key}.svg").write_bytes(svg_bytes)
            out[key] = folder / f"{key}.png"
            continue
        fig = make()
        if fig is not None:
            _save(fig, folder, key, dpi, svg, out)
    return out
