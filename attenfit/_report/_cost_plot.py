"""Error against cost: one labelled point per model, the Pareto front drawn; and the report's
figure of it, the decision's error against the compiled cost of both model classes.

`plot_cost_vs_error` draws one panel from `errors` and `costs`. `decision_cost_figure`
draws the report's: a panel per light and band of the decision table, each model's error
there as the decision judges it (its worst case over every receiver of the band, the three
receiver sets together: `_verify.Verifier`), for the distance curves (circles) and the
area models (squares). Where the report did not search a model's worst case on a band
(the decision searches the candidates it names and their nearest rivals) the point is its
largest sampled error, a lower bound, drawn hollow. Points carry numbers; a key below the
panels names them, so that no label overlaps another.
"""

from __future__ import annotations

from collections.abc import Collection, Mapping
from typing import Any

import numpy as np

from .._shaders import Cost, pareto_front

__all__ = ["decision_cost_figure", "plot_cost_vs_error"]

_XLABELS = {
    "shader_cost": "shader cost (full-rate ALU instructions per evaluation)",
    "ns_per_eval": "measured time per evaluation (ns)",
    "ratio_to_inverse_square": "measured time relative to inverse-square",
}
_STYLE = {"font.size": 9, "axes.grid": True, "grid.alpha": 0.3, "axes.titlesize": 10}


def plot_cost_vs_error(
    errors: Mapping[str, float],
    costs: Mapping[str, float | Cost],
    *,
    by: str = "shader_cost",
    ax: Any = None,
    title: str | None = None,
    xlabel: str | None = None,
    ylim: tuple[float, float] = (1e-4, 1e2),
    ylabel: str = "max relative error",
    lower_bounds: Collection[str] = (),
    squares: Collection[str] = (),
    labels: Mapping[str, str] | None = None,
    legend: bool = True,
) -> tuple[Any, Any]:
    """Error against cost, log-log, one labelled point per model, the Pareto front drawn.

    Returns `(fig, ax)`; draws into `ax` when given. The error axis spans `ylim` (default
    0.01% to 10000%, the band that matters wide): smaller errors are drawn on its bottom edge
    as ▼, larger ones on its top edge as ▲; infinite ones are left out and named in the
    legend. `xlabel` names the cost (default: after `by`). Models in `lower_bounds` are drawn
    hollow (their error is at least that), those in `squares` as squares (another model
    class); `labels` replaces a model's name by a short label (a number of a key).
    """
    import matplotlib.pyplot as plt

    pf = pareto_front(errors, costs, by=by)
    finite = {k: v for k, v in pf.error.items() if np.isfinite(v)}
    with plt.rc_context(_STYLE):
        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 4.8), layout="constrained")
        else:
            fig = ax.figure
        xs = {k: max(pf.cost[k], 0.5) for k in finite}
        ys = {k: min(max(v, ylim[0]), ylim[1]) for k, v in finite.items()}
        _scatter(ax, finite, xs, ys, pf.front, ylim, set(lower_bounds), set(squares))
        _axes(ax, xs, ylim)
        groups: dict[tuple[float, float], list[str]] = {}
        for k in finite:  # models at the same point share one label
            groups.setdefault((xs[k], ys[k]), []).append((labels or {}).get(k, k))
        _place_labels(ax, groups, {(labels or {}).get(k, k) for k in pf.front})
        ax.set_xlabel(_XLABELS[by] if xlabel is None else xlabel)
        ax.set_ylabel(ylabel)
        bad = sorted(k for k, v in pf.error.items() if not np.isfinite(v))
        if bad:
            ax.plot([], [], " ", label=f"infinite error: {', '.join(bad)}")
        if legend:
            ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3, fontsize=7,
                      frameon=False)  # fmt: skip
        if title:
            ax.set_title(title)
    return fig, ax


def _scatter(ax, finite, xs, ys, front, ylim, hollow: set[str], squares: set[str]) -> None:
    """The points (grey dominated, red on the Pareto front; ▼/▲ off the axis) and the front."""
    floor, top = ylim
    off = [k for k in finite if k not in front]
    on = [k for k in front if k in finite]

    def marker(k: str) -> str:
        return (
            "v" if finite[k] < floor else "^" if finite[k] > top else "s" if k in squares else "o"
        )

    for group, colour, size, label in ((off, "0.45", 24, "dominated"),
                                       (on, "C3", 32, "Pareto front")):  # fmt: skip
        named = False
        for m in ("o", "s", "v", "^"):
            for fill in (True, False):
                ks = [k for k in group if marker(k) == m and (k not in hollow) == fill]
                if not ks:
                    continue
                ax.scatter([xs[k] for k in ks], [ys[k] for k in ks], s=size, marker=m,
                           facecolors=colour if fill else "none", edgecolors=colour, zorder=3,
                           clip_on=False, label=None if named else label)  # fmt: skip
                named = True
    if any(marker(k) in "v^" for k in finite):
        ax.plot([], [], " ", label=f"▼ below {100 * floor:g}%, ▲ above {100 * top:g}%: "
                "drawn on the edge")  # fmt: skip
    if on:
        ax.step([xs[k] for k in on], [ys[k] for k in on], where="post", color="C3", lw=1.2,
                zorder=2)  # fmt: skip


def _axes(ax, xs: Mapping[str, float], ylim: tuple[float, float]) -> None:
    """Log axes, the error in percent, cost ticks at 1-2-5."""
    from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_ylim(*ylim)
    lo_x, hi_x = min(xs.values(), default=1), max(xs.values(), default=10)
    ax.set_xlim(lo_x / 1.4, hi_x * 1.6)
    steps = [k * 10**e for e in range(4) for k in (1, 2, 5)]
    ticks = [t for t in steps if lo_x / 1.4 <= t <= hi_x * 1.6]
    ax.xaxis.set_major_locator(FixedLocator(ticks))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _p: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _p: f"{100 * v:g}%"))
    ax.yaxis.set_minor_formatter(NullFormatter())


def _place_labels(ax: Any, groups: Mapping[tuple[float, float], list[str]], front) -> None:
    """Label each point, moving a label up or down (in points) until it overlaps no other."""
    ax.autoscale_view()
    ax.figure.canvas.draw()  # settle the layout, so that the data-to-display transform holds
    to_pt = 72.0 / ax.figure.dpi
    frame = [v * to_pt for v in ax.get_window_extent().extents]
    placed: list[tuple[float, float, float, float]] = []
    for x, y in groups:  # the markers are obstacles too
        px, py = (v * to_pt for v in ax.transData.transform((x, y)))
        placed.append((px - 3, py - 3, px + 3, py + 3))
    offsets = [
        (side, dy) for dy in (3, -10, 10, -17, 17, -24, 24, -31, 31, -38, 38) for side in (1, -1)
    ]
    order = sorted(groups.items(), key=lambda item: (item[0][0], -item[0][1]))
    for (x, y), ks in order:
        text = ", ".join(ks)
        px, py = (v * to_pt for v in ax.transData.transform((x, y)))
        w, h = 4.3 * len(text), 8.0  # 7-point labels

        def box_of(o: tuple[int, float], px=px, py=py, w=w, h=h) -> tuple[float, ...]:
            side, dy = o
            left = px + 4 if side > 0 else px - 4 - w
            return (left, py + dy, left + w, py + dy + h)

        def clash(o: tuple[int, float]) -> float:
            box = box_of(o)
            out = max(0.0, frame[1] - box[1]) + max(0.0, box[3] - frame[3])
            out += max(0.0, box[2] - frame[2]) + max(0.0, frame[0] - box[0])
            area = sum(
                max(0.0, min(box[2], b[2]) - max(box[0], b[0]))
                * max(0.0, min(box[3], b[3]) - max(box[1], b[1]))
                for b in placed
            )
            return area + 100.0 * out

        best = min(offsets, key=lambda o: (clash(o), offsets.index(o)))
        placed.append(box_of(best))
        side, dy = best
        on_front = any(k in front for k in ks)
        label = ax.annotate(text, (x, y), xytext=(4 * side, dy), textcoords="offset points",
                            fontsize=7, color="C3" if on_front else "0.3",
                            ha="left" if side > 0 else "right",
                            arrowprops=None if dy == 3 else {"arrowstyle": "-", "color": "0.7", "lw": 0.5})  # fmt: skip
        label.set_in_layout(False)  # labels must not move the axes they were placed in


# ----------------------------------------------------------------------------- the report's
def _panel_errors(report, cfg) -> tuple[dict[str, Any], dict[str, dict[str, float]], dict]:
    """The published candidates of `cfg` (distance curves and area models) by name, their
    error per band (the searched worst case where known, else the sampled maximum) and which
    are lower bounds."""
    from ._area_candidates import area_candidates
    from ._decide import candidates
    from ._verify import Verifier

    check = Verifier(cfg)
    cands = {c.model: c for c in candidates(report, cfg) if c.mode == "published"}
    cands.update({c.model: c for c in area_candidates(cfg, report)})
    errors: dict[str, dict[str, float]] = {}
    bounds: dict[str, set[str]] = {}
    for name, c in cands.items():
        if c.cost is None:
            continue
        for band, err in c.errors.items():
            if err is None:
                continue
            w = check.known(c, band)
            errors.setdefault(band, {})[name] = err if w is None else w.error
            if w is None:
                bounds.setdefault(band, set()).add(name)
    return cands, errors, bounds


def decision_cost_figure(report) -> Any:
    """The decision's error against the compiled cost, a panel per light and band (see the
    module docstring), or None without lights judged on receivers or measured costs."""
    import matplotlib as mpl

    from . import _plots as plots
    from ._metrics import GAP_BAND_LABELS, GAP_BANDS

    lights = [c for c in report.configs if c.receivers]
    if not report.costs or not lights:  # costs not measured: no figure, as before
        return None
    data = [(cfg, *_panel_errors(report, cfg)) for cfg in lights]
    names = sorted({n for _, c, e, _ in data for band in e.values() for n in band},
                   key=lambda n: (any(c.get(n) and c[n].kind != "distance curve"
                                      for _, c, _, _ in data), n))  # fmt: skip
    if not names:
        return None
    number = {n: str(i) for i, n in enumerate(names, 1)}
    with mpl.rc_context(plots.STYLE):
        fig = plots.new_figure((6.0 * len(GAP_BANDS), 4.6 * len(lights) + 1.4))
        axes = fig.subplots(len(lights), len(GAP_BANDS), squeeze=False)
        for i, (cfg, cands, errors, bounds) in enumerate(data):
            for j, band in enumerate(GAP_BANDS):
                ax, errs = axes[i, j], errors.get(band, {})
                if not errs:
                    ax.set_visible(False)
                    continue
                squares = {n for n in errs if cands[n].kind != "distance curve"}
                plot_cost_vs_error(
                    errs, {n: float(cands[n].cost) for n in errs}, ax=ax, ylim=(1e-6, 1e2),
                    lower_bounds=bounds.get(band, set()), squares=squares, labels=number,
                    legend=False, xlabel="shader cost" if i == len(lights) - 1 else "",
                    ylabel="worst case (hollow: ≥ sampled max)" if j == 0 else "",
                    title=f"{cfg.name}, {GAP_BAND_LABELS[band]}",
                )  # fmt: skip
        key = "   ".join(f"{number[n]}\u00a0{n}" for n in names)
        how = ("● distance curve, ■ area model (published); filled: the worst case over the "
               "band (the judge), hollow: not searched, at least its largest sampled error; red: "
               "the Pareto front")  # fmt: skip
        fig.text(0.5, 0.005, how + "\n" + _wrap(key, 160), ha="center", va="bottom", fontsize=7)
        fig.get_layout_engine().set(rect=(0, 0.06, 1, 0.94))
    return fig


def _wrap(text: str, width: int) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width, break_on_hyphens=False))
