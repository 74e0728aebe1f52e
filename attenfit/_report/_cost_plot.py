"""Error against cost: one labelled point per family, the Pareto front drawn."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from .._shaders import Cost, pareto_front

__all__ = ["plot_cost_vs_error"]


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
) -> tuple[Any, Any]:
    """Error against cost, log-log, one labelled point per family, the Pareto front drawn.

    Returns `(fig, ax)`; draws into `ax` when given. The error axis spans `ylim` (default
    0.01% to 10000%, the band that matters wide): smaller errors are drawn on its bottom edge
    as ▼, larger ones on its top edge as ▲; infinite ones are left out and named in the
    legend. `xlabel` names the cost (default: after `by`).
    """
    import matplotlib.pyplot as plt

    pf = pareto_front(errors, costs, by=by)
    finite = {k: v for k, v in pf.error.items() if np.isfinite(v)}
    floor, top = ylim
    xlabel = (
        {
            "shader_cost": "shader cost (full-rate ALU instructions per evaluation)",
            "ns_per_eval": "measured time per evaluation (ns)",
            "ratio_to_inverse_square": "measured time relative to inverse-square",
        }[by]
        if xlabel is None
        else xlabel
    )
    style = {"font.size": 9, "axes.grid": True, "grid.alpha": 0.3, "axes.titlesize": 10}
    with plt.rc_context(style):
        if ax is None:
            fig, ax = plt.subplots(figsize=(7, 4.8), layout="constrained")
        else:
            fig = ax.figure
        xs = {k: max(pf.cost[k], 0.5) for k in finite}
        ys = {k: min(max(v, floor), top) for k, v in finite.items()}
        off = [k for k in finite if k not in pf.front]
        on = [k for k in pf.front if k in finite]

        def marker(k: str) -> str:
            return "v" if finite[k] < floor else "^" if finite[k] > top else "o"

        for group, colour, size, label in ((off, "0.45", 24, "dominated"),
                                           (on, "C3", 32, "Pareto front")):  # fmt: skip
            named = False
            for m in ("o", "v", "^"):
                ks = [k for k in group if marker(k) == m]
                if ks:
                    ax.scatter([xs[k] for k in ks], [ys[k] for k in ks], c=colour, s=size,
                               marker=m, zorder=3, clip_on=False,
                               label=None if named else label)  # fmt: skip
                    named = True
        if any(marker(k) != "o" for k in finite):
            ax.plot([], [], " ", label=f"▼ below {100 * floor:g}%, ▲ above {100 * top:g}%: "
                    "drawn on the edge")  # fmt: skip
        if on:
            fx, fy = [xs[k] for k in on], [ys[k] for k in on]
            ax.step(fx, fy, where="post", color="C3", lw=1.2, zorder=2)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(floor, top)
        from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

        lo_x, hi_x = min(xs.values(), default=1), max(xs.values(), default=10)
        ax.set_xlim(lo_x / 1.4, hi_x * 1.6)
        ticks = [t for t in (1, 2, 5, 10, 20, 50, 100, 200, 500) if lo_x / 1.4 <= t <= hi_x * 1.6]
        ax.xaxis.set_major_locator(FixedLocator(ticks))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _p: f"{v:g}"))
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _p: f"{100 * v:g}%"))
        ax.yaxis.set_minor_formatter(NullFormatter())
        groups: dict[tuple[float, float], list[str]] = {}
        for k in finite:  # families at the same point share one label
            groups.setdefault((xs[k], ys[k]), []).append(k)
        _place_labels(ax, groups, pf.front)
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        bad = sorted(k for k, v in pf.error.items() if not np.isfinite(v))
        if bad:
            ax.plot([], [], " ", label=f"infinite error: {', '.join(bad)}")
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.13), ncol=3, fontsize=7,
                  frameon=False)  # fmt: skip
        if title:
            ax.set_title(title)
    return fig, ax


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
