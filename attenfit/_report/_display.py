"""Irradiance as a player sees it: display-referred images and errors in stops.

A renderer judges by eye. A linear irradiance image is exposed (`exposure`), tone mapped by
the Khronos PBR Neutral tone mapper and encoded to sRGB for the display; a model's error is
shown in stops, `log2(E_model / E_true)`, on a fixed scale of +-1 stop (a stop is a doubling
of light: 0.1 stop is about the smallest step a viewer notices on a smooth gradient).
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from jaxtyping import ArrayLike

from ._plots import STYLE, new_figure

__all__ = [
    "STOPS_RANGE",
    "display",
    "exposure",
    "pbr_neutral",
    "plot_display_models",
    "srgb_encode",
    "stops",
    "stops_bound",
]

#: The error maps' fixed scale, +-stops (beyond it the colour saturates).
STOPS_RANGE = 1.0
#: The PBR Neutral constants: Fresnel at normal incidence, highlight compression start, and
#: desaturation speed (KhronosGroup/ToneMapping PBR_Neutral/README.md, "Specification").
_F90, _KS, _KD = 0.04, 0.8 - 0.04, 0.15


def pbr_neutral(x: ArrayLike) -> np.ndarray:
    """The Khronos PBR Neutral tone mapper on a grey linear value (R = G = B = x >= 0).

    KhronosGroup/ToneMapping `PBR_Neutral/README.md`, "PBR Neutral Specification" (and
    `pbrNeutral.glsl`, `PBRNeutralToneMapping`): `f = x - x^2 / (4 F90)` for `x <= 2 F90`,
    else `F90`; `p = x - f`; below `K_s` the result is `p`, above it the compressed peak
    `p_n = 1 - (1 - K_s)^2 / (p + 1 - 2 K_s)`. For a grey input the desaturation mix is the
    identity (every channel already equals `p_n`). Output: linear, in [0, 1).
    """
    x = np.maximum(np.asarray(x, dtype=np.float64), 0.0)
    f = np.where(x <= 2 * _F90, x - x * x / (4 * _F90), _F90)
    p = x - f
    pn = 1 - (1 - _KS) ** 2 / (p + 1 - 2 * _KS)
    return np.where(p <= _KS, p, pn)


def srgb_encode(v: ArrayLike) -> np.ndarray:
    """The sRGB transfer function (IEC 61966-2-1): linear [0, 1] to display-encoded [0, 1]."""
    v = np.clip(np.asarray(v, dtype=np.float64), 0.0, 1.0)
    return np.where(v <= 0.0031308, 12.92 * v, 1.055 * v ** (1 / 2.4) - 0.055)


def exposure(truth: ArrayLike) -> float:
    """The exposure that puts the 99th percentile of `truth`'s lit pixels at 1 (exposed for
    the highlights: the light's own pool keeps its shape, PBR Neutral rolls off above 0.76,
    and sRGB lifts the dim edges); the same for every image of one light."""
    t = np.asarray(truth, dtype=np.float64)
    lit = t[np.isfinite(t) & (t > 0)]
    return 1.0 / float(np.percentile(lit, 99)) if lit.size else 1.0


def display(E: ArrayLike, k: float) -> np.ndarray:
    """Irradiance `E` exposed by `k`, tone mapped and sRGB-encoded: what the screen shows."""
    return srgb_encode(pbr_neutral(k * np.nan_to_num(np.asarray(E, dtype=np.float64))))


def stops(model: ArrayLike, truth: ArrayLike) -> np.ndarray:
    """`log2(model / truth)`: 0 where both are 0, +-inf where only one is."""
    m = np.asarray(model, dtype=np.float64)
    t = np.asarray(truth, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.log2(m) - np.log2(t)
    return np.where((m <= 0) & (t <= 0), 0.0, out)


def stops_bound(rel: float | None) -> float | None:
    """The most stops a relative error of at most `rel` can be off: `-log2(1 - rel)` (the dark
    side is the larger), infinite from 100%."""
    if rel is None or not np.isfinite(rel):
        return None
    return float(-np.log2(1 - rel)) if rel < 1 else float("inf")


def plot_display_models(
    truth: ArrayLike,
    models: Mapping[str, ArrayLike],
    extent: tuple[float, float, float, float],
    *,
    truth_label: str = "truth",
    unit: str = "m",
    fig: Any = None,
):
    """The truth and each model as displayed (top row, one exposure for all), and each
    model's error in stops on the fixed +-`STOPS_RANGE` scale (bottom row). Returns
    `(fig, axes)` (2 x (1 + len(models)))."""
    import matplotlib as mpl

    with mpl.rc_context(STYLE):
        n = len(models)
        if fig is None:
            fig = new_figure((2.7 * (n + 1) + 1.2, 5.6))
        axes = np.atleast_2d(fig.subplots(2, n + 1, squeeze=False))
        t = np.asarray(truth, dtype=np.float64)
        k = exposure(t)
        shown = [(truth_label, t), *models.items()]
        for j, (label, img) in enumerate(shown):
            ax = axes[0, j]
            ax.imshow(display(img, k), origin="lower", extent=extent, cmap="gray", vmin=0, vmax=1)
            ax.set_title(label)
            ax.grid(False)
            ax.set_xlabel(f"x / {unit}" if unit != "m" else "x (m)")
        axes[0, 0].set_ylabel(f"y / {unit}" if unit != "m" else "y (m)")
        axes[1, 0].axis("off")
        axes[1, 0].text(
            0.0, 0.5,
            "Top: as displayed (exposure\n"
            f"{k:.3g}: the truth's 99th\n"
            "percentile at 1; Khronos\n"
            "PBR Neutral, sRGB).\n"
            "Bottom: error in stops,\n"
            "log2(model / truth).",
            fontsize=8, va="center", transform=axes[1, 0].transAxes,
        )  # fmt: skip
        im = None
        for j, (label, img) in enumerate(models.items(), start=1):
            ax = axes[1, j]
            s = np.clip(stops(img, t), -STOPS_RANGE, STOPS_RANGE)
            im = ax.imshow(s, origin="lower", extent=extent, cmap="RdBu_r",
                           vmin=-STOPS_RANGE, vmax=STOPS_RANGE)  # fmt: skip
            worst = float(np.nanmax(np.abs(stops(img, t))))
            most = f"{worst:.2g} stops" if worst >= 1e-3 else "< 0.001 stops"
            ax.set_title(f"{label}:\nmax {most}", fontsize=8)
            ax.grid(False)
            ax.set_xlabel(f"x / {unit}" if unit != "m" else "x (m)")
        if im is not None:
            fig.colorbar(im, ax=list(axes[1, 1:]), label="error (stops)", extend="both",
                         shrink=0.9)  # fmt: skip
    return fig, axes
