"""Configurations (docs/report.md, generalising Yuksel 2020's Figure 3 and Madams 2011's
renders), for an emitter of radius r and unit intensity:

* **sweep**: receivers facing the light's centre, `SWEEP_N` distances log-spaced from
  contact (sphere) or 1e-3 r (disk) to 1000 r; the truth is the exact attenuation
  E_true / (I g n.l) there (docs/architecture.md, Conventions);
* **plane**: a receiving plane under the light (the sphere touching it, the disk at r/4 above
  it), rendered on a grid for the images and integrated along a ray for its energy;
* **datasets** (e.g. Mitsuba renders, `--mitsuba FILE.npz`): a dataset whose provenance has a
  2-D `shape` is a plane image, any other a sweep against its own samples.

Everything is computed in float64 (inside `jax.enable_x64(True)`), except the cost per
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._errors import BadTypeError, BadValueError
from .._truth import DiskEmitter, SphereEmitter, irradiance

#: Radius of the default emitters, in m (a 20 cm globe or disk).
DEFAULT_RADIUS = 0.1
#: The threshold that sets a window's range "as published": where the light's facing
#: irradiance has fallen to this fraction of its value at the light's surface (Madams 2011's
#: example cutoff I_c = 0.001 for L_i = 1), i.e. range = r / sqrt(PUBLISHED_CUTOFF) = 31.6 r.
PUBLISHED_CUTOFF = 1e-3
#: Distances per sweep.
SWEEP_N = 160
#: Pixels per side of the rendered planes.
PLANE_PX = 96
#: Samples along the ray used for plane energies.
RADIAL_N = 1200
#: Floors under the light (heights log-spaced from contact to 10 r) and receivers per floor.
FLOOR_HEIGHTS = 7
FLOOR_N = 48
#: Receivers of random position and orientation around the light (fixed seed).
RANDOM_N = 600
RANDOM_SEED = 19
#: Families whose range and near-field behaviour the report's findings are about.
WINDOWED = ("smooth", "hard")
MODES = ("published", "fitted")


# ============================================================================ configurations
@dataclasses.dataclass
class Sweep:
    """Facing receivers at distances `d` with the true attenuation there."""

    d: np.ndarray
    truth: np.ndarray
    stderr: np.ndarray | None
    truth0: float | None  # true attenuation at d -> 0 (None: inside the emitter)
    truth_max: float
    description: str
    #: Distances at which the curves are drawn when the truth is sparse samples (a dataset).
    dense_d: np.ndarray | None = None


@dataclasses.dataclass
class Plane:
    """A receiving plane: an image grid and a radial profile for its energy."""

    E: np.ndarray  # (ny, nx) true irradiance
    dist: np.ndarray  # distance of each pixel from the light's centre
    weight: np.ndarray  # point-light weight I g max(0, n.l)
    extent: tuple[float, float, float, float]
    xy: tuple[np.ndarray, np.ndarray]
    rho: np.ndarray | None  # radial profile (None for a dataset image)
    rdist: np.ndarray | None
    rweight: np.ndarray | None
    rE: np.ndarray | None
    description: str
    truth_label: str = "truth (exact)"
    E_exact: np.ndarray | None = None  # the exact image when E is a Monte Carlo one
    #: The pixels' receivers (px*px, 3) where the image is attenfit's own (an area model's
    #: image is drawn at them); None for a dataset's image.
    points: np.ndarray | None = None
    normals: np.ndarray | None = None


@dataclasses.dataclass
class Receivers:
    """One receiver set (docs/report.md, "The receivers that matter"): each receiver's centre
    distance `d`, point-light weight `weight` (I g max(0, n.l)), exact irradiance `E`, the
    irradiance its error is relative to (`ref`: E itself, or the irradiance a receiver facing
    the light's centre there would get) and its distance from the light's surface `gap`
    (d - r for a sphere or capsule, to the nearest point of a disk), which sets its decision
    band."""

    name: str  # "facing" | "floor" | "random"
    d: np.ndarray
    weight: np.ndarray
    E: np.ndarray
    ref: np.ndarray
    gap: np.ndarray
    description: str
    #: The receivers themselves (N x 3), for models that read their geometry (area models).
    points: np.ndarray | None = None
    normals: np.ndarray | None = None


@dataclasses.dataclass
class Config:
    name: str
    kind: str  # "sphere" | "disk" | "capsule" | "dataset"
    emitter: Any
    radius: float
    sweep: Sweep | None
    plane: Plane | None
    source: str  # "attenfit.irradiance" or the dataset's generator
    #: The receiver sets every model is judged on (facing, floor, random), by name.
    receivers: dict[str, Receivers] = dataclasses.field(default_factory=dict)
    #: For a Monte Carlo dataset: (exact - sample) / stderr at each receiver (the witness).
    witness_z: np.ndarray | None = None


def default_emitters(radius: float = DEFAULT_RADIUS) -> dict[str, Any]:
    """The report's default emitters, by name: a sphere and a one-sided disk facing down (-z).

    Both have radius `radius` (m), unit intensity and their centre at the origin.
    """

    return {
        "sphere": SphereEmitter(center=(0.0, 0.0, 0.0), radius=radius),
        "disk": DiskEmitter(center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, -1.0), radius=radius),
    }


def emitter_kind(emitter: Any) -> str:
    kind = getattr(type(emitter), "kind", None)
    if kind in ("sphere", "disk", "capsule"):
        return kind
    raise BadTypeError(
        f"emitter must be a SphereEmitter, DiskEmitter or CapsuleEmitter, got {type(emitter).__name__}"
    )


def geometry(emitter: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """(centre, unit 'down' axis along which receivers face the light, radius)."""
    kind = emitter_kind(emitter)
    r = float(np.asarray(emitter.radius))
    if kind == "capsule":
        a, b = np.asarray(emitter.a, float), np.asarray(emitter.b, float)
        c = 0.5 * (a + b)
        u = (b - a) / max(np.linalg.norm(b - a), 1e-300)
        trial = np.array([0.0, 0.0, -1.0]) if abs(u[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
        axis = trial - np.dot(trial, u) * u
        return c, axis / np.linalg.norm(axis), r
    c = np.asarray(emitter.center, float)
    if kind == "disk":
        m = np.asarray(emitter.normal, float)
        return c, m / np.linalg.norm(m), r
    return c, np.array([0.0, 0.0, -1.0]), r


_EXACT_JIT: Any = None


def exact_truth(emitter: Any, points: np.ndarray, normals: np.ndarray):
    """(E_true, d, weight) at receivers, from attenfit.irradiance and the point-light model.

    One jitted call for all the receivers of an emitter (the closed forms are many small
    operations; compiled once per emitter kind they are fast)."""
    global _EXACT_JIT
    import jax
    import jax.numpy as jnp

    if _EXACT_JIT is None:

        def both(e, p, n):
            d, w = e.point_light(p, n)
            return irradiance(e, p, n), d, w

        _EXACT_JIT = jax.jit(both)
    p = jnp.asarray(points, jnp.float64)
    n = jnp.asarray(normals, jnp.float64)
    E, d, w = _EXACT_JIT(emitter, p, n)
    return np.asarray(E, np.float64), np.asarray(d, np.float64), np.asarray(w, np.float64)


def exact_truth_parts(emitter: Any, parts: Sequence[tuple[np.ndarray, np.ndarray]]):
    """`exact_truth` over several receiver sets in one call; returns one (E, d, w) per set."""
    pts = np.concatenate([np.reshape(p, (-1, 3)) for p, _ in parts])
    nrm = np.concatenate([np.reshape(np.broadcast_to(n, np.shape(p)), (-1, 3)) for p, n in parts])
    E, d, w = exact_truth(emitter, pts, nrm)
    out, i = [], 0
    for p, _ in parts:
        k = int(np.prod(np.shape(p)[:-1]))
        out.append((E[i : i + k], d[i : i + k], w[i : i + k]))
        i += k
    return out


def frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    trial = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = trial - np.dot(trial, axis) * axis
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def emitter_config(name: str, emitter: Any, n: int, px: int) -> Config:
    """The sweep and the plane of one emitter, with the exact truth from one irradiance call."""
    kind = emitter_kind(emitter)
    c, axis, r = geometry(emitter)
    # sweep: facing receivers along the axis
    lo = 1e-3 * r if kind == "disk" else r * (1.0 + 1e-9)
    dd = np.geomspace(lo, 1e3 * r, n)
    sweep_p = c[None, :] + dd[:, None] * axis[None, :]
    # d -> 0+ for the disk, evaluated at 1e-7 r (relative change from the limit < 1e-14)
    zero_p = (c + 1e-7 * r * axis)[None, :]
    lay = _plane_layout(kind, c, axis, r, px)
    floor_p, floor_n, floor_what = _floor_receivers(kind, c, axis, r)
    rand_p, rand_n, facing_n, rand_what = _random_receivers(kind, emitter, c, axis, r)
    parts = exact_truth_parts(
        emitter,
        [(sweep_p, -axis), (zero_p, -axis), (lay["plane_p"], -axis), (lay["radial_p"], -axis),
         (floor_p, floor_n), (rand_p, rand_n), (rand_p, facing_n)],
    )  # fmt: skip
    (sE, sd, sw), (zE, _, zw), (pE, pd, pw), (rE, rd, rw) = parts[:4]
    (fE, fd, fw), (qE, qd, qw), (qF, _, _) = parts[4:]
    what_sweep = {
        "sphere": "receivers facing the centre, from contact (d = r) to 1000 r",
        "disk": "receivers on the axis facing the disk, from 0.001 r to 1000 r",
        "capsule": "receivers on the perpendicular bisector facing the segment, from contact to 1000 r",
    }[kind]
    truth = sE / sw
    truth0 = float(zE[0] / zw[0]) if kind == "disk" else None
    top = float(np.nanmax(truth)) if truth0 is None else max(truth0, float(np.nanmax(truth)))
    sweep = Sweep(d=sd, truth=truth, stderr=None, truth0=truth0, truth_max=top,
                  description=f"{what_sweep}; {n} log-spaced distances")  # fmt: skip
    half, rho_max = lay["half"], lay["rho_max"]
    plane = Plane(
        E=pE.reshape(px, px), dist=pd.reshape(px, px), weight=pw.reshape(px, px),
        extent=(-half, half, -half, half), xy=lay["xy"], rho=lay["rho"], rdist=rd, rweight=rw,
        rE=rE,
        description=(
            f"{lay['what']}; image {px} x {px} over a {2 * half:.3g} m square; energy over a "
            f"disc of radius {rho_max:.3g} m ({RADIAL_N} samples along a ray)"
        ),
        points=lay["plane_p"].reshape(-1, 3), normals=np.broadcast_to(-axis, (px * px, 3)),
    )  # fmt: skip

    def gap(pts: np.ndarray, d: np.ndarray) -> np.ndarray:
        return _gap(kind, c, axis, r, pts, d)

    receivers = {
        "facing": Receivers(
            "facing", sd, sw, sE, sE, gap(sweep_p, sd), what_sweep, *_geometry(sweep_p, -axis)
        ),
        "floor": Receivers(
            "floor", fd, fw, fE, fE, gap(floor_p, fd), floor_what, *_geometry(floor_p, floor_n)
        ),
        "random": Receivers(
            "random", qd, qw, qE, qF, gap(rand_p, qd), rand_what, *_geometry(rand_p, rand_n)
        ),
    }
    return Config(name, kind, emitter, r, sweep, plane, "attenfit.irradiance (exact)", receivers)


def _plane_layout(kind: str, c, axis, r: float, px: int) -> dict[str, Any]:
    """The plane of the images: its pixels' points, and a ray of it for the energy."""
    if kind == "disk":
        h, half = 0.25 * r, 4.0 * r
        what = f"a plane {h:g} m (r/4) below the disk, facing it"
    else:  # touching: 1e-9 r above contact, since a receiver on the sphere is invalid
        h, half = r * (1.0 + 1e-9), 1.2 * published_range(r)
        what = f"a plane touching the {kind} (its centre r = {r:g} m above it)"
    u, v = frame(axis)
    origin = c + h * axis
    xs = np.linspace(-half, half, px)
    X, Y = np.meshgrid(xs, xs)
    rho_max = max(1e3 * h, 3.0 * published_range(r))
    rho = np.concatenate([[0.0], np.geomspace(1e-3 * h, rho_max, RADIAL_N - 1)])
    return {
        "what": what,
        "half": half,
        "xy": (X, Y),
        "plane_p": origin[None, None, :] + X[..., None] * u + Y[..., None] * v,
        "rho": rho,
        "rho_max": rho_max,
        "radial_p": origin[None, :] + rho[:, None] * u[None, :],
    }


def _gap(kind: str, c, axis, r: float, pts: np.ndarray, dd: np.ndarray) -> np.ndarray:
    """The receivers' distance from the light's surface (a disk: to its nearest point)."""
    if kind != "disk":
        return np.maximum(dd - r, 0.0)
    rel = np.reshape(pts, (-1, 3)) - c
    z = rel @ axis
    q = np.linalg.norm(rel - z[:, None] * axis, axis=1)
    return np.hypot(z, np.maximum(q - r, 0.0))


def _geometry(points: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    p = np.reshape(points, (-1, 3))
    return p, np.broadcast_to(normals, p.shape).reshape(-1, 3)


def _floor_receivers(kind: str, c: np.ndarray, axis: np.ndarray, r: float):
    """Floors under the light, facing up at it: FLOOR_HEIGHTS heights from contact to 10 r,
    each with receivers from under the centre out to 100 r along two perpendicular rays."""
    lo = 1e-2 * r if kind == "disk" else r * (1.0 + 1e-9)
    hs = np.geomspace(lo, 10.0 * r, FLOOR_HEIGHTS)
    rho = np.concatenate([[0.0], np.geomspace(1e-2 * r, 100.0 * r, FLOOR_N - 1)])
    u, v = frame(axis)
    pts = [
        c + h * axis + x * e for h in hs for e in (u, v) for x in rho
    ]  # small: 2 * FLOOR_HEIGHTS * FLOOR_N points
    what = (
        f"floors facing the light at {FLOOR_HEIGHTS} heights from "
        f"{'0.01 r' if kind == 'disk' else 'contact'} to 10 r below its centre, receivers "
        "from under the centre out to 100 r"
    )
    return np.asarray(pts), -axis, what


def _random_receivers(kind: str, emitter: Any, c: np.ndarray, axis: np.ndarray, r: float):
    """RANDOM_N receivers around the light: directions uniform on the sphere, gaps from the
    light's surface log-uniform from 0.01 r to 1000 r, normals uniform on the sphere (fixed
    seed); also the normals facing the light's centre (for the error's reference)."""
    rng = np.random.default_rng(RANDOM_SEED)
    n = RANDOM_N
    dirs = rng.normal(size=(n, 3))
    dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
    gap = r * 10.0 ** rng.uniform(-2.0, 3.0, n)
    base = 0.0 if kind == "disk" else r
    if kind == "capsule":
        base += 0.5 * float(np.linalg.norm(np.asarray(emitter.b) - np.asarray(emitter.a)))
    pts = c + (base + gap)[:, None] * dirs
    nrm = rng.normal(size=(n, 3))
    nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
    what = (
        f"{n} receivers around the light, {'0.01 r' if kind == 'disk' else 'contact'} to 1000 r, "
        "random directions and orientations (error relative to a receiver facing the light there)"
    )
    return pts, nrm, -dirs, what


def check_dataset(name: str, ds: Any) -> None:
    """Refuse, before any work, a dataset the report cannot judge a curve on."""
    E = np.asarray(ds.E, np.float64).ravel()
    w = np.asarray(ds.weight(), np.float64).ravel() if len(E) else E
    if not np.any((E > 0) & (w > 0)):
        raise BadValueError(
            f"dataset {name!r} has no receiver lit from the front with E > 0 "
            f"({len(E)} receivers): there is nothing to judge a curve on"
        )


def dataset_config(name: str, ds: Any, sweep_n: int) -> Config:
    """A configuration from a Dataset: a plane image if its provenance has a 2-D shape."""
    emitter = ds.emitter
    kind = emitter_kind(emitter)
    r = float(np.asarray(emitter.radius))
    prov = dict(getattr(ds, "provenance", {}) or {})
    gen = str(prov.get("generator", "dataset"))
    d = np.asarray(ds.distance(), np.float64).ravel()
    w = np.asarray(ds.weight(), np.float64).ravel()
    E = np.asarray(ds.E, np.float64).ravel()
    se = getattr(ds, "stderr", None)
    se = None if se is None else np.broadcast_to(np.asarray(se, np.float64), E.shape).ravel()
    pts = np.asarray(ds.points, np.float64).reshape(-1, 3)
    nrm = np.asarray(np.broadcast_to(ds.normals, np.shape(ds.points)), np.float64).reshape(-1, 3)
    E_exact, _, _ = exact_truth(emitter, pts, nrm)
    z = None
    if se is not None:
        good = np.isfinite(se) & (se > 0) & np.isfinite(E)
        z = (E_exact[good] - E[good]) / se[good]
    shape = prov.get("shape")
    label = f"{gen}" + (f" {prov['variant']}, {prov['spp']} spp" if "spp" in prov else "")
    if shape is not None and len(shape) == 2:
        ny, nx = (int(s) for s in shape)
        idx = np.asarray(prov.get("grid_index", np.arange(ny * nx)), np.int64)
        if idx.size != E.size:
            raise BadValueError(
                f"dataset {name!r}: provenance grid_index has {idx.size} entries for {E.size} receivers"
            )

        def grid(values: np.ndarray) -> np.ndarray:
            img = np.full(ny * nx, np.nan)
            img[idx] = values
            return img.reshape(ny, nx)

        up = np.asarray(prov.get("up", nrm[0]), np.float64)
        ex = np.asarray(prov.get("x_axis", frame(-up)[0]), np.float64)
        ey = np.asarray(prov.get("y_axis", np.cross(up, ex)), np.float64)
        c, _, _ = geometry(emitter)
        X, Y = grid((pts - c) @ ex), grid((pts - c) @ ey)
        half = prov.get("extent")
        extent = (
            (-float(half), float(half), -float(half), float(half))
            if half is not None
            else (
                float(np.nanmin(X)),
                float(np.nanmax(X)),
                float(np.nanmin(Y)),
                float(np.nanmax(Y)),
            )
        )
        plane = Plane(
            E=grid(E),
            dist=grid(d),
            weight=grid(w),
            extent=extent,
            xy=(np.nan_to_num(X), np.nan_to_num(Y)),
            rho=None,
            rdist=None,
            rweight=None,
            rE=None,
            description=f"dataset image {ny} x {nx} ({label})",
            truth_label=f"truth ({gen})",
            E_exact=grid(E_exact),
        )
        return Config(name, kind, emitter, r, None, plane, gen, witness_z=z)
    ok = w > 0
    order = np.argsort(d[ok])
    dd, tt = d[ok][order], (E[ok] / w[ok])[order]
    ss = None if se is None else (se[ok] / w[ok])[order]
    sweep = Sweep(
        d=dd,
        truth=tt,
        stderr=ss if ss is not None and np.any(ss > 0) else None,
        truth0=None,
        truth_max=float(np.nanmax(tt)),
        description=f"{dd.size} dataset samples ({label})",
        dense_d=np.geomspace(dd.min(), dd.max(), 240) if dd.size >= 2 and dd.min() > 0 else None,
    )
    return Config(name, kind, emitter, r, sweep, None, gen, witness_z=z)


# ============================================================================ parameters
def published_range(r: float) -> float:
    """The range (m) given to windowed families as published: r / sqrt(PUBLISHED_CUTOFF)."""
    return r / math.sqrt(PUBLISHED_CUTOFF)
