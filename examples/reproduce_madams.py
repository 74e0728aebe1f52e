"""Madams 2011, both posts: the spherical-light curve, its cutoff, four lights, and smooth windows.

T. Madams, "Light attenuation" (2011-01-31) and "Improved light attenuation" (2011-02-10),
imdoingitwrong.wordpress.com. Three figures:

1. `madams_curve.png`, the first post's curve: a sphere light of radius r seen from a point
   facing it, f_att = 1/(d/r + 1)^2 with d measured from the light's *surface* (normalised
   to 1 at the surface), against the exact sphere (`attenfit.irradiance`) and a Mitsuba
   Monte Carlo estimate (the post's path tracer); with the scale-and-bias cutoff
   (f_att - Ic)/(1 - Ic), clamped at 0, for the post's thresholds Ic = 0.001 and 0.005,
   which reaches 0 at d_max = r (sqrt(Li/Ic) - 1) (Li = 1).
2. `madams_four_lights.png`, the post's render of four sphere lights above a plane: Mitsuba's
   Monte Carlo irradiance (the plane and the lights occlude, so shadows are Mitsuba's)
   against the analytic curve times the cosine (the post's GLSL `DirectIllumination`), the
   difference image on a diverging colour map (red where the analytic render is too bright:
   the shadow one light casts on the plane from another, "an area of the plane to the far
   left is slightly too bright due to a lack of a shadowing term"), and the cutoff renders
   with the unlit areas in red (Ic = 0.001 and 0.005).
3. `madams_windows.png`, the second post: the scale-and-bias curve against the tan warp
   d' = (2 d_max/pi) tan(pi d/(2 d_max)) and the rational warp d' = d/(1 - (d/d_max)^2),
   for r = 1 and d_max = 2.1 pi/2 (where the post's constant 2.1 equals 2 d_max/pi), with
   the slope of each at d_max from `jax.grad`: non-zero for the bias, zero for the warps.

Run: python examples/reproduce_madams.py [--out DIR] [--force] [--quick] [--variant NAME]
"""

from __future__ import annotations

import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _example  # noqa: E402

import attenfit  # noqa: E402
from attenfit.plots import STYLE, new_figure, plot_plane_image  # noqa: E402

NAME = "reproduce_madams"
CUTOFFS = (0.001, 0.005)  # the first post's two thresholds

# Four sphere lights of unit intensity above the plane z = 0: (x, y, z), radius. The second
# light sits lower and wider between the first and the far left of the plane, so it shadows
# the first light's illumination there (the region the post points at).
LIGHTS = (
    ((-0.3, 0.35, 1.6), 0.07),
    ((-1.0, 0.2, 0.9), 0.14),
    ((0.6, -0.8, 0.55), 0.09),
    ((1.6, 0.9, 0.8), 0.08),
)
HALF_SIZE = 3.5  # the plane's square is [-3.5, 3.5]^2 m
SIGNIFICANT = 0.1  # a shadow counts where the hidden light gives >= 10% of the unshadowed total


# ----------------------------------------------------------------------------- 1. the curve
def madams_att(d_s: np.ndarray, r: float) -> np.ndarray:
    """The post's f_att = 1/(d_s/r + 1)^2 (surface distance, 1 at the surface), via the library.

    `attenfit.MadamsSphere` is this curve divided by r^2 and taken at the centre distance
    d_s + r (docs/architecture.md, Conventions), so f_att = r^2 madams_sphere(d_s + r).
    """
    return r * r * np.asarray(attenfit.MadamsSphere(r=r)(jnp.asarray(d_s + r)))


def cutoff_att(d_s: np.ndarray, r: float, c: float) -> np.ndarray:
    """The post's scale and bias, max(0, (f_att - c)/(1 - c)), via `attenfit.MadamsCutoff`."""
    return r * r * np.asarray(attenfit.MadamsCutoff(r=r, cutoff=c)(jnp.asarray(d_s + r)))


def d_max_post(r: float, c: float, li: float = 1.0) -> float:
    """The post's maximum distance of influence (from the surface), r (sqrt(Li/Ic) - 1)."""
    return r * (math.sqrt(li / c) - 1.0)


def curve_truth(r: float, spp: int, variant: str) -> dict:
    """The exact sphere on a facing sweep, and Mitsuba's estimate at a few of its distances."""
    sphere = attenfit.SphereEmitter(center=[0.0, 0.0, 0.0], radius=r)
    exact = attenfit.facing_sweep(sphere, 1.01 * r, 60.0 * r, n=200, dtype=jnp.float64)
    out = {"d_s": exact.distance() - r, "exact": r * r * exact.attenuation()}
    try:
        from data_gen import render_dataset
    except ImportError:  # Mitsuba not installed: the exact truth stands alone
        return out
    sparse = attenfit.facing_sweep(sphere, 1.05 * r, 40.0 * r, n=10, dtype=jnp.float64)
    mc = render_dataset(sparse, spp=spp, seed=1, variant=variant)
    w = np.asarray(mc.weight())
    out["mc_d_s"] = np.asarray(mc.distance()) - r
    out["mc"] = r * r * np.asarray(mc.E) / w
    out["mc_stderr"] = r * r * np.asarray(mc.stderr) / w
    out["variant"] = mc.provenance.get("variant")
    return out


def curve_figure(truth: dict, r: float):
    import matplotlib as mpl

    d_s = np.linspace(0.0, 40.0 * r, 801)
    with mpl.rc_context(STYLE):
        fig = new_figure((10.0, 4.0))
        ax_lin, ax_log = fig.subplots(1, 2)
        for ax, log in ((ax_lin, False), (ax_log, True)):
            x = d_s[1:] if log else d_s
            ax.plot(truth["d_s"] / r, truth["exact"], color="black", lw=3.2, alpha=0.3,
                    label="exact sphere (attenfit.irradiance)")  # fmt: skip
            ax.plot(x / r, madams_att(x, r), color="tab:blue", label="1/(d/r + 1)²")
            for c, colour in zip(CUTOFFS, ("tab:red", "tab:orange"), strict=True):
                ax.plot(x / r, cutoff_att(x, r, c), color=colour, ls="--",
                        label=f"scale and bias, Ic = {c:g}")  # fmt: skip
                ax.axvline(d_max_post(r, c) / r, color=colour, lw=0.7, ls=":")
            if "mc" in truth:
                ax.errorbar(truth["mc_d_s"] / r, truth["mc"], yerr=2 * truth["mc_stderr"],
                            fmt="o", ms=3.5, color="black", capsize=2,
                            label=f"Mitsuba Monte Carlo (±2σ, {truth['variant']})")  # fmt: skip
            ax.set_xlabel("distance from the light's surface d / r")
            ax.set_ylabel("f_att (1 at the surface)")
        ax_lin.set_xlim(0, 15)
        ax_lin.set_ylim(0, 1.02)
        ax_lin.set_title("Madams 2011: sphere light, r = 1, and the cutoff")
        ax_lin.legend(loc="upper right")
        ax_log.set_xscale("log")
        ax_log.set_yscale("log")
        ax_log.set_ylim(1e-4, 1.5)
        ax_log.set_title("log-log: the cutoffs end at d_max = r (√(Li/Ic) − 1) (dotted)")
    return fig


# ----------------------------------------------------------------------------- 2. four lights
def _emitters() -> list:
    return [attenfit.SphereEmitter(center=c, radius=r) for c, r in LIGHTS]


def analytic_image(points: np.ndarray, normals: np.ndarray, family_of) -> np.ndarray:
    """Sum over the lights of I f(d) max(0, n.l): the post's `DirectIllumination`, unshadowed."""
    total = np.zeros(len(points))
    for em in _emitters():
        d, weight = em.point_light(points, normals)
        total += np.asarray(weight) * np.asarray(family_of(float(em.radius))(d))
    return total


def shadow_mask(
    points: np.ndarray, normals: np.ndarray, pairs: Sequence[tuple[int, int]] | None = None
) -> np.ndarray:
    """Receivers where a light that matters is (partly) hidden behind another, by geometry alone.

    Light j is partly hidden behind light k when k is nearer and the angular discs of the
    two spheres seen from the receiver overlap: angle(c_j, c_k) < asin(r_j/d_j) + asin(r_k/d_k).
    It matters where light j's unshadowed irradiance is at least `SIGNIFICANT` of the total.
    `pairs` (j, k) restricts the test to those pairs (default: every pair).
    """
    exact = [np.asarray(attenfit.irradiance(em, points, normals)) for em in _emitters()]
    total = np.sum(exact, axis=0)
    mask = np.zeros(len(points), dtype=bool)
    for j, (cj, rj) in enumerate(LIGHTS):
        vj = np.asarray(cj) - points
        dj = np.linalg.norm(vj, axis=1)
        for k, (ck, rk) in enumerate(LIGHTS):
            if k == j or (pairs is not None and (j, k) not in pairs):
                continue
            vk = np.asarray(ck) - points
            dk = np.linalg.norm(vk, axis=1)
            cos = np.clip(np.sum(vj * vk, axis=1) / (dj * dk), -1.0, 1.0)
            overlap = np.arccos(cos) < np.arcsin(rj / dj) + np.arcsin(rk / dk)
            mask |= overlap & (dk < dj) & (exact[j] >= SIGNIFICANT * total)
    return mask


def four_lights(resolution: int, spp: int, variant: str) -> dict:
    from data_gen import Plane, render_plane_map
    from data_gen.maps import plane_grid
    from data_gen.scenes import lights_from_emitter

    plane = Plane(point=(0.0, 0.0, 0.0), normal=(0.0, 0.0, 1.0), half_size=HALF_SIZE)
    t0 = time.perf_counter()
    mc = render_plane_map(
        [light for em in _emitters() for light in lights_from_emitter(em)],
        plane,
        resolution=resolution,
        spp=spp,
        seed=7,
        variant=variant,
    )
    seconds = time.perf_counter() - t0

    points, normals = plane_grid(plane, resolution)
    shape = (resolution, resolution)
    analytic = analytic_image(points, normals, lambda r: attenfit.MadamsSphere(r=r))
    exact = np.zeros(len(points))
    for em in _emitters():
        exact += np.asarray(attenfit.irradiance(em, points, normals))
    cut = {
        c: analytic_image(points, normals, lambda r, c=c: attenfit.MadamsCutoff(r=r, cutoff=c))
        for c in CUTOFFS
    }
    return {
        "mc": mc.E,
        "stderr": mc.stderr,
        "analytic": analytic.reshape(shape),
        "exact_unshadowed": exact.reshape(shape),
        "cutoff": {c: v.reshape(shape) for c, v in cut.items()},
        "shadowed": shadow_mask(points, normals).reshape(shape),
        # the post's region: the first light hidden behind the second, on the far left
        "main_shadow": shadow_mask(points, normals, [(0, 1)]).reshape(shape),
        "extent": mc.extent,
        "variant": mc.variant,
        "seconds": seconds,
    }


def four_lights_figure(img: dict):
    import matplotlib as mpl
    from matplotlib.colors import ListedColormap, TwoSlopeNorm

    ext = img["extent"]
    peak = float(np.nanmax(img["analytic"]))
    vmin = peak * 1e-3
    with mpl.rc_context(STYLE):
        fig = new_figure((13.0, 7.2))
        axes = fig.subplots(2, 3)
        plot_plane_image(img["mc"], ext, vmin=vmin, vmax=peak, ax=axes[0, 0],
                         title=f"Monte Carlo truth (Mitsuba {img['variant']})")  # fmt: skip
        plot_plane_image(img["analytic"], ext, vmin=vmin, vmax=peak, ax=axes[0, 1],
                         title="analytic: Σ cos θ / max(d, r)², no shadows")  # fmt: skip
        diff = img["analytic"] - img["mc"]
        ax = axes[0, 2]
        im = ax.imshow(diff / img["analytic"], origin="lower", extent=ext, cmap="RdBu_r",
                       norm=TwoSlopeNorm(0.0, -0.6, 0.6))  # fmt: skip
        ax.contour(img["shadowed"].astype(float), levels=[0.5], colors="black",
                   linewidths=0.7, extent=ext, origin="lower")  # fmt: skip
        ax.set_title(
            "(analytic − Monte Carlo) / analytic\nred: too bright; black: shadows (geometry)"
        )
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        fig.colorbar(im, ax=ax, label="relative difference", extend="both")
        red = ListedColormap([(0.85, 0.1, 0.1, 1.0)])
        for ax, c in zip(axes[1, :2], CUTOFFS, strict=True):
            image = img["cutoff"][c]
            plot_plane_image(np.where(image > 0, image, np.nan), ext, vmin=vmin, vmax=peak,
                             ax=ax, title=f"cutoff Ic = {c:g}: unlit areas in red")  # fmt: skip
            ax.imshow(np.where(image > 0, np.nan, 1.0), origin="lower", extent=ext, cmap=red)
        ax = axes[1, 2]
        z = diff / np.where(img["stderr"] > 0, img["stderr"], np.inf)
        im = ax.imshow(z, origin="lower", extent=ext, cmap="RdBu_r",
                       norm=TwoSlopeNorm(0.0, -5.0, 5.0))  # fmt: skip
        ax.contour(img["main_shadow"].astype(float), levels=[0.5], colors="black",
                   linewidths=0.7, extent=ext, origin="lower")  # fmt: skip
        ax.set_title("the difference in Monte Carlo standard errors\n"
                     "outlined: light 1 hidden behind light 2")  # fmt: skip
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        fig.colorbar(im, ax=ax, label="z = (analytic − MC) / σ_MC")
    return fig


def four_lights_numbers(img: dict) -> dict:
    """How the analytic render differs from Mitsuba's, inside and outside the shadows."""
    diff = img["analytic"] - img["mc"]
    z = diff / img["stderr"]
    sh, main = img["shadowed"], img["main_shadow"]
    rel_exact = np.abs(img["analytic"] - img["exact_unshadowed"]) / img["exact_unshadowed"]
    x = np.linspace(*img["extent"][:2], sh.shape[1] + 1)
    x = 0.5 * (x[1:] + x[:-1])
    lit_fraction = {str(c): float(np.mean(v > 0)) for c, v in img["cutoff"].items()}

    def pooled_z(m):  # the summed difference over a region, in its standard errors
        return float(diff[m].sum() / np.sqrt(np.sum(img["stderr"][m] ** 2)))

    return {
        "variant": img["variant"],
        "render_seconds": img["seconds"],
        "analytic_vs_exact_unshadowed_max_rel": float(rel_exact.max()),
        "shadowed_fraction": float(sh.mean()),
        "z_mean_unshadowed": float(z[~sh].mean()),
        "z_std_unshadowed": float(z[~sh].std()),
        "pooled_z_unshadowed": pooled_z(~sh),
        "pooled_z_shadowed": pooled_z(sh),
        "main_shadow_pixels": int(main.sum()),
        "main_shadow_pooled_z": pooled_z(main),
        "main_shadow_excess": float(diff[main].sum() / img["mc"][main].sum()),
        "main_shadow_centroid_x": float(np.average(x, weights=main.sum(axis=0))),
        "lit_fraction": lit_fraction,
    }


# ----------------------------------------------------------------------------- 3. windows
def window_curves(r: float, d_max: float):
    """The second post's three curves in its normalisation (1 at the surface), by surface distance.

    Bias: scale and bias with the threshold that puts its zero at d_max,
    Ic = (r/(r + d_max))^2. Tan and rational: `attenfit.MadamsTan`/`MadamsRational`,
    whose d_max is measured from the surface as in the post.
    """
    c = (r / (r + d_max)) ** 2
    fams = {
        "scale and bias": attenfit.MadamsCutoff(r=r, cutoff=c),
        "tan warp": attenfit.MadamsTan(r=r, d_max=d_max),
        "rational warp": attenfit.MadamsRational(r=r, d_max=d_max),
    }
    return {k: (lambda d_s, f=f: r * r * f(d_s + r)) for k, f in fams.items()}, c


def post_tan(d_s, r: float, d_max: float, k: float = 2.1):
    """The post's literal tan curve, d' = 2.1 tan(pi d/(2 d_max)), 1/(d'/r + 1)^2 (numpy)."""
    d_s = np.asarray(d_s)
    dp = k * np.tan(np.pi * d_s / (2 * d_max))
    return np.where(d_s < d_max, 1 / (dp / r + 1) ** 2, 0.0)


def window_gradients(r: float, d_max: float) -> dict:
    """Value and slope (jax.grad, by surface distance) of each curve at and just before d_max."""
    fs, c = window_curves(r, d_max)
    out = {"cutoff_for_bias": c}
    for name, f in fs.items():
        g = jax.grad(lambda x, f=f: f(x))
        left = d_max * (1 - 1e-9)
        out[name] = {
            "value_at_d_max": float(f(jnp.float64(d_max))),
            "grad_at_d_max": float(g(jnp.float64(d_max))),
            "grad_left_of_d_max": float(g(jnp.float64(left))),
        }
    # the unwindowed curve's slope there, for scale: d/dd 1/(d/r + 1)^2 = -2/(r (d/r + 1)^3)
    out["unwindowed_slope_at_d_max"] = -2.0 / (r * (d_max / r + 1) ** 3)
    return out


def windows_figure(r: float, d_max: float, grads: dict):
    import matplotlib as mpl

    fs, c = window_curves(r, d_max)
    d_s = np.linspace(0.0, 1.25 * d_max, 600)
    colours = {"scale and bias": "tab:red", "tan warp": "tab:green", "rational warp": "tab:purple"}
    with mpl.rc_context(STYLE):
        fig = new_figure((10.0, 4.0))
        ax, ax_zoom = fig.subplots(1, 2)
        for a in (ax, ax_zoom):
            a.plot(d_s / r, madams_att(d_s, r), color="tab:blue", lw=1.0,
                   label="1/(d/r + 1)² (no window)")  # fmt: skip
            for name, f in fs.items():
                g = grads[name]["grad_left_of_d_max"]
                a.plot(d_s / r, np.asarray(f(jnp.asarray(d_s))), color=colours[name],
                       label=f"{name}: slope at d_max {g:+.3g}")  # fmt: skip
            a.plot(d_s / r, post_tan(d_s, r, d_max), color="black", ls=":", lw=1.0,
                   label="post's 2.1 tan(π d / 2 d_max)")  # fmt: skip
            a.axvline(d_max / r, color="grey", lw=0.7, ls="--")
            a.set_xlabel("distance from the light's surface d / r")
            a.set_ylabel("f_att (1 at the surface)")
        ax.set_title(f"Madams 2011b: r = 1, d_max = 2.1π/2 = {d_max:.3f} (Ic = {c:.4f})")
        ax.legend(loc="upper right")
        ax_zoom.set_xlim(0.75 * d_max / r, 1.05 * d_max / r)
        ax_zoom.set_ylim(-0.002, 0.03)
        ax_zoom.set_title("near d_max: bias ends with a kink, the warps smoothly")
    return fig


# ----------------------------------------------------------------------------- main
def main(argv: Sequence[str] | None = None) -> dict:
    p = _example.parser(NAME, __doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a smaller, noisier render (tests)")
    p.add_argument(
        "--variant",
        default="auto",
        choices=("auto", "scalar_rgb", "llvm_ad_rgb"),
        help="Mitsuba variant (auto: llvm_ad_rgb when a working libLLVM is found)",
    )
    args = _example.parse_args(p, argv)
    resolution, spp = (32, 64) if args.quick else (64, 128)
    r = 1.0

    cutoff_rows = [[c, d_max_post(r, c), r / math.sqrt(c)] for c in CUTOFFS]
    print("first post: cutoff threshold -> d_max (surface) and range (centre), r = 1")
    print(_example.table(cutoff_rows, ["Ic", "d_max = r(sqrt(1/Ic)-1)", "centre range"]))
    truth = curve_truth(r, spp=4 * spp, variant=args.variant)
    d_check = np.array([0.0, 1.0, 3.0, 10.0])
    zs = None
    if "mc" in truth:
        zs = (truth["mc"] - madams_att(truth["mc_d_s"], r)) / truth["mc_stderr"]
        print(f"Mitsuba facing sweep vs 1/(d/r+1)^2: z-scores {np.round(zs, 2).tolist()}")

    img = four_lights(resolution, spp, args.variant)
    four = four_lights_numbers(img)
    print(f"four lights ({resolution}x{resolution}, {spp} spp, {four['variant']}, "
          f"{four['render_seconds']:.1f} s):")  # fmt: skip
    for k, v in four.items():
        if isinstance(v, float):
            print(f"  {k}: {v:.4g}")
    print(f"  lit fraction with cutoff: {four['lit_fraction']}")

    d_max = 2.1 * math.pi / 2  # the post's 2.1 = 2 d_max / pi
    grads = window_gradients(r, d_max)
    print(
        f"second post: r = 1, d_max = {d_max:.4f}, bias threshold Ic = {grads['cutoff_for_bias']:.5f}"
    )
    rows = [[k, v["value_at_d_max"], v["grad_left_of_d_max"], v["grad_at_d_max"]]
            for k, v in grads.items() if isinstance(v, dict)]  # fmt: skip
    print(_example.table(rows, ["curve", "f(d_max)", "slope just before d_max", "grad at d_max"]))

    numbers = {
        "r": r,
        "cutoffs": {
            str(c): {"d_max": d_max_post(r, c), "range_centre": r / math.sqrt(c)} for c in CUTOFFS
        },
        "curve": {
            "d_s": d_check.tolist(),
            "f_att": madams_att(d_check, r).tolist(),
            "cutoff_0.001": cutoff_att(d_check, r, 0.001).tolist(),
            "exact_sphere_max_rel_diff": float(
                np.max(np.abs(truth["exact"] - madams_att(truth["d_s"], r)) / truth["exact"])
            ),
            "mc_z": None if zs is None else zs.tolist(),
            # the comment thread's "it is a disc light's curve": the facing disc of the same
            # radius is 1/(D^2 + r^2) (D from the centre), far from this curve near the light
            "disk_facing_max_rel_diff": float(
                np.max(np.abs(1.0 / ((truth["d_s"] + r) ** 2 + r**2) * r**2 / truth["exact"] - 1))
            ),
        },
        "four_lights": four,
        "windows": {"d_max": d_max, **grads},
    }
    with _example.output_folder(args) as tmp:
        _example.save_figure(curve_figure(truth, r), tmp, "madams_curve")
        _example.save_figure(four_lights_figure(img), tmp, "madams_four_lights")
        _example.save_figure(windows_figure(r, d_max, grads), tmp, "madams_windows")
        _example.write_numbers(tmp, numbers)
    print(f"wrote {args.out}")
    return numbers


if __name__ == "__main__":
    _example.run(main)
