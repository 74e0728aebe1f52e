"""Irradiance datasets: receivers, irradiance, its standard error and provenance; files and builders.

A `Dataset` is the unit of ground truth every other part of attenfit consumes: the exact
builders here (`facing_sweep`, `plane_receivers`, `random_receivers`, generator
"attenfit.irradiance", stderr 0) and Mitsuba renders (`data_gen`, generator "mitsuba") make
the same class. Saved as `.npz` (no pickles) with a JSON header: the emitter's `to_dict()`,
the provenance and a format version.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import platform
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import jax
import numpy as np

from .. import _budget
from .._atomic import atomic_write
from .._budget import budget
from .._errors import AttenfitError, BadTypeError, BadValueError, DataFileError
from .._input import load_json, read_npz
from .._version import __version__
from ._clearance import CLEARANCE, scene_scale, too_close
from ._emitters import AbstractEmitter, emitter_from_dict
from ._irradiance import irradiance

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "Dataset",
    "facing_sweep",
    "plane_receivers",
    "random_receivers",
]

#: The `format` entry of every dataset file's header.
FORMAT = "attenfit.dataset"
#: The version of the file layout this module writes and reads.
FORMAT_VERSION = 1
_ARRAYS = ("points", "normals", "E", "stderr")


def _versions() -> dict[str, str]:
    return {
        "attenfit": __version__,
        "jax": jax.__version__,
        "numpy": np.__version__,
        "python": platform.python_version(),
    }


def _float_array(name: str, x: Any) -> np.ndarray:
    try:
        arr = np.array(x)  # a private copy
    except Exception as exc:
        raise BadTypeError(f"{name} must be a float array, got {type(x).__name__}") from exc
    if not np.issubdtype(arr.dtype, np.floating):
        raise BadTypeError(f"{name} must be a float array, got dtype {arr.dtype}")
    if arr.dtype.itemsize not in (4, 8):  # float16, longdouble: JAX computes in neither
        raise BadTypeError(f"{name} must be float32 or float64, got {arr.dtype}")
    arr = arr.astype(arr.dtype.newbyteorder("="), copy=False)  # big-endian: the machine's order
    if not np.all(np.isfinite(arr)):
        raise BadValueError(
            f"{name} must be finite; {int(np.sum(~np.isfinite(arr)))} entries are not"
        )
    arr.setflags(write=False)
    return arr


@dataclasses.dataclass(frozen=True, eq=False)
class Dataset:
    """Irradiance `E` (W/m^2) at `N` receivers from one emitter, with standard errors and provenance.

    Fields: `emitter` (an `attenfit` emitter), `points` and `normals` (float arrays `(N, 3)`,
    normals need not be unit), `E` and `stderr` (float arrays `(N,)`, `stderr >= 0`, 0 for
    exact values), `provenance` (a JSON-serialisable dict: `generator`, and e.g. `variant`,
    `samples`/`spp`, `seed`, `versions`; grid datasets carry `shape` and `grid_index`).
    Arrays are stored as read-only numpy arrays in the dtype given (float32 or float64).
    """

    emitter: AbstractEmitter
    points: np.ndarray
    normals: np.ndarray
    E: np.ndarray
    stderr: np.ndarray
    provenance: dict[str, Any] = dataclasses.field(default_factory=dict)

    def __post_init__(self):
        if not isinstance(self.emitter, AbstractEmitter):
            raise BadTypeError(
                f"emitter must be an attenfit emitter, got {type(self.emitter).__name__}"
            )
        points = _float_array("points", self.points)
        normals = _float_array("normals", self.normals)
        E = _float_array("E", self.E)
        stderr = _float_array("stderr", self.stderr)
        if points.ndim != 2 or points.shape[1] != 3:
            raise BadValueError(f"points must have shape (N, 3), got {points.shape}")
        n = points.shape[0]
        if normals.shape != (n, 3):
            raise BadValueError(
                f"normals must have shape {(n, 3)} like points, got {normals.shape}"
            )
        if E.shape != (n,):
            raise BadValueError(f"E must have shape {(n,)}, got {E.shape}")
        if stderr.shape == ():
            stderr = np.full((n,), stderr, dtype=stderr.dtype)
            stderr.setflags(write=False)
        if stderr.shape != (n,):
            raise BadValueError(f"stderr must have shape {(n,)} or be a scalar, got {stderr.shape}")
        if np.any(E < 0):  # irradiance, and any estimate of it, is never negative
            raise BadValueError(f"E must be >= 0 (an irradiance), got {E[E < 0].flat[0].item()!r}")
        if np.any(stderr < 0):
            raise BadValueError(f"stderr must be >= 0, got {stderr[stderr < 0].flat[0].item()!r}")
        size = np.max(np.abs(normals), axis=1) if n else None  # no squares: 1e308 overflows
        if n and not np.all(size > 0):
            zero = int(np.argmin(size > 0))
            raise BadValueError(
                f"normals must be non-zero vectors; normal {zero} is {normals[zero].tolist()}"
            )
        if not isinstance(self.provenance, Mapping):
            raise BadTypeError(f"provenance must be a dict, got {type(self.provenance).__name__}")
        prov = dict(self.provenance)
        try:
            json.dumps(prov)
        except (TypeError, ValueError) as exc:
            raise BadValueError(f"provenance must be JSON-serialisable: {exc}") from exc
        for name, value in (("points", points), ("normals", normals), ("E", E), ("stderr", stderr)):
            object.__setattr__(self, name, value)
        object.__setattr__(self, "provenance", prov)

    def __len__(self) -> int:
        return int(self.points.shape[0])

    def __repr__(self) -> str:
        gen = self.provenance.get("generator", "?")
        return (
            f"Dataset({self.emitter.kind}, N={len(self)}, generator={gen!r}, dtype={self.E.dtype})"
        )

    # ------------------------------------------------------------------ derived quantities
    def distance(self) -> np.ndarray:
        """Distance `d` of each receiver from the light's centre (capsule: from its segment)."""
        d, _ = self.emitter.point_light(self.points, self.normals)
        return np.asarray(d)

    def weight(self) -> np.ndarray:
        """Point-light weight `I * g * max(0, n.l)` of each receiver (`E_model = weight * f(d)`)."""
        _, w = self.emitter.point_light(self.points, self.normals)
        return np.asarray(w)

    def attenuation(self) -> np.ndarray:
        """Ground-truth attenuation `E / weight` (1/m^2); NaN where the weight is 0."""
        w = self.weight()
        ok = w > 0
        return np.where(ok, self.E / np.where(ok, w, 1), np.nan).astype(self.E.dtype)

    def grid_image(self, values: np.ndarray | None = None) -> np.ndarray:
        """`values` (default `E`) scattered into the receiver grid of a `plane_receivers` dataset.

        Returns an array of `provenance["shape"]` with NaN where the grid had no receiver
        (inside the light). Raises `BadValueError` for a dataset that is not a grid.
        """
        if "shape" not in self.provenance or "grid_index" not in self.provenance:
            raise BadValueError(
                "this dataset is not a receiver grid (no 'shape' in its provenance)"
            )
        values = self.E if values is None else np.asarray(values)
        if values.shape != (len(self),):
            raise BadValueError(f"values must have shape {(len(self),)}, got {values.shape}")
        shape = tuple(self.provenance["shape"])
        img = np.full(math.prod(shape), np.nan, dtype=np.result_type(values.dtype, np.float32))
        img[np.asarray(self.provenance["grid_index"], dtype=np.int64)] = values
        return img.reshape(shape)

    # ------------------------------------------------------------------ files
    def save(self, path: str | os.PathLike, force: bool = False) -> Path:
        """Write the dataset to `path` (`.npz` + JSON header) atomically; refuse to overwrite unless `force`."""
        header = {
            "format": FORMAT,
            "version": FORMAT_VERSION,
            "emitter": self.emitter.to_dict(),
            "provenance": self.provenance,
            "n": len(self),
        }
        arrays = {name: getattr(self, name) for name in _ARRAYS}

        def write(tmp: Path) -> None:
            with open(tmp, "wb") as fh:
                np.savez(fh, header=np.asarray(json.dumps(header)), **arrays)

        return atomic_write(path, write, force=force)

    @classmethod
    def load(cls, path: str | os.PathLike) -> Dataset:
        """Read a dataset written by `save`, validating its header, shapes, dtypes and finiteness.

        Raises `DataFileError` for a missing, truncated, corrupt or foreign file.
        """
        path = Path(path)
        what = repr(str(path))
        arrays = read_npz(path, what, budget(), "attenfit dataset (.npz)", ("header", *_ARRAYS))
        if "header" not in arrays or arrays["header"].shape != ():
            raise DataFileError(f"{what} is not an attenfit dataset (no header)")
        header = load_json(str(arrays.pop("header")), f"the header of {what}")
        if not isinstance(header, dict) or header.get("format") != FORMAT:
            raise DataFileError(
                f"{str(path)!r} is not an attenfit dataset (header format is not {FORMAT!r})"
            )
        if header.get("version") != FORMAT_VERSION:
            raise DataFileError(
                f"{str(path)!r} has dataset format version {header.get('version')!r}; this attenfit reads {FORMAT_VERSION}"
            )
        arrays = {name: arrays[name] for name in _ARRAYS if name in arrays}
        missing = [name for name in _ARRAYS if name not in arrays]
        if missing:
            raise DataFileError(f"{str(path)!r} lacks the arrays {missing}")
        try:
            emitter = emitter_from_dict(header["emitter"])
            ds = cls(emitter, provenance=header.get("provenance", {}), **arrays)
        except (AttenfitError, KeyError) as exc:
            raise DataFileError(f"{str(path)!r} holds an invalid dataset: {exc}") from exc
        if header.get("n") != len(ds):
            raise DataFileError(
                f"{str(path)!r}: header says {header.get('n')} receivers, arrays hold {len(ds)}"
            )
        return ds


# ----------------------------------------------------------------------------- builders
def _positive(name: str, x: Any) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError) as exc:
        raise BadTypeError(f"{name} must be a number, got {x!r}") from exc
    if not (math.isfinite(v) and v > 0):
        raise BadValueError(f"{name} must be finite and > 0, got {x!r}")
    return v


def _count(name: str, n: Any) -> int:
    if isinstance(n, bool) or not isinstance(n, int | np.integer):
        raise BadTypeError(f"{name} must be an integer, got {n!r}")
    if n < 1:
        raise BadValueError(f"{name} must be >= 1, got {n}")
    return int(n)


#: Peak memory of a builder per receiver (points, normals, E, the irradiance's chunked
#: intermediates, the program compiled for its shape), measured by `python -m benchmarks
#: memory` (about 1.2 kB at 300,000 receivers) and rounded up.
BYTES_PER_RECEIVER = 2048


def _receivers_within_budget(n: int) -> int:
    """`n`, after refusing a receiver count whose arrays would exceed the memory budget."""
    _budget.check(BYTES_PER_RECEIVER * n, f"{n:,} receivers", "fewer receivers (n)")
    return n


def _dtype(dtype: Any) -> np.dtype:
    try:
        dt = np.dtype(jax.dtypes.canonicalize_dtype(np.float64) if dtype is None else dtype)
    except TypeError:
        raise BadTypeError(f"dtype must be float32 or float64, got {dtype!r}") from None
    if dt not in (np.dtype(np.float32), np.dtype(np.float64)):
        raise BadTypeError(f"dtype must be float32 or float64, got {dt}")
    if dt == np.float64 and not jax.config.jax_enable_x64:
        raise BadValueError(
            "dtype float64 needs jax_enable_x64 (jax.config.update('jax_enable_x64', True))"
        )
    return dt


def _check_reach(far: float, dtype: Any) -> None:
    """Refuse receivers so far from the light (m) that d^2 overflows `dtype`."""
    limit = math.sqrt(float(np.finfo(dtype).max)) / 16
    if not far < limit:
        raise BadValueError(
            f"receivers reach {far:g} m from the light; in {np.dtype(dtype)} they must stay "
            f"within {limit:.3g} m (d^2 overflows beyond)"
        )


def _exact(emitter, points, normals, provenance, dtype) -> Dataset:
    centre = np.asarray(emitter.reference_point(), dtype=np.float64)
    offsets = np.asarray(points, np.float64) - centre
    scale = float(np.max(np.abs(offsets))) or 1.0  # scaled norm: no overflow in float64 either
    dist = scale * np.linalg.norm(offsets / scale, axis=-1)
    _check_reach(float(np.max(dist)), dtype)
    # the light's radius and the receivers' distances must square to normal numbers too
    small = math.sqrt(float(np.finfo(dtype).tiny))
    dt_name = np.dtype(dtype).name
    if not float(emitter.radius) > small:
        raise BadValueError(
            f"the light's radius is {float(emitter.radius):g} m; in {dt_name} it must exceed "
            f"{small:.3g} m (its square underflows)"
        )
    nearest = float(np.min(dist[dist > 0], initial=math.inf))
    if not nearest > small:
        raise BadValueError(
            f"a receiver is {nearest:g} m from the light's centre; in {dt_name} distances "
            f"must exceed {small:.3g} m (their squares underflow)"
        )
    # no irradiance exceeds pi L = I / r^2 (L the emitter's radiance): that bound, and the
    # intensity the kernels multiply by, must fit the dtype
    peak = math.pi * float(emitter.intensity) / (math.pi * float(emitter.radius) ** 2)
    if not max(peak, float(emitter.intensity)) < float(np.finfo(dtype).max) / 16:
        raise BadValueError(
            f"the light's intensity {float(emitter.intensity):g} (radius "
            f"{float(emitter.radius):g} m: irradiance up to {peak:.3g}) overflows "
            f"{dt_name}: lower the intensity, or use float64"
        )
    p = np.asarray(points, dtype=dtype)
    n = np.asarray(normals, dtype=dtype)
    # pad to a power of two (repeating the first receiver) so that builders of similar
    # sizes share one compilation of `irradiance`
    size = max(16, 1 << (len(p) - 1).bit_length())
    pad = np.broadcast_to(p[:1], (size - len(p), 3))
    pad_n = np.broadcast_to(n[:1], (size - len(p), 3))
    E = np.asarray(irradiance(emitter, np.concatenate([p, pad]), np.concatenate([n, pad_n])))
    E = E[: len(p)]
    if not np.all(np.isfinite(E)):  # a bug, not a user error: the builders avoid the invalid set
        raise RuntimeError("irradiance returned non-finite values for builder receivers")
    prov = {
        "generator": "attenfit.irradiance",
        "stderr": "exact",
        "versions": _versions(),
        **provenance,
    }
    return Dataset(emitter, np.asarray(p), np.asarray(n), E, np.zeros_like(E), prov)


def _unit_np(v: Sequence[float], name: str) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or not np.linalg.norm(v) > 0:
        raise BadValueError(f"{name} must be a finite non-zero 3-vector, got {v.tolist()}")
    return v / np.linalg.norm(v)


def facing_sweep(
    emitter: AbstractEmitter,
    d_min: float,
    d_max: float,
    n: int = 256,
    *,
    dtype: Any = None,
) -> Dataset:
    """Receivers facing the light on a log-spaced distance sweep `d_min..d_max` (the seeds' curves).

    Sphere: along -z from the centre. Disk: on its axis, on the emitting side, facing it
    (coaxial; `E = I / (d^2 + r^2)`). Capsule: from the segment's midpoint perpendicular to
    its axis (so `d` is the distance to the segment). Every receiver's normal points at the
    centre, so the attenuation `E / weight` is the plain curve. `d_min` must exceed the
    radius for a sphere or capsule. `dtype` float32 or float64 (default: JAX's default float).
    """
    d_min, d_max = _positive("d_min", d_min), _positive("d_max", d_max)
    n = _receivers_within_budget(_count("n", n))
    if d_max < d_min:
        raise BadValueError(f"d_max ({d_max}) must be >= d_min ({d_min})")
    solid = emitter.solid_radius
    if d_min <= solid:
        raise BadValueError(
            f"d_min ({d_min}) must exceed the {emitter.kind}'s radius ({solid}): receivers would be inside"
        )
    dt = _dtype(dtype)
    c = np.asarray(emitter.reference_point(), dtype=np.float64)
    direction = emitter.facing_direction()
    d = np.geomspace(d_min, d_max, n)
    points = c[None, :] + d[:, None] * direction[None, :]
    normals = np.broadcast_to(-direction, points.shape)
    if too_close(emitter, points[:1])[0]:
        need = solid + CLEARANCE * float(scene_scale(emitter, points[:1])[0])
        raise BadValueError(
            f"d_min ({d_min:g}) puts a receiver nearer the light's surface than float32 "
            f"renderers can judge (2^-16 of the scene's scale, attenfit._truth._clearance); "
            f"d_min must be at least {need * (1 + 2**-20):.6g}"
        )
    prov = {
        "builder": "facing_sweep",
        "d_min": d_min,
        "d_max": d_max,
        "n": n,
        "direction": direction.tolist(),
    }
    return _exact(emitter, points, normals, prov, dt)


def plane_receivers(
    emitter: AbstractEmitter,
    height: float,
    extent: float,
    n: int | tuple[int, int] = 64,
    *,
    up: Sequence[float] = (0.0, 0.0, 1.0),
    dtype: Any = None,
) -> Dataset:
    """A square grid of receivers on a plane `height` below the light's centre, normals `up`.

    The plane is perpendicular to `up` (default +z) at signed distance `height` below the
    light's centre (capsule: its midpoint): `height < r` makes a sphere or capsule cross the
    plane, `height == r` touch it (as with virtual point lights on surfaces), `height <= 0`
    puts the centre on or under the plane. The grid spans `+-extent` around the foot of the
    centre with `n` (or `(ny, nx)`) points per side. Grid points on or inside the light are
    left out, and so are those nearer its surface than float32 renderers can judge (2^-16
    of the scene's scale, `attenfit._truth._clearance`); `provenance` records `shape` (ny, nx), `grid_index` (the flat grid index of
    each receiver kept), the axes and the extent, so `Dataset.grid_image` can show it.
    """
    try:
        h = float(height)
    except (TypeError, ValueError) as exc:
        raise BadTypeError(f"height must be a number, got {height!r}") from exc
    if not math.isfinite(h):
        raise BadValueError(f"height must be finite, got {height!r}")
    extent = _positive("extent", extent)
    ny, nx = (n, n) if not isinstance(n, tuple | list) else tuple(n)
    ny, nx = _count("n", ny), _count("n", nx)
    _receivers_within_budget(ny * nx)
    dt = _dtype(dtype)
    up_v = _unit_np(up, "up")
    # grid axes: world x (or y, for an up close to x) made perpendicular to up; +x, +y for up = +z
    helper = np.array([1.0, 0, 0]) if abs(up_v[0]) < 0.9 else np.array([0, 1.0, 0])
    ex = helper - (helper @ up_v) * up_v
    ex /= np.linalg.norm(ex)
    ey = np.cross(up_v, ex)
    c = np.asarray(emitter.reference_point(), dtype=np.float64)
    foot = c - h * up_v
    xs = np.linspace(-extent, extent, nx)
    ys = np.linspace(-extent, extent, ny)
    X, Y = np.meshgrid(xs, ys)  # (ny, nx)
    pts = foot[None, :] + X.reshape(-1, 1) * ex[None, :] + Y.reshape(-1, 1) * ey[None, :]
    keep = ~emitter.inside(pts) & ~too_close(emitter, pts)  # too close: _clearance.py
    index = np.nonzero(keep)[0]
    if index.size == 0:
        raise BadValueError(
            "every grid point lies inside the light; move the plane or widen the extent"
        )
    pts = pts[index]
    normals = np.broadcast_to(up_v, pts.shape)
    prov = {
        "builder": "plane_receivers",
        "height": h,
        "extent": extent,
        "shape": [ny, nx],
        "grid_index": index.tolist(),
        "x_axis": ex.tolist(),
        "y_axis": ey.tolist(),
        "up": up_v.tolist(),
    }
    return _exact(emitter, pts, normals, prov, dt)


def random_receivers(
    emitter: AbstractEmitter,
    n: int,
    d_min: float,
    d_max: float,
    *,
    seed: int = 0,
    dtype: Any = None,
) -> Dataset:
    """`n` receivers at log-uniform distances `d_min..d_max` in uniform directions, random normals.

    Distances are from the centre (capsule: from its segment; the point is offset from a
    uniform point of the segment). Half the normals are uniform on the sphere; the other half
    have `n.l` uniform in the horizon-straddling band `|n.l| < sin(alpha)` (alpha the light's
    apparent angular radius `asin(r/d)`, or `atan(r/d)` for a disk), so horizon-clipped
    receivers are well represented next to unclipped and fully-below ones. Points nearer the
    light's surface than float32 renderers can judge (2^-16 of the scene's scale,
    `attenfit._truth._clearance`) are drawn again. Deterministic in `seed`. `d_min` must exceed the radius for a sphere or capsule.
    """
    n = _receivers_within_budget(_count("n", n))
    d_min, d_max = _positive("d_min", d_min), _positive("d_max", d_max)
    if d_max < d_min:
        raise BadValueError(f"d_max ({d_max}) must be >= d_min ({d_min})")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer):
        raise BadTypeError(f"seed must be an integer, got {seed!r}")
    solid = emitter.solid_radius
    if d_min <= solid:
        raise BadValueError(
            f"d_min ({d_min}) must exceed the {emitter.kind}'s radius ({solid}): receivers would be inside"
        )
    dt = _dtype(dtype)
    _check_reach(d_max + 2 * emitter.solid_radius + emitter.core_length, dt)
    rng = np.random.default_rng(int(seed))
    pts = _random_points(emitter, n, d_min, d_max, rng)
    normals = _random_normals(emitter, pts, rng)
    prov = dict(builder="random_receivers", n=n, d_min=d_min, d_max=d_max, seed=int(seed))
    return _exact(emitter, pts, normals, prov, dt)


def _unit_vectors(rng: np.random.Generator, k: int) -> np.ndarray:
    v = rng.normal(size=(k, 3))
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def _random_points(emitter, n: int, d_min: float, d_max: float, rng) -> np.ndarray:
    """`n` points at log-uniform distances from the light's centre (or a uniform point of its
    segment), none inside it or nearer its surface than the clearance."""
    pts_list: list[np.ndarray] = []
    have = 0
    while have < n:
        k = 2 * (n - have) + 8
        d = np.exp(rng.uniform(math.log(d_min), math.log(d_max), size=k))
        p = emitter.core_samples(rng, k) + d[:, None] * _unit_vectors(rng, k)
        ok = ~emitter.inside(p, margin=1e-6) & ~too_close(emitter, p)
        ok &= emitter.core_distance(p) >= d_min  # a centre's: d >= d_min, to rounding
        pts_list.append(p[ok])
        have += int(ok.sum())
    return np.concatenate(pts_list)[:n]


def _random_normals(emitter, pts: np.ndarray, rng) -> np.ndarray:
    """Half uniform on the sphere, half with `n.l` uniform in the horizon-straddling band."""
    n = len(pts)
    target = np.asarray(emitter.closest_point(pts), dtype=np.float64)
    dp = np.linalg.norm(target - pts, axis=1)
    l = (target - pts) / dp[:, None]
    sin_a = emitter.apparent_sine(dp)
    uniform = rng.uniform(size=n) < 0.5
    cos_t = np.where(uniform, rng.uniform(-1, 1, size=n), rng.uniform(-1, 1, size=n) * sin_a)
    t1 = np.cross(l, _unit_vectors(rng, n))
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    sin_t = np.sqrt(np.clip(1 - cos_t**2, 0, 1))
    return cos_t[:, None] * l + sin_t[:, None] * t1
