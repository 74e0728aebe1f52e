"""The report's section "what no distance curve can fix": the ceiling of the point-light model
and the area models that lift it (`ceiling_section`, the one entry point).

The numbers come from `_ceiling_eval.ceiling_table` (the best possible f(d) and every area
model, shipped and fitted, with its compiled cost); the figures are error against compiled
cost with both classes on it, and the floor under a one-sided disk at h = r/4 rendered:
truth, the best f(d), the best area model, and their error maps.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import matplotlib as mpl
import numpy as np

from ._ceiling_eval import (
    CEILING_CONFIGS,
    FLOOR,
    build_case,
    ceiling_table,
    cheapest_within,
    family_costs,
    predict,
)
from ._plots import STYLE

__all__ = ["ceiling_data", "ceiling_section"]

#: The max relative error the issue's goal asks of an area model.
GOAL = 0.01
#: Configurations on the error-against-cost figure.
COST_PANELS = ("disk_h0.25", "sphere_1-1.5", "sphere_10-100")
#: Below this a relative error is drawn (and written) as exact.
EXACT = 1e-6


def ceiling_data() -> dict[str, Any]:
    """Every number of the section, JSON-ready: `rows` (`ceiling_table`) and `family_costs`."""
    return {"rows": ceiling_table(), "family_costs": family_costs()}


def _pct(x: float) -> str:
    if not np.isfinite(x):
        return "-"
    if x < EXACT:
        return "exact"
    return f"{100 * x:.3g}%" if x < 10 else f"{x:.3g}×"


def _save(fig: Any, folder: Path, name: str, dpi: int, svg: bool) -> Path:
    path = folder / f"{name}.png"
    fig.savefig(path, dpi=dpi)
    if svg:
        fig.savefig(folder / f"{name}.svg")
    return path


def _cost_figure(data: Mapping[str, Any], folder: Path, dpi: int, svg: bool) -> Path:
    """Error against compiled cost, one column per configuration of `COST_PANELS`: max
    relative error (top) and max absolute error in units of the facing value (bottom)."""
    import matplotlib.pyplot as plt

    rows = {r["config"]: r for r in data["rows"]}
    fams = data["family_costs"]
    panels = [rows[k] for k in COST_PANELS if k in rows]
    lo, hi = min(fams.values()), max(fams.values())
    metrics = (("max_rel", "max relative error"), ("max_abs", "max abs. error / facing value"))
    with mpl.rc_context(STYLE):
        fig, axes = plt.subplots(
            2, len(panels), figsize=(4.6 * len(panels), 7.6), layout="constrained", squeeze=False
        )
        for col, row in enumerate(panels):
            for k, (key, what) in enumerate(metrics):
                ax = axes[k][col]
                ceil = max(row["best_fd"][key], EXACT)
                ax.fill_between([lo, hi], [ceil, ceil], [1e3, 1e3], color="tab:red", alpha=0.12)
                ax.plot([lo, hi], [ceil, ceil], color="tab:red", lw=2)
                ax.scatter(list(fams.values()), [ceil] * len(fams), marker="^", color="tab:red",
                           s=18, zorder=3, label="point-light model, any f(d) (on or above the line)")  # fmt: skip
                for i, m in enumerate(
                    sorted(row["models"], key=lambda m: (m["cost"], m["fitted"]))
                ):
                    y = max(m[key], EXACT)
                    face = "none" if m["fitted"] else "tab:blue"
                    ax.scatter([m["cost"]], [y], s=42, facecolors=face, edgecolors="tab:blue",
                               zorder=4)  # fmt: skip
                    label = m["name"] + (" (fitted)" if m["fitted"] else "")
                    dy = -11 if m["fitted"] else 4
                    ax.annotate(label, (m["cost"], y), xytext=(5, dy + 3 * (i % 2)),
                                textcoords="offset points", fontsize=7)  # fmt: skip
                if key == "max_rel":
                    ax.axhline(GOAL, color="gray", ls=":", lw=1, label="goal: 1%")
                    ax.set_title(row["title"], fontsize=9)
                ax.set_yscale("log")
                ax.set_ylim(EXACT / 2, 300)
                top = max(hi, *(m["cost"] for m in row["models"]))
                ax.set_xlim(0, top * 1.3)
                ax.set_xlabel("compiled cost (SPIR-V instructions)")
                ax.set_ylabel(f"{what} (bottom: exact)")
        ax0 = axes[0][0]
        ax0.scatter([], [], s=42, color="tab:blue", label="area model, shipped")
        ax0.scatter(
            [], [], s=42, facecolors="none", edgecolors="tab:blue", label="area model, fitted"
        )
        ax0.legend(loc="center right", fontsize=7)
        fig.suptitle("What no distance curve can fix: error against compiled cost, both model classes",
                     fontsize=10)  # fmt: skip
        path = _save(fig, folder, "ceiling_cost_vs_error", dpi, svg)
        plt.close(fig)
    return path


def _floor_figure(data: Mapping[str, Any], folder: Path, dpi: int, svg: bool) -> Path:
    """The floor under the disk at h = r/4: truth, best f(d), best area model, error maps."""
    import matplotlib.pyplot as plt

    from .._curves import get_area_model

    config = next(c for c in CEILING_CONFIGS if c.key == "disk_h0.25")
    row = next(r for r in data["rows"] if r["config"] == config.key)
    pick = cheapest_within(row, GOAL) or min(row["models"], key=lambda m: m["max_rel"])
    model = get_area_model(pick["name"])(**(pick["params"] if pick["fitted"] else {}))
    case = build_case(config)
    assert case.shape is not None and case.grid_index is not None
    ny, nx = case.shape

    def image(values: np.ndarray) -> np.ndarray:
        out = np.full(ny * nx, np.nan)
        out[case.grid_index] = values
        return out.reshape(ny, nx)

    area_pred = predict(case, model)
    ext = float(np.abs(case.points[:, 0]).max())
    extent = (-ext, ext, -ext, ext)
    peak = float(case.E.max())
    norm = mpl.colors.LogNorm(vmin=peak * 1e-4, vmax=peak)
    with mpl.rc_context(STYLE):
        fig, axes = plt.subplots(2, 3, figsize=(13, 8.2), layout="constrained")
        shows = [
            (case.E, "truth (exact irradiance)"),
            (case.best_fd, "best f(d): I g f*(d) max(0, n.l)"),
            (area_pred, f"area model: {pick['name']}"),
        ]
        for ax, (values, title) in zip(axes[0], shows, strict=True):
            im = ax.imshow(image(np.maximum(values, peak * 1e-6)), origin="lower",
                           extent=extent, norm=norm, cmap="magma")  # fmt: skip
            ax.set_title(title, fontsize=9)
            ax.set_xlabel("x / r")
            ax.set_ylabel("y / r")
        fig.colorbar(im, ax=axes[0], label="irradiance (I = 1, r = 1)", shrink=0.85)
        keep = case.E > FLOOR * case.facing
        for ax, values, name in (
            (axes[1][0], case.best_fd, "best f(d)"),
            (axes[1][1], area_pred, pick["name"]),
        ):
            rel = np.where(keep, np.abs(values - case.E) / np.where(keep, case.E, 1), np.nan)
            em = ax.imshow(image(np.log10(np.maximum(rel, 1e-8))), origin="lower", extent=extent,
                           vmin=-8, vmax=0, cmap="viridis")  # fmt: skip
            ax.set_title(
                f"log10 relative error, {name}: max {_pct(np.nanmax(rel))}\n"
                "(blank: below 0.1% of the facing value)",
                fontsize=8,
            )
            ax.set_xlabel("x / r")
            ax.set_ylabel("y / r")
        fig.colorbar(em, ax=axes[1][:2], label="log10 |relative error|", shrink=0.85)
        ax = axes[1][2]
        on_line = np.abs(case.points[:, 1]) < 1e-9
        x = case.points[on_line, 0]
        order = np.argsort(x)
        for values, label, style in (
            (case.E, "truth", {"color": "black", "lw": 3, "alpha": 0.4}),
            (case.best_fd, "best f(d)", {"color": "tab:red", "ls": "--"}),
            (area_pred, pick["name"], {"color": "tab:blue", "ls": ":"}),
        ):
            ax.plot(x[order], values[on_line][order], label=label, **style)
        ax.set_yscale("log")
        ax.set_xlabel("x / r (through the centre)")
        ax.set_ylabel("irradiance")
        ax.set_title("profile through the centre", fontsize=9)
        ax.legend(fontsize=8)
        fig.suptitle(f"{config.title}: the floor, {ny} × {nx} receivers", fontsize=10)
        path = _save(fig, folder, "ceiling_disk_floor", dpi, svg)
        plt.close(fig)
    return path


def _markdown(data: Mapping[str, Any], figures: Mapping[str, str]) -> str:
    rows = data["rows"]
    fams = data["family_costs"]
    label = rows[0]["models"][0]["cost_label"] if rows and rows[0]["models"] else "-"
    out = [
        "## What no distance curve can fix",
        "",
        "The point-light model `E = I g f(d) max(0, n.l)` has a ceiling that no `f(d)` lifts: "
        "its error lies in the angular factor. Below, its error with the best possible "
        "`f(d)` (the light's exact facing attenuation) against the area-light models "
        "(`attenfit.area`), which read the cosine at the receiver and the light's size. Max "
        "relative error over the receivers above 0.1% of their facing value; max absolute "
        "error in units of the facing value; energy ratio = predicted over exact irradiance "
        "summed over the receivers. Cost: " + label + "; the point-light model costs "
        f"{min(fams.values()):.0f}-{max(fams.values()):.0f} over the families (their shader "
        "form times `g max(0, n.l)`).",
        "",
        "| configuration | best f(d): max rel | max abs | energy | cheapest area model within 1% | cost | best cheaper area model: max rel, max abs, cost |",
        "|---|---:|---:|---:|---|---:|---|",
    ]
    for r in rows:
        b = r["best_fd"]
        ok = cheapest_within(r, GOAL)
        cheaper = [m for m in r["models"] if ok is None or m["cost"] < ok["cost"]]
        close = min(cheaper, key=lambda m: (m["max_rel"], m["max_abs"])) if cheaper else None
        name = lambda m: m["name"] + (" (fitted)" if m["fitted"] else "")  # noqa: E731
        best = (
            f"{name(close)}: {_pct(close['max_rel'])}, {_pct(close['max_abs'])}, {close['cost']:.0f}"
            if close
            else "-"
        )
        out.append(
            f"| {r['title']} | {_pct(b['max_rel'])} | {_pct(b['max_abs'])} | "
            f"{b['energy']:.3f} | {name(ok) if ok else 'none'} | "
            f"{format(ok['cost'], '.0f') if ok else '-'} | {best} |"
        )
    out += [""]
    for key, alt in (("ceiling_cost_vs_error", "error against cost"),
                     ("ceiling_disk_floor", "the floor under a disk")):  # fmt: skip
        if key in figures:
            out += [f"![{alt}]({figures[key]})", ""]
    out += ["### Every area model, per configuration", ""]
    for r in rows:
        out += [
            f"**{r['title']}** ({r['n']} receivers)",
            "",
            "| model | max rel | max abs | energy | cost | fitted parameters |",
            "|---|---:|---:|---:|---:|---|",
        ]
        for m in r["models"]:
            params = ", ".join(f"{k} = {v:.4g}" for k, v in m["params"].items())
            out.append(
                f"| {m['name']}{' (fitted)' if m['fitted'] else ''} | {_pct(m['max_rel'])} | "
                f"{_pct(m['max_abs'])} | {m['energy']:.3f} | {m['cost']:.0f} | "
                f"{params if m['fitted'] else ''} |"
            )
        out.append("")
    return "\n".join(out)


def ceiling_section(
    folder: str | Path | None = None,
    *,
    data: Mapping[str, Any] | None = None,
    dpi: int = 100,
    svg: bool = False,
) -> tuple[str, dict[str, Path], dict[str, Any]]:
    """The section "what no distance curve can fix": `(markdown, figures, data)`.

    `data` is `ceiling_data()` (computed when not given: two minutes on 2 cores, most of it
    the capsule's quadrature and the fits); figures are drawn into `folder` (none when None)
    and referenced in the markdown as `figures/<name>.png`.
    """
    data = dict(data) if data is not None else ceiling_data()
    figs: dict[str, Path] = {}
    if folder is not None:
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        figs["ceiling_cost_vs_error"] = _cost_figure(data, folder, dpi, svg)
        figs["ceiling_disk_floor"] = _floor_figure(data, folder, dpi, svg)
    rel = {k: f"figures/{v.name}" for k, v in figs.items()}
    return _markdown(data, rel), figs, data
