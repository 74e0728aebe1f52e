"""Yuksel 2020's motivating case: virtual point lights lying on a surface, seen on a plane.

Many-light methods (instant radiosity, lightcuts) place virtual point lights (VPLs) on the
surfaces a light's first bounce reaches; each VPL is a small cosine emitter lying on its
surface. Where another surface passes close to a VPL, inverse-square attenuation makes a
bright spike (Yuksel 2020, Fig. 1a): 1/d^2 grows without bound as the gap d closes, although
the light a VPL stands for is spread over some radius r. Yuksel's eq. 7 (Fig. 1b) and its ad
hoc eq. 8 stay bounded.

The scene: `N_VPL` VPLs of total intensity 1 scattered on a ramp that rises from the floor
(z = 0.25 x, the lowest VPL 1.5 cm up), each facing down the ramp's normal, lighting the
floor z = 0.
The floor is rendered with the point-light model `E = sum I g f(d) max(0, n.l)` for
inverse square, eq. 7 and eq. 8 (f with the VPL radius r), against two exact truths
(`attenfit.irradiance`):

* each VPL as a Lambertian *disk* of radius r lying on the ramp (what a VPL stands for:
  a small patch of the surface, emitting with a cosine). Bounded: at most about 1/r^2.
* each VPL as a *sphere* of radius r (the light Yuksel's derivation starts from). A sphere
  fully above a receiver's horizon gives exactly I cos / d^2, inverse square's value, so it
  cannot remove a spike: the spikes sit where d < r, inside the sphere, where it has no
  receivers at all (grey). That is why eq. 7 switches to a disk (the talk's section 2).

It prints the peak of each image and at the foot of the lowest VPL.

Run: python examples/virtual_point_lights.py [--out DIR] [--force] [--quick]
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)

import jax.numpy as jnp  # noqa: E402
import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
import _example  # noqa: E402

import attenfit  # noqa: E402
from attenfit.plots import STYLE, new_figure  # noqa: E402

NAME = "virtual_point_lights"
N_VPL = 40
RADIUS = 0.05  # m, each VPL's radius (eq. 7 and eq. 8's r, the truths' disk/sphere radius)
RAMP_SLOPE = 0.25  # the ramp z = slope x rises from the floor (a crease at x = 0)
X_LOWEST = 0.06  # the lowest VPL: 1.5 cm above the floor, its disk's edge 3 mm above it
EXTENT = (-0.05, 1.05, -0.55, 0.55)  # the floor window rendered (x0, x1, y0, y1), m
MODELS = ("inverse square", "Yuksel eq. 7", "Yuksel eq. 8")


def vpls(n: int = N_VPL, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """VPL centres on the ramp (the first one lowest, at y = 0) and the ramp's downward normal.

    No VPL's disk reaches the floor: x >= X_LOWEST > r sin(atan(slope)) / slope.
    """
    rng = np.random.default_rng(seed)
    x = np.concatenate([[X_LOWEST], rng.uniform(X_LOWEST, 1.0, n - 1)])
    y = np.concatenate([[0.0], rng.uniform(-0.45, 0.45, n - 1)])
    centres = np.stack([x, y, RAMP_SLOPE * x], axis=1)
    normal = np.array([RAMP_SLOPE, 0.0, -1.0]) / np.hypot(RAMP_SLOPE, 1.0)
    return centres, normal


def floor(resolution: int) -> tuple[np.ndarray, np.ndarray, tuple[int, int]]:
    """Receivers on the floor window (row i = y, column j = x), normals +z."""
    x0, x1, y0, y1 = EXTENT
    nx = resolution
    ny = max(2, round(resolution * (y1 - y0) / (x1 - x0)))
    xs = x0 + (np.arange(nx) + 0.5) * (x1 - x0) / nx
    ys = y0 + (np.arange(ny) + 0.5) * (y1 - y0) / ny
    gx, gy = np.meshgrid(xs, ys)
    points = np.stack([gx, gy, np.zeros_like(gx)], axis=-1).reshape(-1, 3)
    normals = np.broadcast_to(np.array([0.0, 0.0, 1.0]), points.shape)
    return points, np.ascontiguousarray(normals), (ny, nx)


@jax.jit
def _model_terms(d: jax.Array, weight: jax.Array) -> jax.Array:
    """weight * f(d) for the three point-light models, stacked (3, n)."""
    r = RADIUS
    fams = (attenfit.InverseSquare(), attenfit.Yuksel(r=r), attenfit.YukselAdhoc(r=r))
    return jnp.stack([weight * f(d) for f in fams])


def render(points: np.ndarray, normals: np.ndarray, centres: np.ndarray, normal: np.ndarray):
    """The floor's irradiance under every model and truth, each (n,)."""
    intensity = 1.0 / len(centres)
    models = np.zeros((len(MODELS), len(points)))
    disk_truth = np.zeros(len(points))
    sphere_truth = np.zeros(len(points))
    sphere_inverse_square = np.zeros(len(points))
    for c in centres:
        disk = attenfit.DiskEmitter(c, normal, RADIUS, intensity=intensity)
        d, weight = disk.point_light(points, normals)  # weight = I max(0, cos_e) max(0, n.l)
        models += np.asarray(_model_terms(d, weight))
        disk_truth += np.asarray(attenfit.irradiance(disk, points, normals))
        sphere = attenfit.SphereEmitter(c, RADIUS, intensity=intensity)
        sphere_truth += np.asarray(attenfit.irradiance(sphere, points, normals))  # NaN inside
        d, weight = sphere.point_light(points, normals)  # isotropic: I max(0, n.l)
        sphere_inverse_square += np.asarray(_model_terms(d, weight)[0])
    out = dict(zip(MODELS, models, strict=True))
    out["truth: disks"] = disk_truth
    out["truth: spheres"] = sphere_truth
    out["inverse square, isotropic"] = sphere_inverse_square
    return out


def foot_values(centres: np.ndarray, normal: np.ndarray) -> dict[str, float]:
    """Every image at the floor point straight below the lowest VPL (1 cm gap)."""
    foot = np.array([[centres[0, 0], centres[0, 1], 0.0]])
    up = np.array([[0.0, 0.0, 1.0]])
    return {k: float(v[0]) for k, v in render(foot, up, centres, normal).items()}


def figure(images: dict[str, np.ndarray], profile: dict[str, np.ndarray], x: np.ndarray):
    import matplotlib as mpl
    from matplotlib.colors import LogNorm, TwoSlopeNorm

    vmax = float(np.nanmax(images["inverse square"]))
    vmin = float(np.nanmax(images["truth: disks"])) / 30
    with mpl.rc_context(STYLE):
        fig = new_figure((13.0, 7.0))
        grid = fig.subplots(2, 3)
        order = [*MODELS, "truth: disks"]
        cmap = mpl.colormaps["inferno"].with_extremes(bad="0.6")
        for ax, label in zip(grid.flat, order, strict=False):
            img = images[label]
            im = ax.imshow(np.clip(img, vmin, None), origin="lower", extent=EXTENT, cmap=cmap,
                           norm=LogNorm(vmin, vmax))  # fmt: skip
            ax.set_title(f"{label}: peak {np.nanmax(img):.3g} W/m²")
            ax.set_xlabel("x (m)")
            ax.set_ylabel("y (m)")
        ax = grid[1, 1]
        ratio = images["inverse square, isotropic"] / images["truth: spheres"]
        cm = mpl.colormaps["RdBu_r"].with_extremes(bad="0.6")
        im2 = ax.imshow(ratio, origin="lower", extent=EXTENT, cmap=cm,
                        norm=TwoSlopeNorm(1.0, 0.8, 1.2))  # fmt: skip
        ax.set_title("VPLs as spheres: inverse square / truth\n"
                     "(= 1 outside; grey: inside a sphere)")  # fmt: skip
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        fig.colorbar(im2, ax=ax, shrink=0.8, extend="both")
        fig.colorbar(im, ax=[grid[0, 0], grid[0, 1], grid[0, 2], grid[1, 0]], label="floor irradiance E (W/m², total I = 1 W/sr)",
                     shrink=0.7, extend="min")  # fmt: skip
        ax = grid[1, 2]
        styles = {"inverse square": ("black", "-"), "Yuksel eq. 7": ("tab:red", "-"),
                  "Yuksel eq. 8": ("tab:blue", "--"), "truth: disks": ("tab:green", ":")}  # fmt: skip
        for label, (colour, ls) in styles.items():
            e = profile[label]
            ax.semilogy(x, e, color=colour, ls=ls, label=label, lw=1.6)
        ax.set_xlim(-0.02, 0.3)
        ax.set_ylim(0.3, 300)
        ax.set_xlabel("x (m), through the lowest VPL (y = 0, x = 0.06)")
        ax.set_ylabel("E (W/m²)")
        ax.set_title("profile through the spike")
        ax.legend(loc="upper right")
    return fig


def main(argv: Sequence[str] | None = None) -> dict:
    p = _example.parser(NAME, __doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="a coarser floor image (tests)")
    args = _example.parse_args(p, argv)
    resolution = 72 if args.quick else 144
    centres, normal = vpls()
    points, normals, shape = floor(resolution)
    flat = render(points, normals, centres, normal)
    images = {k: v.reshape(shape) for k, v in flat.items()}
    # a fine profile through the lowest VPL's foot (y = 0)
    x = np.linspace(-0.05, 0.3, 351)
    line = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    up = np.broadcast_to(np.array([0.0, 0.0, 1.0]), line.shape)
    profile = render(line, np.ascontiguousarray(up), centres, normal)
    foot = foot_values(centres, normal)

    peaks = {k: float(np.nanmax(v)) for k, v in flat.items()}
    rows = [[k, peaks[k], foot[k], peaks[k] / peaks["truth: disks"]] for k in flat]
    rows = [row for row in rows if row[0] != "truth: spheres"]  # a different light, below
    print(f"{N_VPL} VPLs of radius {RADIUS} m on a ramp; the lowest {centres[0, 2]:.3g} m up")
    print(_example.table(rows, ["image", "peak (W/m2)", "at the lowest foot", "peak / disk truth"]))
    inside = float(np.mean(np.isnan(flat["truth: spheres"])))
    print(f"floor receivers inside a sphere VPL: {inside:.2%}")
    far = np.isfinite(flat["truth: spheres"])
    rel_sphere = flat["inverse square, isotropic"][far] / flat["truth: spheres"][far] - 1
    print(
        "VPLs as spheres: inverse square (isotropic) / sphere truth - 1 outside the spheres: "
        f"median {np.median(np.abs(rel_sphere)):.2g}, max {np.max(np.abs(rel_sphere)):.2g}"
    )
    numbers = {
        "n_vpl": N_VPL,
        "radius": RADIUS,
        "gap_at_foot": float(centres[0, 2]),
        "centres": centres.tolist(),
        "vpl_normal": normal.tolist(),
        "peaks": peaks,
        "foot": foot,
        "fraction_inside_spheres": inside,
        "inverse_square_vs_spheres_median_abs_rel": float(np.median(np.abs(rel_sphere))),
        "inverse_square_vs_spheres_max_abs_rel": float(np.max(np.abs(rel_sphere))),
        "energy_ratio_to_disks": {
            k: float(np.sum(flat[k]) / np.sum(flat["truth: disks"])) for k in MODELS
        },
    }
    with _example.output_folder(args) as tmp:
        _example.save_figure(figure(images, profile, x), tmp, "vpl_floor")
        _example.write_numbers(tmp, numbers)
    print(f"wrote {args.out}")
    return numbers


if __name__ == "__main__":
    _example.run(main)
