"""The figures of the comparison report (`attenfit.report.Report.write_figures`).

Built from `attenfit.plots`; one function per figure kind, each saving PNG (and SVG) and
closing its figure. Families are split into two panels, those without a range and the
windowed ones, so that no panel carries more than ten curves.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import plots

_WINDOWED = ("smooth", "hard")


def _save(fig, folder: Path, key: str, dpi: int, svg: bool, out: dict[str, Path]) -> None:
    import matplotlib as mpl

    png = folder / f"{key}.png"
    with mpl.rc_context(plots.STYLE):
        fig.savefig(png, dpi=dpi)
        if svg:
            fig.savefig(folder / f"{key}.svg")
    out[key] = png


def _split(report) -> tuple[list[str], list[str]]:
    from ._family import get_family

    plain, windowed = [], []
    for fam in report.families:
        try:
            w = get_family(fam).window
        except Exception:
            w = "none"
        (windowed if w in _WINDOWED else plain).append(fam)
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

    from .cost import plot_cost_vs_error

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
                title=f"{cfg.name}, {mode_text}: max |relative error| (in range) against cost",
            )
            used.add((i, j))
        for i in range(len(modes)):
            for j in range(len(sweeps)):
                if (i, j) not in used:
                    axes[i, j].set_visible(False)
    return fig


def draw_all(
    report, folder: Path, *, dpi: int = 100, svg: bool = True, progress=None
) -> dict[str, Path]:
    """Draw every figure of `report` into `folder`; return figure key -> PNG path."""
    out: dict[str, Path] = {}
    say = progress or (lambda s: None)
    for cfg in report.configs:
        say(f"figures: {cfg.name}")
        if cfg.sweep is not None:
            for mode in ("published", "fitted"):
                if not any(report._get(f, cfg.name, mode) for f in report.families):
                    continue
                _save(
                    _two_panel(report, cfg, mode, "attenuation"),
                    folder,
                    f"{cfg.name}_attenuation_{mode}",
                    dpi,
                    svg,
                    out,
                )
                _save(
                    _two_panel(report, cfg, mode, "error"),
                    folder,
                    f"{cfg.name}_error_{mode}",
                    dpi,
                    svg,
                    out,
                )
        if cfg.plane is not None:
            _save(_plane_errors(report, cfg), folder, f"{cfg.name}_plane_errors", dpi, svg, out)
            fig = _side_by_side(report, cfg)
            if fig is not None:
                _save(fig, folder, f"{cfg.name}_plane_side_by_side", dpi, svg, out)
    fig = _cost_vs_error(report)
    if fig is not None:
        _save(fig, folder, "cost_vs_error", dpi, svg, out)
    return out
