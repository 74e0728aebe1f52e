"""Figures of the comparison report: curves against the truth, errors, and rendered planes.

Every function takes an optional `ax=` (or `fig=` for the multi-panel ones), returns
`(fig, ax)` (`ax` an array of axes for a multi-panel figure), styles itself through a local
`matplotlib.rc_context` and never calls `show()`. Distances are in metres and attenuation in
1/m^2 (docs/architecture.md, Conventions: a unit-intensity light). They use only NumPy and Matplotlib, so
they work on any backend, including Agg.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from jaxtyping import ArrayLike

from .._errors import BadValueError
from ._metrics import relative_error

#: The rc settings every figure is drawn with (small but readable at 100%).
STYLE: Mapping[str, Any] = {
    "font.size": 9,
    "axes.titlesize": 10,
    "axes.labelsize": 9,
    "legend.fontsize": 8,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.grid": True,
    "grid.alpha": 0.3,
    "grid.linewidth": 0.5,
    "lines.linewidth": 1.4,
    "figure.dpi": 100,
    "savefig.dpi": 110,
    "svg.fonttype": "none",
    "image.interpolation": "nearest",
}

#: At most six curves a panel, each with its own colour (Okabe-Ito, told apart by colour-blind
#: readers too) and its own line style.
GROUP = 6
_COLOURS = ("#0072B2", "#E69F00", "#009E73", "#D55E00", "#CC79A7", "#56B4E9")
_LINESTYLES = ("-", "--", "-.", ":", (0, (6, 1.5, 1, 1.5, 1, 1.5)), (0, (1, 1)))
_TRUTH_STYLE = {"color": "black", "linewidth": 2.6, "zorder": 1}
_ERR_LABEL = "relative error (model − truth) / truth"


def _tick_text(v: float, _pos: Any = None) -> str:
    """Plain tick labels for log axes ("0.01", "1e-6"): no mathtext, which is slow to lay out."""
    if v == 0:
        return "0"
    a = abs(v)
    sign = "−" if v < 0 else ""
    e = np.log10(a)
    if abs(e - round(e)) < 1e-9:
        e = round(e)
        return sign + (f"{a:g}" if -3 <= e <= 3 else f"1e{e}")
    return sign + f"{a:.3g}"


def plain_log_ticks(axis: Any) -> None:
    """Use `_tick_text` labels on a log or symlog `axis`: the decades, and the minor ticks
    too where the view spans less than a decade (else a narrow axis has no label at all).

    The minor labels are made a whole axis at a time (`Formatter.format_ticks`, the view's
    span read once): a report's figure asks for them some 60 times per axis while it lays
    out, each time for every minor tick."""
    from matplotlib.ticker import Formatter, FuncFormatter

    class _Minor(Formatter):
        def __call__(self, v: float, pos: Any = None) -> str:
            return self.format_ticks([v])[0]

        def format_ticks(self, values) -> list[str]:
            lo, hi = sorted(abs(x) for x in axis.get_view_interval())
            span = hi / lo if lo > 0 else np.inf
            if span >= 10:
                return [""] * len(values)
            return [_minor_text(v, span) for v in values]

    axis.set_major_formatter(FuncFormatter(_tick_text))
    axis.set_minor_formatter(_Minor())


def _minor_text(v: float, span: float) -> str:
    """A minor tick's label on an axis spanning `span` (< 10): every one below a span of 3,
    else those at 2 and 5 times a decade."""
    if v == 0:
        return ""
    mantissa = round(abs(v) / 10 ** np.floor(np.log10(abs(v))), 6)
    return _tick_text(v) if span < 3 or mantissa in (2.0, 5.0) else ""


def curve_styles(labels: Sequence[str]) -> dict[str, dict[str, Any]]:
    """A colour and a line style per label, both distinct within every run of `GROUP` (6)
    labels (draw at most six curves a panel), stable for a given list of labels."""
    return {
        lab: {"color": _COLOURS[i % GROUP], "linestyle": _LINESTYLES[i % GROUP]}
        for i, lab in enumerate(labels)
    }


def new_figure(figsize: tuple[float, float]):
    """A constrained-layout `Figure` outside pyplot (no global state, works on any backend)."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, layout="constrained")


def _new_ax(ax, figsize):
    if ax is None:
        fig = new_figure(figsize)
        ax = fig.subplots()
    else:
        fig = ax.figure
    return fig, ax


def _finite_positive(y: np.ndarray) -> np.ndarray:
    y = np.asarray(y, dtype=np.float64)
    return np.where(np.isfinite(y) & (y > 0), y, np.nan)


def _legend(ax, where: str) -> None:
    """Place the legend "right" of or "below" the axes (never over the data), or "best" inside."""
    if not ax.get_legend_handles_labels()[0]:
        return
    if where == "right":
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    elif where == "below":
        ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), frameon=False, ncol=2)
    elif where == "best":
        ax.legend(loc="best", framealpha=0.85)
    elif where != "none":
        raise BadValueError(f"legend must be 'right', 'below', 'best' or 'none', got {where!r}")


def _finish_log_axes(ax, xlabel: str, ylabel: str, title: str | None, legend: str) -> None:
    """Plain tick labels on both (log or symlog) axes, the axis labels, the title and the legend."""
    plain_log_ticks(ax.xaxis)
    plain_log_ticks(ax.yaxis)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    if title:
        ax.set_title(title)
    _legend(ax, legend)


def plot_attenuation(
    d: ArrayLike,
    curves: Mapping[str, ArrayLike],
    truth: ArrayLike | None = None,
    *,
    r: float | None = None,
    truth_label: str = "truth",
    truth_points: tuple[ArrayLike, ArrayLike, ArrayLike | None] | None = None,
    truth_points_label: str = "truth (Monte Carlo)",
    styles: Mapping[str, Mapping[str, Any]] | None = None,
    title: str | None = None,
    legend: str = "right",
    ax=None,
):
    """Attenuation `f(d)` against distance, log-log, each curve against the truth.

    `curves` maps a label to f at the distances `d` (m); `truth` is the true attenuation there
    (black). `truth_points` = (d, f, stderr or None) adds sampled truth (e.g. Mitsuba) as
    points with error bars. With the light's radius `r` the x axis is d / r (the report's one
    convention) and says r; without it, d in m. Zeros (a window beyond its range) are not
    drawn on the log axis. Returns `(fig, ax)`.
    """
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        fig, ax = _new_ax(ax, (7.5, 4.2))
        scale = 1.0 if r is None else float(r)
        d = np.asarray(d, dtype=np.float64) / scale
        if truth is not None:
            ax.plot(d, _finite_positive(truth), label=truth_label, **_TRUTH_STYLE)
        sty = dict(styles or curve_styles(list(curves)))
        for lab, y in curves.items():
            ax.plot(d, _finite_positive(y), label=lab, **sty.get(lab, {}))
        if truth_points is not None:
            pd, pf, ps = truth_points
            ax.errorbar(
                np.asarray(pd) / scale,
                np.asarray(pf),
                yerr=None if ps is None else 2 * np.asarray(ps),
                fmt="o",
                ms=3,
                color="black",
                label=truth_points_label,
                zorder=5,
            )
        if r is not None:
            ax.axvline(1.0, color="0.3", linewidth=0.8, linestyle=":")
            ax.annotate(
                "d = r",
                (1.0, 0.02),
                xycoords=("data", "axes fraction"),
                rotation=90,
                va="bottom",
                ha="right",
                fontsize=8,
                color="0.3",
            )
        ax.set_xscale("log")
        ax.set_yscale("log")
        xlabel = (
            "distance from the light's centre d (m)"
            if r is None
            else f"distance from the light's centre in radii, d / r (r = {r:g} m)"
        )
        _finish_log_axes(ax, xlabel, "attenuation f(d) (1/m²)", title, legend)
    return fig, ax


def plot_relative_error(
    d: ArrayLike,
    curves: Mapping[str, ArrayLike],
    truth: ArrayLike,
    *,
    r: float,
    styles: Mapping[str, Mapping[str, Any]] | None = None,
    title: str | None = None,
    ylim: tuple[float, float] = (1e-3, 10.0),
    legend: str = "right",
    ax=None,
):
    """|Relative error| `|f - truth| / truth` of each curve against `d / r`, log-log.

    The y axis spans `ylim` (default 0.1% to 1000%): smaller errors (exact to rounding) are
    drawn on its bottom edge, larger ones (and infinite ones) on its top edge, each marked
    there with a triangle in the curve's colour (▲ too large, ▼ too small). Returns
    `(fig, ax)`.
    """
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        fig, ax = _new_ax(ax, (7.5, 4.2))
        x = np.asarray(d, dtype=np.float64) / float(r)
        lo, hi = ylim
        sty = dict(styles or curve_styles(list(curves)))
        for lab, y in curves.items():
            rel = np.abs(relative_error(y, truth))
            shown = np.clip(np.where(np.isinf(rel), hi, rel), lo, hi)
            st = sty.get(lab, {})
            ax.plot(x, shown, label=lab, **st)
            for sel, y_edge, marker in ((rel > hi, hi, "^"), (rel < lo, lo, "v")):
                idx = np.flatnonzero(sel & ~np.isnan(rel))
                if idx.size:
                    idx = idx[:: max(1, idx.size // 8)]
                    ax.plot(
                        x[idx], np.full(idx.size, y_edge), linestyle="none", marker=marker,
                        ms=5, color=st.get("color"), clip_on=False, zorder=4,
                    )  # fmt: skip
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_ylim(lo, hi)
        ax.yaxis.set_major_formatter(mpl.ticker.FuncFormatter(lambda v, _p: f"{100 * v:g}%"))
        ax.yaxis.set_minor_formatter(mpl.ticker.NullFormatter())
        plain_log_ticks(ax.xaxis)
        ax.set_xlabel(f"distance from the light's centre in radii, d / r (r = {r:g} m)")
        ax.set_ylabel("|relative error| (▲ above, ▼ below the axis)")
        if title:
            ax.set_title(title)
        _legend(ax, legend)
    return fig, ax


def plot_plane_image(
    E: ArrayLike,
    extent: tuple[float, float, float, float],
    *,
    vmin: float | None = None,
    vmax: float | None = None,
    title: str | None = None,
    colorbar: bool = True,
    unit: str = "m",
    ax=None,
):
    """Irradiance on a receiving plane as an image, log colour scale (W/m² for a 1 W/sr light).

    `E[i, j]` is the irradiance at row i (y) and column j (x); `extent` = (x0, x1, y0, y1) in
    `unit` (m, or "r" for light radii). The colour scale (inferno, perceptual) spans
    `vmin`..`vmax` (default: four decades below the peak); brighter pixels saturate at the top
    colour (draw the colour bar with `extend="max"`). Returns `(fig, ax)`.
    """
    import matplotlib as mpl
    from matplotlib.colors import LogNorm

    with mpl.rc_context(STYLE):
        fig, ax = _new_ax(ax, (4.0, 3.4))
        e = np.asarray(E, dtype=np.float64)
        vmax = float(np.nanmax(e)) if vmax is None else vmax
        vmin = vmax * 1e-4 if vmin is None else vmin
        shown = np.where(e > vmin, e, vmin)
        im = ax.imshow(
            shown,
            origin="lower",
            extent=extent,
            norm=LogNorm(vmin=vmin, vmax=vmax),
            cmap="inferno",
        )
        ax.set_xlabel(f"x ({unit})" if unit == "m" else f"x / {unit}")
        ax.set_ylabel(f"y ({unit})" if unit == "m" else f"y / {unit}")
        ax.grid(False)
        if title:
            ax.set_title(title)
        if colorbar:
            plain_log_ticks(
                fig.colorbar(im, ax=ax, label="irradiance E (W/m²)", shrink=0.9).ax.yaxis
            )
    return fig, ax


def plot_error_map(
    rel: ArrayLike,
    extent: tuple[float, float, float, float],
    *,
    vmax: float = 1.0,
    linthresh: float | None = 1e-2,
    title: str | None = None,
    colorbar: bool = True,
    unit: str = "m",
    ax=None,
):
    """A diverging map of a plane image's relative error, centred on 0 (white = exact).

    Blue is too dark (-1 = black), red too bright; errors beyond +-`vmax` saturate (the colour
    bar's arrows). The colour scale is symmetric-log, linear within +-`linthresh` (so errors
    of a few percent still show), or linear throughout with `linthresh=None`. Returns `(fig, ax)`.
    """
    import matplotlib as mpl
    from matplotlib.colors import Normalize, SymLogNorm

    with mpl.rc_context(STYLE):
        fig, ax = _new_ax(ax, (4.0, 3.4))
        norm = (
            Normalize(vmin=-vmax, vmax=vmax)
            if linthresh is None
            else SymLogNorm(linthresh=linthresh, linscale=0.5, vmin=-vmax, vmax=vmax, base=10)
        )
        im = ax.imshow(
            np.asarray(rel, dtype=np.float64),
            origin="lower",
            extent=extent,
            cmap="RdBu_r",
            norm=norm,
        )
        ax.set_xlabel(f"x ({unit})" if unit == "m" else f"x / {unit}")
        ax.set_ylabel(f"y ({unit})" if unit == "m" else f"y / {unit}")
        ax.grid(False)
        if title:
            ax.set_title(title)
        if colorbar:
            cb = fig.colorbar(im, ax=ax, label=_ERR_LABEL, extend="both", shrink=0.9)
            plain_log_ticks(cb.ax.yaxis)
    return fig, ax


def _image_rel(model: np.ndarray, truth: np.ndarray, floor: float = 1e-6) -> np.ndarray:
    peak = np.nanmax(truth)
    return (model - truth) / np.maximum(truth, floor * peak)


def plot_side_by_side(
    truth: ArrayLike,
    model: ArrayLike,
    extent: tuple[float, float, float, float],
    *,
    label: str = "model",
    truth_label: str = "truth",
    vmax_error: float = 1.0,
    fig=None,
):
    """Truth, model and their error map side by side (Madams 2011's comparison, generalised).

    Both images share one log colour scale. Returns `(fig, axes)` with three axes.
    """
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        if fig is None:
            fig = new_figure((11.5, 3.3))
        axes = fig.subplots(1, 3)
        t = np.asarray(truth, dtype=np.float64)
        m = np.asarray(model, dtype=np.float64)
        vmax = float(np.nanmax(t))
        plot_plane_image(t, extent, vmax=vmax, title=truth_label, ax=axes[0], colorbar=False)
        _, ax1 = plot_plane_image(m, extent, vmax=vmax, title=label, ax=axes[1], colorbar=False)
        cb = fig.colorbar(ax1.images[0], ax=axes[:2], label="irradiance E (W/m²)", shrink=0.9)
        plain_log_ticks(cb.ax.yaxis)
        plot_error_map(
            _image_rel(m, t), extent, vmax=vmax_error, title=f"{label}: error", ax=axes[2]
        )
    return fig, axes


def plot_plane_comparison(
    truth: ArrayLike,
    models: Mapping[str, ArrayLike],
    extent: tuple[float, float, float, float],
    *,
    truth_label: str = "truth",
    ncols: int = 5,
    vmax_error: float = 1.0,
    unit: str = "m",
    fig=None,
):
    """The true plane image followed by one error map per model, on a grid with shared colour bars.

    Returns `(fig, axes)` (a 2-D array of axes; unused cells are hidden).
    """
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        n = len(models) + 1
        ncols = max(1, min(ncols, n))
        nrows = -(-n // ncols)
        if fig is None:
            fig = new_figure((2.3 * ncols + 1.4, 2.25 * nrows + 0.3))
        axes = np.atleast_2d(fig.subplots(nrows, ncols, squeeze=False))
        flat = axes.ravel()
        t = np.asarray(truth, dtype=np.float64)
        _, a0 = plot_plane_image(
            t, extent, title=truth_label, ax=flat[0], colorbar=False, unit=unit
        )
        plain_log_ticks(
            fig.colorbar(a0.images[0], ax=flat[0], label="E (W/m²)", shrink=0.85).ax.yaxis
        )
        last = None
        for ax, (lab, img) in zip(flat[1:], models.items(), strict=False):
            _, ax = plot_error_map(
                _image_rel(np.asarray(img, dtype=np.float64), t),
                extent,
                vmax=vmax_error,
                title=lab,
                ax=ax,
                colorbar=False,
                unit=unit,
            )
            last = ax
        for ax in flat[n:]:
            ax.set_visible(False)
        for i, ax in enumerate(flat[:n]):
            ax.locator_params(nbins=3)
            if i % ncols:
                ax.set_ylabel("")
            if i < n - ncols:
                ax.set_xlabel("")
        if last is not None:
            cb = fig.colorbar(
                last.images[0],
                ax=list(flat[1:n]),
                label=_ERR_LABEL,
                extend="both",
                shrink=0.6,
                aspect=30,
            )
            plain_log_ticks(cb.ax.yaxis)
    return fig, axes
