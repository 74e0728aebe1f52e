"""Yuksel 2020, Figure 3: inverse-square, eq. 7 and eq. 8 on the same axes, plus the true lights.

C. Yuksel, "Point Light Attenuation Without Singularity", SIGGRAPH 2020 Talks. Figure 3
compares the inverse-square law 1/d^2, the talk's non-singular attenuation (eq. 7)

    f(d) = 2/r^2 (1 - d / sqrt(d^2 + r^2)),

and the ad hoc softening it motivates (eq. 8), f(d) = 1/(d^2 + r^2/2). This script draws the
same three curves against d/r (linear axes, f in units of 1/r^2, where the three differ) and
on log-log axes (where they meet), and adds what the talk does not show: the exact
attenuation of the lights eq. 7 stands in for, a Lambertian sphere and a one-sided disk of
radius r and unit intensity (L = 1/(pi r^2), the talk's normalisation), with the receiver
facing the centre (`attenfit.irradiance`).

It prints the curves at a few d/r and checks the features the talk states: eq. 7 and
eq. 8 both equal 2/r^2 at d = 0; eq. 8 lies between eq. 7 and inverse square; all three
tend to 1/d^2 (f d^2 -> 1) for d >> r. Where the talk and the exact lights disagree: the
true facing disk is 1/(d^2 + r^2), so its value at 0 is 1/r^2, half of eq. 7's 2/r^2
(eq. 5 integrates the solid angle, not the cosine-weighted one), and the true sphere is
exactly 1/d^2 wherever it is wholly above the receiver's horizon (at most 1/r^2, touching).

Run: python examples/reproduce_yuksel_fig3.py [--out DIR] [--force]
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _example  # noqa: E402

import attenfit  # noqa: E402
from attenfit.plots import STYLE, new_figure  # noqa: E402

NAME = "reproduce_yuksel_fig3"
R = 1.0  # the light's radius; every number below is in units of r (f in 1/r^2)
_PAD = 2048  # the longest distance array any figure or check uses
PRINT_AT = (0.0, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0, 100.0)


@jax.jit
def _seed_curves(d: jax.Array, r: float) -> tuple[jax.Array, jax.Array, jax.Array]:
    return attenfit.InverseSquare()(d), attenfit.Yuksel(r=r)(d), attenfit.YukselAdhoc(r=r)(d)


def curves(d: np.ndarray, r: float = R) -> dict[str, np.ndarray]:
    """Inverse square, eq. 7, eq. 8 and the exact facing disk and sphere at distances `d`."""
    n = np.size(d)
    # Pad to a fixed length so that every call reuses one compiled program per light.
    d = np.concatenate([np.ravel(d).astype(np.float64), np.full(_PAD - n, 2.0 * r)])
    inv, eq7, eq8 = _seed_curves(d, r)
    out = {
        "inverse square": np.asarray(inv),
        "Yuksel eq. 7": np.asarray(eq7),
        "Yuksel eq. 8": np.asarray(eq8),
    }
    # The exact lights, unit intensity, receiver on the axis facing the centre.
    axis = np.array([0.0, 0.0, -1.0])
    points = d[:, None] * axis
    up = np.broadcast_to(-axis, points.shape)
    disk = attenfit.DiskEmitter(center=[0.0, 0.0, 0.0], normal=axis, radius=r)
    e_disk = np.asarray(attenfit.irradiance(disk, points, up))
    w_disk = np.asarray(disk.point_light(points, up)[1])
    safe_w = np.where(w_disk > 0, w_disk, 1.0)
    out["true disk (facing)"] = np.where(w_disk > 0, e_disk / safe_w, np.nan)
    # Inside the sphere there is no receiver: evaluate at a safe distance, then mask.
    sphere = attenfit.SphereEmitter(center=[0.0, 0.0, 0.0], radius=r)
    outside = d > r
    safe_points = np.where(outside[:, None], points, 2.0 * r * axis)
    e_sph = np.asarray(attenfit.irradiance(sphere, safe_points, up))
    out["true sphere (facing)"] = np.where(outside, e_sph, np.nan)  # I = 1, n.l = 1
    return {k: v[:n] for k, v in out.items()}


def features(r: float = R) -> dict[str, float]:
    """The talk's stated properties, measured on the library's curves."""
    d = np.concatenate([[0.0, 1e-9 * r, 1e3 * r], np.geomspace(1e-3 * r, 1e4 * r, 2001)])
    c = curves(d, r)
    fi, f7, f8 = c["inverse square"][3:], c["Yuksel eq. 7"][3:], c["Yuksel eq. 8"][3:]
    far = 1e3 * r
    return {
        "eq7_at_0_times_r2": float(c["Yuksel eq. 7"][0]) * r * r,
        "eq8_at_0_times_r2": float(c["Yuksel eq. 8"][0]) * r * r,
        "disk_at_0_times_r2": float(c["true disk (facing)"][1]) * r * r,
        "eq8_between_eq7_and_inverse_square": bool(np.all((f7 <= f8) & (f8 <= fi))),
        "min_gap_eq8_minus_eq7": float(np.min((f8 - f7) / fi)),
        "min_gap_inverse_square_minus_eq8": float(np.min((fi - f8) / fi)),
        "eq7_times_d2_at_1000r": float(c["Yuksel eq. 7"][2]) * far**2,
        "eq8_times_d2_at_1000r": float(c["Yuksel eq. 8"][2]) * far**2,
    }


def figure(r: float = R):
    """Figure 3 (linear axes) and its log-log companion, with the true disk and sphere."""
    import matplotlib as mpl

    d_lin = np.linspace(0.0, 4.0 * r, 801)
    d_log = np.geomspace(1e-2 * r, 1e2 * r, 801)
    styles = {
        "inverse square": {"color": "black", "linestyle": "-", "linewidth": 1.2},
        "Yuksel eq. 7": {"color": "tab:red", "linestyle": "-", "linewidth": 1.8},
        "Yuksel eq. 8": {"color": "tab:blue", "linestyle": "--", "linewidth": 1.8},
        "true disk (facing)": {"color": "tab:green", "linestyle": ":", "linewidth": 2.0},
        "true sphere (facing)": {"color": "tab:purple", "linestyle": "-.", "linewidth": 1.4},
    }
    with mpl.rc_context(STYLE):
        fig = new_figure((10.0, 4.0))
        ax_lin, ax_log = fig.subplots(1, 2)
        lin = curves(d_lin, r)
        for label, f in lin.items():
            with np.errstate(divide="ignore"):
                ax_lin.plot(d_lin / r, f * r * r, label=label, **styles[label])
        ax_lin.set_xlim(0.0, 4.0)
        ax_lin.set_ylim(0.0, 2.5)
        ax_lin.set_xlabel("distance d / r")
        ax_lin.set_ylabel("attenuation f(d) · r²")
        ax_lin.set_title("Yuksel 2020, Fig. 3 (r = 1), with the true lights")
        ax_lin.axhline(2.0, color="grey", linewidth=0.6, linestyle=":")
        ax_lin.annotate("2/r²", (3.6, 2.03), fontsize=8, color="grey")
        ax_lin.legend(loc="center right")
        log = curves(d_log, r)
        for label, f in log.items():
            ax_log.loglog(d_log / r, f * r * r, label=label, **styles[label])
        ax_log.set_xlabel("distance d / r")
        ax_log.set_ylabel("attenuation f(d) · r²")
        ax_log.set_title("the same, log-log: all tend to 1/d²")
        ax_log.axvline(1.0, color="grey", linewidth=0.6, linestyle=":")
    return fig


def main(argv: Sequence[str] | None = None) -> dict:
    args = _example.parse_args(_example.parser(NAME, __doc__.splitlines()[0]), argv)
    d = np.array(PRINT_AT) * R
    values = curves(d)
    feats = features()
    rows = [[float(x)] + [float(values[k][i]) for k in values] for i, x in enumerate(PRINT_AT)]
    print("f(d) r^2 at a few d/r (r = 1; NaN: inside the sphere)")
    print(_example.table(rows, ["d/r", *values]))
    for key, val in feats.items():
        print(f"{key}: {val}")
    numbers = {
        "r": R,
        "d_over_r": list(PRINT_AT),
        "values": {k: v.tolist() for k, v in values.items()},
        "features": feats,
    }
    with _example.output_folder(args) as tmp:
        _example.save_figure(figure(), tmp, "yuksel_fig3")
        _example.write_numbers(tmp, numbers)
    print(f"wrote {args.out}")
    return numbers


if __name__ == "__main__":
    _example.run(main)
