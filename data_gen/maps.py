"""Irradiance maps: a square of a plane under (or through) lights, rendered as an image.

The plane is an opaque square in the Mitsuba scene and every pixel centre is a receiver on it,
with the plane's normal: the picture the seeds show ("four lights above a plane", Madams 2011),
with the lights' shadows on each other and on the plane computed by Mitsuba. The image follows
`attenfit.plots.plot_plane_image`: `E[i, j]` is at row i (v) and column j (u), row 0 at the
lowest v, with `extent = (-h, h, -h, h)` in plane coordinates (u, v) = `plane_axes(plane)`
(for a plane facing +z, u = +x and v = +y).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import NamedTuple

import matplotlib as mpl
import numpy as np

from attenfit import BadValueError
from attenfit._atomic import atomic_write

from .estimate import Progress, estimate_detail
from .scenes import Light, Plane, plane_axes

__all__ = ["PlaneMap", "plane_grid", "render_plane_map", "save_map_png"]


class PlaneMap(NamedTuple):
    """An irradiance image: `E` and `stderr` (H, W), the plane, and its `extent` (u0, u1, v0, v1)."""

    E: np.ndarray
    stderr: np.ndarray
    plane: Plane
    extent: tuple[float, float, float, float]
    variant: str


def plane_grid(plane: Plane, resolution: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel-centre receivers (resolution^2, 3) in image order, and their normals."""
    if isinstance(resolution, bool) or not isinstance(resolution, int) or resolution < 1:
        raise BadValueError(f"resolution must be a positive integer, got {resolution!r}")
    u, v = plane_axes(plane)
    h = plane.half_size
    t = (np.arange(resolution) + 0.5) / resolution * 2.0 * h - h
    su, sv = np.meshgrid(t, t)  # row i = v[i], column j = u[j]
    points = np.asarray(plane.point) + su[..., None] * u + sv[..., None] * v
    normals = np.broadcast_to(np.asarray(plane.normal), points.shape)
    return points.reshape(-1, 3), np.ascontiguousarray(normals.reshape(-1, 3))


def render_plane_map(
    lights: Sequence[Light],
    plane: Plane,
    *,
    resolution: int = 64,
    spp: int = 256,
    seed: int = 0,
    variant: str = "auto",
    progress: Progress | None = None,
) -> PlaneMap:
    """Render the irradiance (W m^-2) on `plane` lit by `lights`, one receiver per pixel centre.

    The plane occludes (it is in the scene); receivers inside a light, or nearer its surface
    than 2^-16 of the scene's scale (`data_gen.clearance`), are refused, so a sphere crossing
    or touching the plane needs its footprint outside the pixel centres (or a resolution that
    avoids it). Same `seed` and variant, same image.
    """
    points, normals = plane_grid(plane, resolution)
    est = estimate_detail(
        lights,
        points,
        normals,
        spp=spp,
        seed=seed,
        variant=variant,
        plane=plane,
        progress=progress,
    )
    shape = (resolution, resolution)
    return PlaneMap(
        E=est.E.reshape(shape),
        stderr=est.stderr.reshape(shape),
        plane=plane,
        extent=(-plane.half_size, plane.half_size, -plane.half_size, plane.half_size),
        variant=est.variant,
    )


def save_map_png(
    path: str | os.PathLike, image: PlaneMap, *, force: bool = False, title: str | None = None
):
    """Draw `image` with `attenfit.plots.plot_plane_image` and write it atomically as a PNG."""
    import matplotlib.pyplot as plt

    from attenfit.plots import STYLE, plot_plane_image

    fig, _ = plot_plane_image(image.E, image.extent, title=title)
    try:
        with mpl.rc_context(STYLE):
            atomic_write(path, lambda tmp: fig.savefig(tmp, format="png"), force=force)
    finally:
        plt.close(fig)
    return path
