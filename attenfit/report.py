"""The comparison report: how each attenuation curve approximates real lights.

`build_report(...)` evaluates every family against the exact irradiance of each emitter, both
**as published** (parameters from the family's source, with the light's radius and a range
from a documented threshold, see `published_params`) and **fitted** (least squares with
`attenfit.fit_many`), and returns a `Report`; `Report.write(folder)` writes `report.md`,
`report.json` (every number), `results.csv` (one row per family x configuration x mode) and
the figures (PNG and SVG) into a folder that appears only when complete.

Configurations (DESIGN.md section 5, generalising Yuksel 2020's Figure 3 and Madams 2011's
renders), for an emitter of radius r and unit intensity:

* **sweep**: receivers facing the light's centre, `SWEEP_N` distances log-spaced from
  contact (sphere) or 1e-3 r (disk) to 1000 r; the truth is the exact attenuation
  E_true / (I g n.l) there (DESIGN.md section 1);
* **plane**: a receiving plane under the light (the sphere touching it, the disk at r/4 above
  it), rendered on a grid for the images and integrated along a ray for its energy;
* **datasets** (e.g. Mitsuba renders, `--mitsuba FILE.npz`): a dataset whose provenance has a
  2-D `shape` is a plane image, any other a sweep against its own samples.

Everything is computed in float64 (inside `jax.enable_x64(True)`), except the cost per
evaluation, which is measured in float32 as a shader would run it.

Run as a module to regenerate the README's report section: `python -m attenfit.report --readme`.
"""

from __future__ import annotations

import csv
import dataclasses
import datetime as _dt
import io
import json
import math
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from . import metrics as M
from ._errors import BadTypeError, BadValueError, UnknownNameError

__all__ = [
    "DEFAULT_RADIUS",
    "PUBLISHED_CUTOFF",
    "PUBLISHED_RULES",
    "SWEEP_N",
    "Report",
    "build_report",
    "default_emitters",
    "published_params",
]

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
#: Families whose range and near-field behaviour the report's findings are about.
_WINDOWED = ("smooth", "hard")
_MODES = ("published", "fitted")


# ============================================================================ configurations
@dataclasses.dataclass
class _Sweep:
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
class _Plane:
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


@dataclasses.dataclass
class _Config:
    name: str
    kind: str  # "sphere" | "disk" | "capsule" | "dataset"
    emitter: Any
    radius: float
    sweep: _Sweep | None
    plane: _Plane | None
    source: str  # "attenfit.irradiance" or the dataset's generator


def default_emitters(radius: float = DEFAULT_RADIUS) -> dict[str, Any]:
    """The report's default emitters, by name: a sphere and a one-sided disk facing down (-z).

    Both have radius `radius` (m), unit intensity and their centre at the origin.
    """
    from .emitters import DiskEmitter, SphereEmitter

    return {
        "sphere": SphereEmitter(center=(0.0, 0.0, 0.0), radius=radius),
        "disk": DiskEmitter(center=(0.0, 0.0, 0.0), normal=(0.0, 0.0, -1.0), radius=radius),
    }


def _kind(emitter: Any) -> str:
    kind = getattr(type(emitter), "kind", None)
    if kind in ("sphere", "disk", "capsule"):
        return kind
    raise BadTypeError(
        f"emitter must be a SphereEmitter, DiskEmitter or CapsuleEmitter, got {type(emitter).__name__}"
    )


def _geometry(emitter: Any) -> tuple[np.ndarray, np.ndarray, float]:
    """(centre, unit 'down' axis along which receivers face the light, radius)."""
    kind = _kind(emitter)
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


def _exact(emitter: Any, points: np.ndarray, normals: np.ndarray):
    """(E_true, d, weight) at receivers, from attenfit.irradiance and the point-light model.

    One jitted call for all the receivers of an emitter (the closed forms are many small
    operations; compiled once per emitter kind they are fast)."""
    global _EXACT_JIT
    import jax
    import jax.numpy as jnp

    from ._irradiance import irradiance

    if _EXACT_JIT is None:

        def both(e, p, n):
            d, w = e.point_light(p, n)
            return irradiance(e, p, n), d, w

        _EXACT_JIT = jax.jit(both)
    p = jnp.asarray(points, jnp.float64)
    n = jnp.asarray(normals, jnp.float64)
    E, d, w = _EXACT_JIT(emitter, p, n)
    return np.asarray(E, np.float64), np.asarray(d, np.float64), np.asarray(w, np.float64)


def _exact_parts(emitter: Any, parts: Sequence[tuple[np.ndarray, np.ndarray]]):
    """`_exact` over several receiver sets in one call; returns one (E, d, w) per set."""
    pts = np.concatenate([np.reshape(p, (-1, 3)) for p, _ in parts])
    nrm = np.concatenate([np.reshape(np.broadcast_to(n, np.shape(p)), (-1, 3)) for p, n in parts])
    E, d, w = _exact(emitter, pts, nrm)
    out, i = [], 0
    for p, _ in parts:
        k = int(np.prod(np.shape(p)[:-1]))
        out.append((E[i : i + k], d[i : i + k], w[i : i + k]))
        i += k
    return out


def _frame(axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    trial = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = trial - np.dot(trial, axis) * axis
    u /= np.linalg.norm(u)
    return u, np.cross(axis, u)


def _emitter_config(name: str, emitter: Any, n: int, px: int) -> _Config:
    """The sweep and the plane of one emitter, with the exact truth from one irradiance call."""
    kind = _kind(emitter)
    c, axis, r = _geometry(emitter)
    rng = published_range(r)
    # sweep: facing receivers along the axis
    lo = 1e-3 * r if kind == "disk" else r * (1.0 + 1e-9)
    dd = np.geomspace(lo, 1e3 * r, n)
    sweep_p = c[None, :] + dd[:, None] * axis[None, :]
    # d -> 0+ for the disk, evaluated at 1e-7 r (relative change from the limit < 1e-14)
    zero_p = (c + 1e-7 * r * axis)[None, :]
    # plane
    if kind == "disk":
        h, half = 0.25 * r, 4.0 * r
        what = f"a plane {h:g} m (r/4) below the disk, facing it"
    else:  # touching: 1e-9 r above contact, since a receiver on the sphere is invalid
        h, half = r * (1.0 + 1e-9), 1.2 * rng
        what = f"a plane touching the {kind} (its centre r = {r:g} m above it)"
    u, v = _frame(axis)
    origin = c + h * axis
    xs = np.linspace(-half, half, px)
    X, Y = np.meshgrid(xs, xs)
    plane_p = origin[None, None, :] + X[..., None] * u + Y[..., None] * v
    rho_max = max(1e3 * h, 3.0 * rng)
    rho = np.concatenate([[0.0], np.geomspace(1e-3 * h, rho_max, RADIAL_N - 1)])
    radial_p = origin[None, :] + rho[:, None] * u[None, :]
    (sE, sd, sw), (zE, _, zw), (pE, pd, pw), (rE, rd, rw) = _exact_parts(
        emitter, [(sweep_p, -axis), (zero_p, -axis), (plane_p, -axis), (radial_p, -axis)]
    )
    truth = sE / sw
    truth0 = float(zE[0] / zw[0]) if kind == "disk" else None
    what_sweep = {
        "sphere": "receivers facing the centre, from contact (d = r) to 1000 r",
        "disk": "receivers on the axis facing the disk, from 0.001 r to 1000 r",
        "capsule": "receivers on the perpendicular bisector facing the segment, from contact to 1000 r",
    }[kind]
    sweep = _Sweep(
        d=sd,
        truth=truth,
        stderr=None,
        truth0=truth0,
        truth_max=float(np.nanmax(truth))
        if truth0 is None
        else max(truth0, float(np.nanmax(truth))),
        description=f"{what_sweep}; {n} log-spaced distances",
    )
    plane = _Plane(
        E=pE.reshape(px, px),
        dist=pd.reshape(px, px),
        weight=pw.reshape(px, px),
        extent=(-half, half, -half, half),
        xy=(X, Y),
        rho=rho,
        rdist=rd,
        rweight=rw,
        rE=rE,
        description=(
            f"{what}; image {px} x {px} over a {2 * half:.3g} m square; energy over a disc of "
            f"radius {rho_max:.3g} m ({RADIAL_N} samples along a ray)"
        ),
    )
    return _Config(name, kind, emitter, r, sweep, plane, "attenfit.irradiance (exact)")


def _dataset_config(name: str, ds: Any, sweep_n: int) -> _Config:
    """A configuration from a Dataset: a plane image if its provenance has a 2-D shape."""
    emitter = ds.emitter
    kind = _kind(emitter)
    r = float(np.asarray(emitter.radius))
    prov = dict(getattr(ds, "provenance", {}) or {})
    gen = str(prov.get("generator", "dataset"))
    d = np.asarray(ds.distance(), np.float64).ravel()
    w = np.asarray(ds.weight(), np.float64).ravel()
    E = np.asarray(ds.E, np.float64).ravel()
    se = getattr(ds, "stderr", None)
    se = None if se is None else np.broadcast_to(np.asarray(se, np.float64), E.shape).ravel()
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

        pts = np.asarray(ds.points, np.float64).reshape(-1, 3)
        nrm = np.asarray(ds.normals, np.float64).reshape(-1, 3)
        up = np.asarray(prov.get("up", nrm[0]), np.float64)
        ex = np.asarray(prov.get("x_axis", _frame(-up)[0]), np.float64)
        ey = np.asarray(prov.get("y_axis", np.cross(up, ex)), np.float64)
        c, _, _ = _geometry(emitter)
        E_exact, _, _ = _exact(emitter, pts, nrm)
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
        plane = _Plane(
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
        return _Config(name, kind, emitter, r, None, plane, gen)
    ok = w > 0
    order = np.argsort(d[ok])
    dd, tt = d[ok][order], (E[ok] / w[ok])[order]
    ss = None if se is None else (se[ok] / w[ok])[order]
    sweep = _Sweep(
        d=dd,
        truth=tt,
        stderr=ss if ss is not None and np.any(ss > 0) else None,
        truth0=None,
        truth_max=float(np.nanmax(tt)),
        description=f"{dd.size} dataset samples ({label})",
        dense_d=np.geomspace(dd.min(), dd.max(), 240) if dd.size >= 2 and dd.min() > 0 else None,
    )
    return _Config(name, kind, emitter, r, sweep, None, gen)


# ============================================================================ parameters
def published_range(r: float) -> float:
    """The range (m) given to windowed families as published: r / sqrt(PUBLISHED_CUTOFF)."""
    return r / math.sqrt(PUBLISHED_CUTOFF)


def _range_of(model: Any) -> float | None:
    """The centre distance at which a windowed family reaches 0 (None without a window)."""
    if type(model).window not in _WINDOWED:
        return None
    if hasattr(model, "range_distance"):
        return float(np.asarray(model.range_distance()))
    p = type(model).range_param
    return None if p is None else float(np.asarray(getattr(model, p)))


#: How `published_params` chooses each family's parameters, as written into report.md.
PUBLISHED_RULES: tuple[str, ...] = (
    'a light radius (`r`; `r_min` of `clamped` and `cryengine_linear`, "the radius of the '
    "physical object emitting the light\", RTR4) is the emitter's radius r;",
    f"a window's range is r/√{PUBLISHED_CUTOFF:g} = {1 / math.sqrt(PUBLISHED_CUTOFF):.3g} r, where "
    "the facing irradiance has fallen to 1/1000 of its value at the light's surface (Madams "
    "2011's example cutoff); Madams' warps take d_max = range − r (surface distance) and "
    "`madams_cutoff` the cutoff 1e-3 itself;",
    "`polynomial` takes Madams' kc = 1, kl = 2/r, kq = 1/r² applied to centre distance and "
    "divided by r² (kc = r², kl = 2r, kq = 1), as a renderer plugging its centre distance into "
    "Madams' factors would;",
    "a free `scale` (Just Cause 2, Unreal's exponential mode) matches the truth at d = r;",
    "engine constants (Unreal's eps = 1 cm², Frostbite's 1 cm clamp, Godot's exponent 1, "
    "three.js's decay 2, Unreal's exponent) and the spline's knots keep the family defaults.",
)


def published_params(cls: type, r: float, truth_at: Callable[[float], float] | None = None):
    """Parameters of family `cls` "as published" for a light of radius `r` (m).

    Returns `(params, note)`. The rules, from each family's source:

    * a light radius (`r`; `r_min` of `clamped` and CryEngine, "the radius of the physical
      object emitting the light", RTR4) is the emitter's radius;
    * a range (`range_param`) is `published_range(r)` = r / sqrt(1e-3), where the facing
      irradiance has fallen to 1/1000 of its value at the light's surface (Madams 2011's
      example cutoff); the Madams warps take it as d_max = range - r (surface distance);
      `madams_cutoff` takes the cutoff 1e-3 itself (so its range is the same);
    * `polynomial` takes Madams' kc = 1, kl = 2/r, kq = 1/r^2 applied to centre distance and
      divided by r^2 (kc = r^2, kl = 2 r, kq = 1), as a renderer plugging its centre
      distance into Madams' factors would;
    * a free `scale` (Just Cause 2, Unreal's exponential mode) matches the truth at d = r (the
      reference distance of RTR4 eq. 5.11 at the light's surface), via `truth_at`;
    * engine constants (Unreal's eps = 1 cm^2, Frostbite's 1 cm clamp, Godot's exponent 1,
      three.js's decay 2, Unreal's exponent) and the spline's knots keep the family defaults.
    """
    defaults = cls.defaults()
    params: dict[str, Any] = {}
    notes = []
    rng = published_range(r)
    for p, v in defaults.items():
        if p == "r" or (p == "r_min" and cls.name in ("clamped", "cryengine_linear")):
            params[p] = r
        elif p == cls.range_param:
            params[p] = rng - r if cls.name in ("madams_tan", "madams_rational") else rng
        elif cls.name == "madams_cutoff" and p == "cutoff":
            params[p] = PUBLISHED_CUTOFF
        elif cls.name == "polynomial" and p in ("kc", "kl", "kq"):
            params[p] = {"kc": r * r, "kl": 2.0 * r, "kq": 1.0}[p]
        else:
            params[p] = v
    if "scale" in params:
        model = cls(**{**params, "scale": 1.0})
        if truth_at is not None:
            params["scale"] = float(truth_at(r)) / float(np.asarray(model(np.float64(r))))
            notes.append("scale matches the truth at d = r")
    if cls.name == "spline":
        notes.append("an authored curve: no published values, defaults shown")
    return params, "; ".join(notes)


# ============================================================================ evaluation
def _eval(model: Any, d: np.ndarray) -> np.ndarray:
    """f(d) in float64 (call inside `jax.enable_x64(True)`)."""
    import jax.numpy as jnp

    with np.errstate(all="ignore"):
        return np.asarray(model(jnp.asarray(d, jnp.float64)), np.float64)


def _values(model: Any, cfg: _Config) -> dict[str, np.ndarray]:
    """The model on every distance a configuration needs, from one evaluation."""
    parts: dict[str, np.ndarray] = {}
    if cfg.sweep is not None:
        parts["sweep"] = cfg.sweep.d
        parts["zero"] = np.zeros(1)
        if cfg.sweep.dense_d is not None:
            parts["dense"] = cfg.sweep.dense_d
    if cfg.plane is not None:
        parts["plane"] = cfg.plane.dist.ravel()
        if cfg.plane.rho is not None:
            parts["radial"] = cfg.plane.rdist
    f = _eval(model, np.concatenate(list(parts.values())))
    out, i = {}, 0
    for k, v in parts.items():
        out[k] = f[i : i + v.size]
        i += v.size
    if "plane" in out:
        out["plane"] = out["plane"].reshape(cfg.plane.dist.shape)
    return out


def _sweep_metrics(
    model: Any, cfg: _Config, vals: Mapping[str, np.ndarray], rng: float | None
) -> dict[str, Any]:
    """Sweep metrics; `rng` is the range inside which `in_range` is judged (None: no window)."""
    sw = cfg.sweep
    f = vals["sweep"]
    out: dict[str, Any] = M.attenuation_errors(sw.d, f, sw.truth, cfg.radius, range_=rng)
    out["at_zero"] = M.value_at_zero(float(vals["zero"][0]), sw.truth0, sw.truth_max)
    if sw.stderr is not None:
        with np.errstate(all="ignore"):
            z = (f - sw.truth) / sw.stderr
        z = z[np.isfinite(z)]
        out["max_abs_z"] = float(np.max(np.abs(z))) if z.size else None
    return out


def _plane_metrics(model: Any, cfg: _Config, vals: Mapping[str, np.ndarray]) -> dict[str, Any]:
    pl = cfg.plane
    img = pl.weight * vals["plane"]
    out: dict[str, Any] = {"image": M.image_errors(img, pl.E, coords=pl.xy)}
    if pl.rho is not None:
        model_e = M.plane_energy(pl.rho, pl.rweight * vals["radial"])
        true_e = M.plane_energy(pl.rho, pl.rE)
        out["energy"] = {"true": true_e, "model": model_e, "ratio": model_e / true_e}
        rng = _range_of(model)
        if rng is not None:
            out["energy"]["discarded_fraction"] = M.discarded_fraction(pl.rho, pl.rE, pl.rdist, rng)
    return out


def _window_metrics(model: Any) -> dict[str, Any] | None:
    rng = _range_of(model)
    if rng is None or not math.isfinite(rng) or rng <= 0:
        return None
    out = M.window_edge(model, rng)
    out["range"] = rng
    return out


def _json_params(model: Any) -> dict[str, Any]:
    out = {}
    for k, v in model.params().items():
        a = np.asarray(v, np.float64)
        out[k] = float(a) if a.ndim == 0 else a.tolist()
    return out


# ============================================================================ cost
def _ns_per_eval(model: Any, n: int = 1 << 16, repeats: int = 7) -> float:
    """Median wall time per evaluation (ns) of a jitted float32 evaluation over `n` distances.

    A stand-in until `attenfit.cost` provides the project's measurement: the same jitted
    map, timed after compilation, median over `repeats`.
    """
    import jax
    import jax.numpy as jnp

    with jax.enable_x64(False):
        d = jnp.geomspace(1e-3, 1e3, n, dtype=jnp.float32)
        m32 = jax.tree_util.tree_map(
            lambda x: (
                jnp.asarray(x, jnp.float32) if hasattr(x, "dtype") or isinstance(x, float) else x
            ),
            model,
        )
        fn = jax.jit(lambda m, x: m(x))
        fn(m32, d).block_until_ready()
        times = []
        for _ in range(repeats):
            t0 = time.perf_counter()
            fn(m32, d).block_until_ready()
            times.append(time.perf_counter() - t0)
    return float(np.median(times) / n * 1e9)


def _costs(names: Sequence[str], instances: Mapping[str, Any]) -> dict[str, Any]:
    """Cost of each family: `attenfit.cost.cost_table` (measured ns/eval, its ratio to
    inverse-square in the same run, operation counts and shader cost); the stand-in
    `_ns_per_eval` if that fails."""
    try:
        from .cost import cost_table

        table = cost_table([instances[n] for n in names], measure=True, n=1 << 16, repeats=5)
        return {
            n: {
                "ns_per_eval": table[n].ns_per_eval,
                "ns_iqr": table[n].ns_iqr,
                "ratio_to_inverse_square": table[n].ratio_to_inverse_square,
                "shader_cost": table[n].shader_cost,
                "ops": dict(table[n].ops),
                "method": "attenfit.cost.cost_table: float32, jitted, 65536 distances, median of 5 "
                "interleaved repeats; shader cost in full-rate ALU instructions",
            }
            for n in names
        }
    except Exception as exc:  # a family the tracer cannot read: time them all the plain way
        note = f"attenfit.cost unavailable ({type(exc).__name__}: {exc}); "
    return {
        n: {
            "ns_per_eval": _ns_per_eval(instances[n]),
            "method": note + "jit float32, 65536 distances, median of 7",
        }
        for n in names
    }


# ============================================================================ the report
@dataclasses.dataclass
class Report:
    """A built comparison report: every number, and what the figures need.

    `results` has one dict per family x configuration x mode ("published" or "fitted") with
    the parameters, the fit's status and the metrics (`attenfit.metrics`); `findings` lists
    the numbers behind the seeds' claims; `configs` describes each configuration. Write it with
    `write(folder)`; `to_dict()` is what `report.json` holds.
    """

    families: list[str]
    configs: list[_Config]
    results: list[dict[str, Any]]
    findings: list[dict[str, Any]]
    costs: dict[str, Any]
    meta: dict[str, Any]
    _models: dict[tuple[str, str, str], Any] = dataclasses.field(default_factory=dict, repr=False)
    #: (family, configuration, mode) -> the model's values on the configuration's distances.
    _values: dict[tuple[str, str, str], dict[str, np.ndarray]] = dataclasses.field(
        default_factory=dict, repr=False
    )
    #: Figures drawn while the fits ran (`_report_figures.prerender`): key -> (PNG, SVG).
    _prerendered: dict[str, tuple[bytes, bytes | None]] = dataclasses.field(
        default_factory=dict, repr=False
    )

    # ------------------------------------------------------------------ access
    def result(self, family: str, config: str, mode: str = "published") -> dict[str, Any]:
        """The result row of `family` on configuration `config` in `mode`."""
        for row in self.results:
            if row["family"] == family and row["config"] == config and row["mode"] == mode:
                return row
        raise UnknownNameError(
            f"no result for family {family!r}, configuration {config!r}, mode {mode!r}"
        )

    def finding(self, key: str) -> dict[str, Any]:
        """The finding `key` (see `findings`)."""
        for f in self.findings:
            if f["key"] == key:
                return f
        raise UnknownNameError(
            f"no finding {key!r}; findings: {', '.join(f['key'] for f in self.findings)}"
        )

    def to_dict(self) -> dict[str, Any]:
        """Every number of the report, JSON-ready (what report.json holds)."""
        cfgs = []
        for c in self.configs:
            cfgs.append(
                {
                    "name": c.name,
                    "kind": c.kind,
                    "radius": c.radius,
                    "emitter": _emitter_dict(c.emitter),
                    "source": c.source,
                    "sweep": None
                    if c.sweep is None
                    else {
                        "description": c.sweep.description,
                        "n": int(c.sweep.d.size),
                        "d_min": float(c.sweep.d.min()),
                        "d_max": float(c.sweep.d.max()),
                        "truth_at_zero": c.sweep.truth0,
                        "truth_max": c.sweep.truth_max,
                    },
                    "plane": None if c.plane is None else {"description": c.plane.description},
                }
            )
        return _jsonable(
            {
                "meta": self.meta,
                "families": self.families,
                "configurations": cfgs,
                "findings": self.findings,
                "costs": self.costs,
                "results": self.results,
            }
        )

    # ------------------------------------------------------------------ tables
    def csv_rows(self) -> list[dict[str, Any]]:
        """One flat row per family x configuration x mode (what results.csv holds)."""
        rows = []
        for r in self.results:
            sw = r.get("sweep") or {}
            ov = sw.get("overall") or {}
            bands = sw.get("bands") or {}
            inr = sw.get("in_range") or {}
            z = sw.get("at_zero") or {}
            pl = r.get("plane") or {}
            img = pl.get("image") or {}
            en = pl.get("energy") or {}
            win = r.get("window") or {}
            rows.append(
                {
                    "family": r["family"],
                    "configuration": r["config"],
                    "mode": r["mode"],
                    "status": r["status"],
                    "params": json.dumps(r.get("params"), sort_keys=True),
                    "max_abs_rel_error": ov.get("max_abs"),
                    "rms_rel_error": ov.get("rms"),
                    "worst_at_d": ov.get("worst_at"),
                    **{
                        f"{b}_{k}": (bands.get(b) or {}).get(s)
                        for b in M.BANDS
                        for k, s in (("max_abs", "max_abs"), ("rms", "rms"))
                    },
                    "in_range_max_abs": inr.get("max_abs"),
                    "in_range_rms": inr.get("rms"),
                    "inner_half_max_abs": (sw.get("inner_half") or {}).get("max_abs"),
                    "reach_1pct_of_range": (sw.get("reach") or {}).get("1%"),
                    "reach_10pct_of_range": (sw.get("reach") or {}).get("10%"),
                    "f_at_0": z.get("value"),
                    "f_at_0_over_truth": z.get("ratio"),
                    "range": win.get("range"),
                    "edge_value_rel": win.get("value_rel"),
                    "edge_slope_rel": win.get("slope_rel"),
                    "plane_energy_ratio": en.get("ratio"),
                    "plane_energy_discarded": en.get("discarded_fraction"),
                    "image_max_abs": img.get("max_abs"),
                    "image_rms": img.get("rms"),
                    "ns_per_eval": (self.costs.get(r["family"]) or {}).get("ns_per_eval"),
                }
            )
        return rows

    def summary_markdown(self) -> str:
        """The summary table: one row per family, worst error per configuration and mode."""
        sweeps = [c for c in self.configs if c.sweep is not None]
        head = ["family"]
        for c in sweeps:
            head += [f"{c.name}: published", f"{c.name}: fitted"]
        zero_cfg = next((c for c in sweeps if c.sweep.truth0 is not None), None)
        if zero_cfg is not None:
            head.append(f"f(0) / truth(0), {zero_cfg.name}")
        plane_cfg = next(
            (c for c in self.configs if c.plane is not None and c.plane.rho is not None), None
        )
        if plane_cfg is not None:
            head.append(f"plane energy / truth, {plane_cfg.name}")
        head.append("shader cost")
        lines = [_md_row(head), _md_row(["---"] + ["---:"] * (len(head) - 1))]
        for fam in self.families:
            row = [f"`{fam}`"]
            for c in sweeps:
                for mode in _MODES:
                    row.append(_cell_error(self._get(fam, c.name, mode)))
            if zero_cfg is not None:
                z = ((self._get(fam, zero_cfg.name, "published") or {}).get("sweep") or {}).get(
                    "at_zero"
                ) or {}
                row.append(_fmt_num(z.get("ratio"), inf_text="∞ (singular)"))
            if plane_cfg is not None:
                en = ((self._get(fam, plane_cfg.name, "published") or {}).get("plane") or {}).get(
                    "energy"
                ) or {}
                row.append(_fmt_num(en.get("ratio")))
            row.append(_fmt_num((self.costs.get(fam) or {}).get("shader_cost"), digits=3))
            lines.append(_md_row(row))
        note = (
            "Cells: the largest |relative error| (model − truth)/truth over each configuration's "
            "sweep (windowed families, marked ᵂ: over the inner half of their range, d ≤ range/2; "
            "near the range every window must deviate, and beyond it it is black by design; the "
            "report's Windows table has the rest). *published*: the source's parameters for this light; *fitted*: least squares "
            "on the relative error. Plane energy: the published curve on the plane with the "
            f"light {'touching it' if plane_cfg is not None and plane_cfg.kind == 'sphere' else 'above it'}. "
            "Shader cost: full-rate ALU instructions per evaluation (`attenfit.cost`; measured "
            "times are in report.json and results.csv)."
        )
        return "\n".join(lines) + "\n\n" + note + "\n"

    def cost_markdown(self) -> str:
        """One row per family: shader cost, measured time per evaluation, ratio to 1/d^2."""
        lines = [
            _md_row(["family", "shader cost (ALU ops)", "ns / eval", "time / inverse_square"]),
            _md_row(["---", "---:", "---:", "---:"]),
        ]
        for fam in self.families:
            c = self.costs.get(fam) or {}
            lines.append(
                _md_row(
                    [
                        f"`{fam}`",
                        _fmt_num(c.get("shader_cost")),
                        _fmt_num(c.get("ns_per_eval"), digits=2),
                        _fmt_num(c.get("ratio_to_inverse_square"), digits=2),
                    ]
                )
            )
        method = next(iter(self.costs.values())).get("method", "")
        return "\n".join(lines) + f"\n\n{method}; times are of this machine and this run.\n"

    def _get(self, fam: str, cfg: str, mode: str) -> dict[str, Any] | None:
        try:
            return self.result(fam, cfg, mode)
        except UnknownNameError:
            return None

    def findings_markdown(self) -> str:
        """The findings that are not about one window, with the closed-form value where known."""
        lines = [
            _md_row(["quantity", "value", "closed form", "configuration"]),
            _md_row(["---", "---:", "---:", "---"]),
        ]
        for f in self.findings:
            if f["key"].startswith("window_"):
                continue
            lines.append(
                _md_row(
                    [
                        f["quantity"],
                        _fmt_num(f["value"], digits=6),
                        _fmt_num(f.get("expected"), digits=6),
                        f.get("config", ""),
                    ]
                )
            )
        return "\n".join(lines) + "\n"

    def windows_markdown(self) -> str:
        """One row per windowed family: its deviation inside the range and what it drops."""
        cfg = next(
            (
                c
                for c in self.configs
                if c.sweep is not None and c.plane is not None and c.plane.rho is not None
            ),
            None,
        )
        if cfg is None:
            return ""
        head = [
            "family",
            "window",
            "range (m)",
            "max |error|, d ≤ range/2",
            "off by > 1% from",
            "off by > 10% from",
            "f·d² at range",
            "slope vs 1/d² at range",
            "true energy beyond range",
            "plane energy / truth",
        ]
        lines = [_md_row(head), _md_row(["---", "---"] + ["---:"] * (len(head) - 2))]
        from ._family import get_family

        n = 0
        for fam in self.families:
            try:
                kind = get_family(fam).window
            except Exception:
                continue
            r = self._get(fam, cfg.name, "published")
            if kind not in _WINDOWED or r is None or r["status"] != "ok":
                continue
            half = (r["sweep"] or {}).get("inner_half") or {}
            reach = (r["sweep"] or {}).get("reach") or {}
            win = r.get("window") or {}
            en = (r["plane"] or {}).get("energy") or {}
            lines.append(
                _md_row(
                    [
                        f"`{fam}`",
                        kind,
                        _fmt_num(win.get("range")),
                        _fmt_pct(half.get("max_abs")),
                        _fmt_reach(reach.get("1%")),
                        _fmt_reach(reach.get("10%")),
                        _fmt_num(win.get("value_rel"), digits=2),
                        _fmt_num(win.get("slope_rel"), digits=2),
                        _fmt_pct(en.get("discarded_fraction")),
                        _fmt_num(en.get("ratio"), digits=4),
                    ]
                )
            )
            n += 1
        if not n:
            return ""
        return (
            f"Against the {cfg.name}, as published; energies on {cfg.plane.description.split(';')[0]}. "
            "'Off by > 1% from': the fraction of the range beyond which the curve is off by more "
            "than 1% all the way to the range. f·d² and the slope are taken just inside the range, relative to inverse-square there "
            "(0 and 0: the window closes smoothly; 1 and 1: no window). The energy columns "
            "integrate the irradiance over the plane.\n\n" + "\n".join(lines) + "\n"
        )

    def markdown(self, figures: Mapping[str, str] | None = None) -> str:
        """report.md: the summary table, the findings, then one section per configuration."""
        figures = figures or {}
        m = self.meta
        out = [
            "# attenfit comparison report",
            "",
            f"attenfit {m['version']}, {m['created']}; {len(self.families)} families, "
            f"{len(self.configs)} configurations; built in {m['build_seconds']:.1f} s. "
            "Every number is in `report.json`, one row per family × configuration × mode in "
            "`results.csv`. Lights have unit intensity; distances in m, attenuation in 1/m².",
            "",
            "## Summary",
            "",
            self.summary_markdown(),
            "## Findings",
            "",
            "The numbers behind the seeds' claims (report.json `findings`).",
            "",
            self.findings_markdown(),
        ]
        win = self.windows_markdown()
        if win:
            out += ["### Windows: what each range costs inside it and what it drops", "", win]
        for c in self.configs:
            out += self._config_markdown(c, figures)
        if self.costs:
            out += ["## Cost against error", "", self.cost_markdown(), ""]
        if "cost_vs_error" in figures:
            out += [f"![cost against error]({figures['cost_vs_error']})", ""]
        out += [
            "## How the numbers were made",
            "",
            f"* Truth: {', '.join(sorted({c.source for c in self.configs}))}; computed in float64.",
            "* As published (`published_params`):",
            *(f"  * {rule}" for rule in PUBLISHED_RULES),
            "* Fitted: `attenfit.fit_many` (every family in one solve), relative loss, each family's "
            "default free parameters, "
            "started from the published values; windowed families are fitted inside their "
            "range only (weights 0 beyond it). A fit that does not converge is marked and its "
            "numbers are not shown.",
            "* Bands: near d < r, mid r ≤ d ≤ 10 r, far d > 10 r. Plane images: relative error "
            "against max(truth, 1e-6 × peak).",
            "* Cost: "
            + (next(iter(self.costs.values()))["method"] if self.costs else "not measured")
            + ".",
            "",
        ]
        return "\n".join(out)

    def _config_markdown(self, c: _Config, figures: Mapping[str, str]) -> list[str]:
        out = [f"## {c.name}", "", f"{_describe_emitter(c)}", ""]
        if c.sweep is not None:
            out += [f"Sweep: {c.sweep.description}.", ""]
        if c.plane is not None:
            out += [f"Plane: {c.plane.description}.", ""]
        for key, alt in (
            ("attenuation_published", "attenuation, as published"),
            ("attenuation_fitted", "attenuation, fitted"),
            ("error_published", "relative error, as published"),
            ("error_fitted", "relative error, fitted"),
            ("plane_errors", "plane error maps"),
            ("plane_side_by_side", "plane renders"),
        ):
            k = f"{c.name}_{key}"
            if k in figures:
                out += [f"![{c.name}: {alt}]({figures[k]})", ""]
        out += [self._config_table(c), ""]
        return out

    def _config_table(self, c: _Config) -> str:
        head = ["family", "mode", "status", "parameters"]
        if c.sweep is not None:
            head += ["max", "rms", "near", "mid", "far", "in range", "f(0)/truth"]
        if c.plane is not None:
            head += ["image max", "image rms"]
            if c.plane.rho is not None:
                head += ["energy ratio", "energy dropped"]
        head += ["edge value", "edge slope"]
        lines = [_md_row(head), _md_row(["---"] * 4 + ["---:"] * (len(head) - 4))]
        for fam in self.families:
            for mode in _MODES:
                r = self._get(fam, c.name, mode)
                if r is None:
                    continue
                ok = r["status"] == "ok"
                row = [f"`{fam}`", mode, r["status"], _fmt_params(r.get("params")) if ok else "—"]
                sw, pl, win = r.get("sweep") or {}, r.get("plane") or {}, r.get("window") or {}
                if c.sweep is not None:
                    b = sw.get("bands") or {}
                    row += [
                        _fmt_pct((sw.get("overall") or {}).get("max_abs")),
                        _fmt_pct((sw.get("overall") or {}).get("rms")),
                        *(_fmt_pct((b.get(k) or {}).get("max_abs")) for k in M.BANDS),
                        _fmt_pct((sw.get("in_range") or {}).get("max_abs")),
                        _fmt_num((sw.get("at_zero") or {}).get("ratio"), inf_text="∞"),
                    ]
                if c.plane is not None:
                    img = pl.get("image") or {}
                    row += [_fmt_pct(img.get("max_abs")), _fmt_pct(img.get("rms"))]
                    if c.plane.rho is not None:
                        en = pl.get("energy") or {}
                        row += [_fmt_num(en.get("ratio")), _fmt_pct(en.get("discarded_fraction"))]
                row += [
                    _fmt_num(win.get("value_rel"), digits=2),
                    _fmt_num(win.get("slope_rel"), digits=2),
                ]
                if not ok:
                    row = row[:4] + ["—"] * (len(row) - 4)
                lines.append(_md_row(row))
        note = (
            "max/rms/near/mid/far/in range: |relative error|; f(0)/truth: the curve at d = 0 over "
            "the true limit; edge value and slope: f and f′ just inside the range relative to "
            "inverse-square there (0 = the window closes; slope 0 = smoothly)."
        )
        return "\n".join(lines) + "\n\n" + note

    # ------------------------------------------------------------------ writing
    def write(
        self,
        folder: str | Path,
        *,
        force: bool = False,
        dpi: int = 100,
        svg: bool = True,
        progress: Callable[[str], None] | None = None,
    ) -> Path:
        """Write the report into `folder` (created; replaced only with `force`).

        The files go to a temporary folder that is moved into place only when everything is
        written (`attenfit._atomic.atomic_dir`), so an interrupted run leaves any previous
        report intact. Returns the folder's path.
        """
        from ._atomic import atomic_dir, check_output_path

        check_output_path(folder, force=force, folder=True)
        with atomic_dir(folder, force=force) as tmp:
            figs = self.write_figures(tmp / "figures", dpi=dpi, svg=svg, progress=progress)
            if progress is not None:
                progress("tables: report.md, report.json, results.csv")
            rel = {k: f"figures/{Path(v).name}" for k, v in figs.items()}
            (tmp / "report.md").write_text(self.markdown(rel), encoding="utf-8")
            (tmp / "report.json").write_text(
                json.dumps(self.to_dict(), indent=1, allow_nan=False) + "\n", encoding="utf-8"
            )
            (tmp / "results.csv").write_text(self.csv_text(), encoding="utf-8")
            if progress is not None:
                progress(f"complete; moving it into place as {folder}")
        return Path(folder)

    def csv_text(self) -> str:
        rows = self.csv_rows()
        buf = io.StringIO()
        w = csv.DictWriter(
            buf, fieldnames=list(rows[0]) if rows else ["family"], lineterminator="\n"
        )
        w.writeheader()
        for row in rows:
            w.writerow({k: ("" if v is None else v) for k, v in row.items()})
        return buf.getvalue()

    def write_figures(
        self,
        folder: str | Path,
        *,
        dpi: int = 100,
        svg: bool = True,
        progress: Callable[[str], None] | None = None,
    ) -> dict[str, Path]:
        """Draw every figure into `folder` (PNG, and SVG when `svg`); return key -> PNG path."""
        from . import _report_figures

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        pre = self._prerendered if dpi == 100 else {}
        return _report_figures.draw_all(
            self, folder, dpi=dpi, svg=svg, progress=progress, prerendered=pre
        )


# ============================================================================ formatting
def _md_row(cells: Iterable[Any]) -> str:
    return "| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |"


def _fmt_num(x: Any, digits: int = 3, inf_text: str = "∞") -> str:
    if x is None:
        return "—"
    x = float(x)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return inf_text if x > 0 else "−∞"
    return f"{x:.{digits}g}"


def _fmt_pct(x: Any) -> str:
    if x is None:
        return "—"
    x = float(x)
    if math.isinf(x):
        return "∞"
    if math.isnan(x):
        return "—"
    p = 100.0 * x
    if p == 0:
        return "0%"
    if abs(p) < 0.01:
        return f"{p:.1e}%"
    return f"{p:.3g}%"


def _fmt_reach(x: Any) -> str:
    return "—" if x is None else f"{float(x):.2f} × range"


def _cell_error(r: dict[str, Any] | None) -> str:
    if r is None:
        return "—"
    if r["status"] != "ok":
        return "fit failed"
    sw = r.get("sweep") or {}
    if sw.get("inner_half") is not None:
        return _fmt_pct(sw["inner_half"].get("max_abs")) + " ᵂ"
    return _fmt_pct((sw.get("overall") or {}).get("max_abs"))


def _fmt_params(p: Mapping[str, Any] | None) -> str:
    if not p:
        return "none"
    parts = []
    for k, v in p.items():
        if isinstance(v, list):
            parts.append(f"{k}=[{', '.join(f'{x:.3g}' for x in v)}]")
        else:
            parts.append(f"{k}={v:.4g}")
    return ", ".join(parts)


def _describe_emitter(c: _Config) -> str:
    e = c.emitter
    if c.kind == "sphere":
        return f"A Lambertian sphere of radius r = {c.radius:g} m, unit intensity (L = 1/(π r²)). Truth: {c.source}."
    if c.kind == "disk":
        return f"A one-sided Lambertian disk of radius r = {c.radius:g} m facing {tuple(float(x) for x in np.asarray(e.normal))}, unit on-axis intensity. Truth: {c.source}."
    return f"A {c.kind} light of radius r = {c.radius:g} m. Truth: {c.source}."


def _emitter_dict(e: Any) -> Any:
    to = getattr(e, "to_dict", None)
    if callable(to):
        try:
            return to()
        except Exception:
            pass
    return {"kind": type(e).__name__, "radius": float(np.asarray(e.radius))}


def _jsonable(x: Any) -> Any:
    """Replace non-finite floats by strings ("inf", "-inf", "nan") and arrays by lists."""
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        x = float(x)
        return x if math.isfinite(x) else str(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, np.bool_):
        return bool(x)
    return x


# ============================================================================ building
def _resolve_families(families: Sequence[str | type] | None) -> list[type]:
    from . import families as _families  # noqa: F401  (registers the named families)
    from ._family import Family, get_family, list_families

    if families is None:
        return [get_family(n) for n in list_families()]
    if isinstance(families, str):
        families = [families]
    out = []
    for f in families:
        if isinstance(f, str):
            out.append(get_family(f))
        elif isinstance(f, type) and issubclass(f, Family):
            out.append(f)
        else:
            raise BadTypeError(f"families must be names or Family subclasses, got {f!r}")
    if not out:
        raise BadValueError("families must name at least one family")
    return out


def _resolve_emitters(emitters: Sequence[Any] | Mapping[str, Any] | None) -> dict[str, Any]:
    if emitters is None:
        return default_emitters()
    if isinstance(emitters, Mapping):
        return dict(emitters)
    if isinstance(emitters, str):
        emitters = [emitters]
    out: dict[str, Any] = {}
    defaults = None
    for e in emitters:
        if isinstance(e, str):
            defaults = defaults or default_emitters()
            if e not in defaults:
                raise UnknownNameError(
                    f"unknown emitter {e!r}; the report knows {', '.join(defaults)}"
                )
            out[e] = defaults[e]
        else:
            name = _kind(e)
            k, i = name, 2
            while k in out:
                k, i = f"{name}{i}", i + 1
            out[k] = e
    return out


def _as_float64(ems: dict[str, Any]) -> dict[str, Any]:
    """The emitters rebuilt with float64 fields (the report computes in float64)."""
    from .emitters import emitter_from_dict

    return {k: emitter_from_dict(e.to_dict()) for k, e in ems.items()}


def _stack_params(starts: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    return {k: np.stack([np.asarray(s[k], np.float64) for s in starts]) for k in starts[0]}


def build_report(
    families: Sequence[str | type] | None = None,
    emitters: Sequence[Any] | Mapping[str, Any] | None = None,
    datasets: Sequence[Any] | Mapping[str, Any] | None = None,
    *,
    fitted: bool = True,
    sweep_n: int = SWEEP_N,
    plane_px: int = PLANE_PX,
    cost: bool = True,
    progress: Callable[[str], None] | None = None,
) -> Report:
    """Compare `families` (default: every registered one) against `emitters` and `datasets`.

    Args:
        families: family names or classes.
        emitters: emitters or their names in `default_emitters()` ("sphere", "disk"); a mapping
            gives them names. Default: the sphere and the disk.
        datasets: `attenfit.Dataset`s (e.g. Mitsuba renders), or a mapping name -> dataset;
            each adds a configuration (see the module docstring).
        fitted: also fit every family (the "fitted" mode); False gives "published" only.
        sweep_n, plane_px: samples per sweep and pixels per plane side.
        cost: measure the cost per evaluation of each family.
        progress: called with one line per stage (the CLI prints it on stderr).
    """
    import jax

    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    classes = _resolve_families(families)
    if isinstance(datasets, Mapping):
        ds_items = list(datasets.items())
    else:
        ds_items = []
        for i, ds in enumerate(datasets or []):
            prov = dict(getattr(ds, "provenance", {}) or {})
            ds_items.append((f"{prov.get('generator', 'dataset')}-{i + 1}", ds))
    if int(sweep_n) < 8 or int(plane_px) < 8:
        raise BadValueError(f"sweep_n and plane_px must be >= 8, got {sweep_n} and {plane_px}")
    timings: dict[str, float] = {}
    configs: list[_Config] = []
    with jax.enable_x64(True):
        ems = _as_float64(_resolve_emitters(emitters))
        t = time.perf_counter()
        for name, em in ems.items():
            say(f"truth: {name} ({sweep_n} distances, {plane_px} x {plane_px} plane)")
            configs.append(_emitter_config(name, em, int(sweep_n), int(plane_px)))
        for name, ds in ds_items:
            say(f"dataset: {name} ({len(ds)} samples)")
            configs.append(_dataset_config(name, ds, int(sweep_n)))
        timings["truth"] = time.perf_counter() - t

        results: list[dict[str, Any]] = []
        models: dict[tuple[str, str, str], Any] = {}
        values: dict[tuple[str, str, str], dict[str, np.ndarray]] = {}
        t = time.perf_counter()
        say(f"published: {len(classes)} families x {len(configs)} configurations")
        pub: dict[tuple[str, str], tuple[dict, str]] = {}
        for cls in classes:
            for c in configs:
                truth_at = _truth_at(c)
                params, note = published_params(cls, c.radius, truth_at)
                pub[(cls.name, c.name)] = (params, note)
                model = cls(**params)
                models[(cls.name, c.name, "published")] = model
                results.append(_evaluate(cls.name, c, "published", model, note=note, store=values))
        timings["published"] = time.perf_counter() - t

        painter = _start_prerender(classes, configs, results, models, values) if fitted else None
        if fitted:
            t = time.perf_counter()
            sweep_cfgs = [c for c in configs if c.sweep is not None]
            say(
                f"fit: {len(classes)} families x {len(sweep_cfgs)} configurations (one fit_many solve)"
            )
            _fit_families(classes, sweep_cfgs, pub, models, results, values)
            # a plane-only configuration (a dataset image) shows the fits of its emitter kind
            for c in configs:
                if c.sweep is None:
                    for cls in classes:
                        src = next(
                            (
                                s
                                for s in sweep_cfgs
                                if s.kind == c.kind and (cls.name, s.name, "fitted") in models
                            ),
                            None,
                        )
                        if src is not None:
                            m = models[(cls.name, src.name, "fitted")]
                            models[(cls.name, c.name, "fitted")] = m
                            results.append(
                                _evaluate(
                                    cls.name,
                                    c,
                                    "fitted",
                                    m,
                                    note=f"fitted on {src.name}",
                                    store=values,
                                )
                            )
            timings["fit"] = time.perf_counter() - t

        findings = _findings(classes, configs, results, models)
    prerendered = painter.result() if painter is not None else {}  # joined before timing costs
    costs: dict[str, Any] = {}
    if cost:
        t = time.perf_counter()
        say(f"cost: {len(classes)} families")
        costs = _costs(
            [c.name for c in classes],
            {cls.name: models[(cls.name, configs[0].name, "published")] for cls in classes},
        )
        timings["cost"] = time.perf_counter() - t
    from . import __version__

    meta = {
        "version": __version__,
        "created": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "build_seconds": time.perf_counter() - t_start,
        "timings": timings,
        "published_cutoff": PUBLISHED_CUTOFF,
        "sweep_n": int(sweep_n),
        "plane_px": int(plane_px),
        "jax": jax.__version__,
        "backend": jax.default_backend(),
    }
    return Report(
        [c.name for c in classes],
        configs,
        results,
        findings,
        costs,
        meta,
        models,
        values,
        prerendered,
    )


class _Painter:
    """A thread drawing the published figures while the fits run (see `_report_figures.prerender`)."""

    def __init__(self, report: Report):
        import threading

        self._report = report
        self._out: dict[str, tuple[bytes, bytes | None]] = {}
        self._thread = threading.Thread(target=self._run, name="attenfit-figures", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from . import _report_figures

        try:
            self._out = _report_figures.prerender(self._report)
        except Exception:  # drawn again, in the main thread, by Report.write
            self._out = {}

    def result(self) -> dict[str, tuple[bytes, bytes | None]]:
        self._thread.join()
        return self._out


def _start_prerender(classes, configs, results, models, values) -> _Painter | None:
    """Start drawing the published figures in a thread (None if threads are unavailable)."""
    published = [r for r in results if r["mode"] == "published"]
    draft = Report(
        [c.name for c in classes], configs, published, [], {}, {}, dict(models), dict(values)
    )
    try:
        return _Painter(draft)
    except RuntimeError:
        return None


def _truth_at(c: _Config) -> Callable[[float], float] | None:
    if c.sweep is None:
        return None
    sw = c.sweep

    def at(d: float) -> float:
        # log-log interpolation of the sampled truth (the sweep starts at or below r)
        return float(np.exp(np.interp(np.log(d), np.log(sw.d), np.log(sw.truth))))

    return at


def _evaluate(
    fam: str,
    c: _Config,
    mode: str,
    model: Any,
    *,
    note: str = "",
    fit: Any = None,
    store: dict | None = None,
    range_: float | None = None,
) -> dict[str, Any]:
    row: dict[str, Any] = {
        "family": fam,
        "config": c.name,
        "mode": mode,
        "status": "ok",
        "note": note,
        "params": _json_params(model),
        "sweep": None,
        "plane": None,
        "window": None,
    }
    if fit is not None:
        row["fit"] = fit
    try:
        vals = _values(model, c)
        if store is not None:
            store[(fam, c.name, mode)] = vals
        rng = _range_of(model) if range_ is None else range_
        if c.sweep is not None:
            row["sweep"] = _sweep_metrics(model, c, vals, rng)
        if c.plane is not None:
            row["plane"] = _plane_metrics(model, c, vals)
        row["window"] = _window_metrics(model)
    except Exception as exc:  # a family that fails to evaluate is marked, not dropped
        row["status"] = f"error: {type(exc).__name__}: {exc}"
        row["sweep"] = row["plane"] = row["window"] = None
    return row


def _fit_range(cls: type, start: Mapping[str, Any]) -> float | None:
    """The range inside which a windowed family is fitted and judged: its published one."""
    return _range_of(cls(**start))


def _fit_families(classes, sweep_cfgs, pub, models, results, values) -> None:
    """Fit every family on every sweep, in one solve per sample count (`_report_fit`).

    Windowed families are fitted inside their published range (weights 0 beyond it). If the
    combined solve fails as a whole, each family is fitted on its own with `fit_many`.
    """
    from ._report_fit import fit_all

    groups: dict[int, list[_Config]] = {}
    for c in sweep_cfgs:
        groups.setdefault(int(c.sweep.d.size), []).append(c)
    for cfgs in groups.values():
        problems, keys = [], []
        for cls in classes:
            for c in cfgs:
                start = pub[(cls.name, c.name)][0]
                rg = _fit_range(cls, start)
                w = (
                    (c.sweep.d < rg).astype(np.float64)
                    if rg is not None
                    else np.ones_like(c.sweep.d)
                )
                problems.append((cls, start, c.sweep.d, c.sweep.truth, w))
                keys.append((cls, c, rg))
        try:
            outs = fit_all(problems)
        except Exception as exc:  # e.g. a user's family that cannot be traced under a switch
            outs = [None] * len(problems)
            error = f"{type(exc).__name__}: {exc}"

        def start_of(cls, c):
            return pub[(cls.name, c.name)][0]

        for (cls, c, rg), out in zip(keys, outs, strict=True):
            if out is None:
                results.append(_failed(cls.name, c, f"fit error: {error}"))
                continue
            params, info = out
            if params is None:
                results.append(
                    _failed(
                        cls.name, c, f"fit did not converge: {_why(info, start_of(cls, c))}", info
                    )
                )
                continue
            try:
                model = cls(**params)
            except Exception as exc:
                results.append(_failed(cls.name, c, f"fitted parameters rejected: {exc}", info))
                continue
            models[(cls.name, c.name, "fitted")] = model
            note = f"free: {', '.join(info['free']) or 'none'}"
            moved = _moved(info, start_of(cls, c))
            if moved:  # converged where the loss reached rounding level, the optimum at a limit
                note += f"; {'; '.join(moved)}: no finite optimum"
            results.append(
                _evaluate(
                    cls.name, c, "fitted", model, note=note, fit=info, store=values, range_=rg
                )
            )


def _moved(info: Mapping[str, Any], start: Mapping[str, Any]) -> list[str]:
    """The positive scalar parameters a fit drove towards 0 or infinity, in words."""
    moved = []
    for k, v in (info.get("last_params") or {}).items():
        s0 = start.get(k)
        if s0 is None or np.ndim(v) or np.ndim(s0) or not float(s0) > 0:
            continue
        if 0 <= float(v) < 1e-2 * float(s0):
            moved.append(f"{k} heads to 0 ({k} = {float(v):.2g})")
        elif float(v) > 30 * float(s0):
            moved.append(f"{k} heads to infinity ({k} = {float(v):.3g})")
    return moved


def _why(info: Mapping[str, Any], start: Mapping[str, Any]) -> str:
    """Why a fit did not converge, in words: a parameter running off to a bound says so."""
    moved = _moved(info, start)
    if moved:
        return (
            f"no finite optimum: {'; '.join(moved)} after {info.get('steps')} steps, "
            f"loss {float(info.get('loss', float('nan'))):.2g}"
        )
    return str(info.get("message", ""))


def _failed(fam: str, c: _Config, status: str, info: dict | None = None) -> dict[str, Any]:
    row = {
        "family": fam,
        "config": c.name,
        "mode": "fitted",
        "status": status,
        "note": "",
        "params": None,
        "sweep": None,
        "plane": None,
        "window": None,
    }
    if info is not None:
        row["fit"] = info
    return row


# ============================================================================ findings
def _findings(classes, configs, results, models) -> list[dict[str, Any]]:
    """The numbers behind the seeds' claims, each from the results or a direct evaluation."""
    names = {c.name for c in classes}
    out: list[dict[str, Any]] = []

    def row(fam, cfg, mode):
        for r in results:
            if r["family"] == fam and r["config"] == cfg and r["mode"] == mode:
                return r
        return None

    def add(key, quantity, value, config="", expected=None):
        out.append(
            {
                "key": key,
                "quantity": quantity,
                "value": value,
                "config": config,
                "expected": expected,
            }
        )

    sphere = next(
        (
            c
            for c in configs
            if c.kind == "sphere" and c.sweep is not None and c.source.startswith("attenfit")
        ),
        None,
    )
    disk = next(
        (
            c
            for c in configs
            if c.kind == "disk" and c.sweep is not None and c.source.startswith("attenfit")
        ),
        None,
    )

    if sphere is not None and "inverse_square" in names:
        r = row("inverse_square", sphere.name, "published")
        if r and r["sweep"]:
            add(
                "sphere_inverse_square_max_error",
                "inverse-square vs the sphere, receivers facing it from contact to 1000 r: max |rel. error|",
                r["sweep"]["overall"]["max_abs"],
                sphere.name,
                0.0,
            )
        if r and r["plane"]:
            add(
                "sphere_plane_inverse_square_max_error",
                "inverse-square vs the sphere touching a plane (every receiver unclipped): image max |rel. error|",
                r["plane"]["image"]["max_abs"],
                sphere.name,
                0.0,
            )
    if disk is not None:
        r = disk.radius
        sw = disk.sweep
        if "inverse_square" in names:
            rr = row("inverse_square", disk.name, "published")
            if rr and rr["sweep"]:
                add(
                    "disk_inverse_square_near_max_error",
                    "inverse-square vs the facing disk, near band d < r: max |rel. error|",
                    rr["sweep"]["bands"]["near"]["max_abs"],
                    disk.name,
                )
        for fam, key, what in (
            (
                "yuksel_adhoc",
                "disk_eq8_at_zero_ratio",
                "eq. 8 (yuksel_adhoc, r) / facing disk at d = 0",
            ),
            ("yuksel", "disk_eq7_at_zero_ratio", "eq. 7 (yuksel, r) / facing disk at d = 0"),
            ("disk_facing", "disk_facing_at_zero_ratio", "disk_facing (r) / facing disk at d = 0"),
        ):
            if fam in names:
                rr = row(fam, disk.name, "published")
                if rr and rr["sweep"]:
                    add(
                        key,
                        what,
                        rr["sweep"]["at_zero"]["ratio"],
                        disk.name,
                        2.0 if fam != "disk_facing" else 1.0,
                    )
        if "yuksel_adhoc" in names:
            cls = next(c for c in classes if c.name == "yuksel_adhoc")
            m = cls(r=math.sqrt(2.0) * r)
            f = _eval(m, sw.d)
            rel = M.relative_error(f, sw.truth)
            f0 = float(_eval(m, np.zeros(1))[0])
            worst = max(float(np.nanmax(np.abs(rel))), abs(f0 / sw.truth0 - 1.0))
            add(
                "disk_eq8_sqrt2_max_error",
                "eq. 8 with r' = √2 r vs the facing disk, d = 0 to 1000 r: max |rel. error|",
                worst,
                disk.name,
                0.0,
            )
            fr = row("yuksel_adhoc", disk.name, "fitted")
            if fr and fr["status"] == "ok":
                add(
                    "disk_eq8_fitted_radius_over_r",
                    "eq. 8 fitted to the facing disk: r' / r",
                    fr["params"]["r"] / r,
                    disk.name,
                    math.sqrt(2.0),
                )
        if {"yuksel", "yuksel_adhoc", "inverse_square"} <= names:
            get = {c.name: c for c in classes}
            f7 = _eval(get["yuksel"](r=r), sw.d)
            f8 = _eval(get["yuksel_adhoc"](r=r), sw.d)
            fi = _eval(get["inverse_square"](), sw.d)
            tol = 1e-12
            between = (f7 <= f8 * (1 + tol)) & (f8 <= fi * (1 + tol))
            add(
                "eq8_between_eq7_and_inverse_square",
                "fraction of distances (0.001 r to 1000 r) where eq. 7 ≤ eq. 8 ≤ 1/d²",
                float(np.mean(between)),
                disk.name,
                1.0,
            )
        if "disk_facing" in names:
            rr = row("disk_facing", disk.name, "published")
            if rr and rr["sweep"]:
                add(
                    "disk_facing_max_error",
                    "disk_facing (r) vs the facing disk: max |rel. error|",
                    rr["sweep"]["overall"]["max_abs"],
                    disk.name,
                    0.0,
                )
    if sphere is not None:
        for cls in classes:
            if cls.window not in _WINDOWED:
                continue
            r = row(cls.name, sphere.name, "published")
            if not r or r["status"] != "ok":
                continue
            en = (r["plane"] or {}).get("energy") or {}
            add(
                f"window_{cls.name}_inner_half_max_error",
                f"{cls.name} (published) vs the sphere, d ≤ range/2: max |rel. error|",
                ((r["sweep"] or {}).get("inner_half") or {}).get("max_abs"),
                sphere.name,
            )
            add(
                f"window_{cls.name}_reach_1pct",
                f"{cls.name}: off by > 1% from this fraction of its range on",
                ((r["sweep"] or {}).get("reach") or {}).get("1%"),
                sphere.name,
            )
            if en.get("discarded_fraction") is not None:
                add(
                    f"window_{cls.name}_energy_dropped",
                    f"{cls.name}: fraction of the true plane energy beyond its range",
                    en["discarded_fraction"],
                    sphere.name,
                )
                add(
                    f"window_{cls.name}_energy_ratio",
                    f"{cls.name}: plane energy / true plane energy",
                    en.get("ratio"),
                    sphere.name,
                )
    return out


# ============================================================================ README
_README_BEGIN = (
    "<!-- BEGIN report (generated by `python -m attenfit.report --readme`; do not edit) -->"
)
_README_END = "<!-- END report -->"


def readme_section(report: Report, figure: str) -> str:
    """The README's "The report" section for `report`, showing `figure` (a path from the README)."""
    return "\n".join(
        [
            _README_BEGIN,
            "## The report",
            "",
            "`attenfit report` (or `make report`) writes the default comparison into "
            "`./attenfit-report/`: `report.md` (summary table, findings, one section per emitter "
            "with figures), `report.json` (every number), `results.csv` (one row per family × "
            "configuration × mode) and the figures as PNG and SVG. Options: `--out DIR`, "
            "`--emitters sphere disk`, `--families NAME ...`, `--mitsuba FILE.npz ...` (Monte "
            "Carlo datasets from `attenfit gen`), `--force` to replace an existing report.",
            "",
            "Each family is compared with the exact irradiance of a Lambertian sphere and a "
            "one-sided disk (radius r = 0.1 m, unit intensity), both **as published** (the "
            "source's parameters for this light: r = the light's radius, a window's range where "
            "the facing irradiance falls to 1/1000 of its surface value, engine constants as "
            "shipped) and **fitted** (least squares on the relative error). The default "
            "report's summary:",
            "",
            report.summary_markdown(),
            "The numbers behind the seeds' claims (`findings` in `report.json`):",
            "",
            report.findings_markdown(),
            f"![attenuation against distance, facing disk]({figure})",
            "",
            "The default report takes about a minute of CPU time on the reference 2-core "
            "machine, half of it compiling one fit of every family and half drawing the "
            "figures; the published figures are drawn in a second thread while the fit "
            "compiles, so it writes in about a minute (63 s measured with the machine "
            "otherwise busy). `python -m benchmarks report` measures it stage by stage.",
            "",
            "This section is regenerated by `python -m attenfit.report --readme`.",
            _README_END,
        ]
    )


def _update_readme(readme: Path, docs: Path) -> None:
    """Rebuild the default report and rewrite README.md's report section and its figure."""
    import matplotlib as mpl

    from . import _report_figures, plots
    from ._atomic import atomic_write

    def markers_ok(text: str) -> bool:
        return (_README_BEGIN in text and _README_END in text) or "<!-- SECTION:report -->" in text

    if not markers_ok(readme.read_text(encoding="utf-8")):
        raise BadValueError(f"{readme} has neither the report markers nor <!-- SECTION:report -->")
    rep = build_report(progress=lambda s: print(f"attenfit report: {s}", flush=True))
    cfg = next((c for c in rep.configs if c.kind == "disk" and c.sweep is not None), rep.configs[0])
    fig = _report_figures._two_panel(rep, cfg, "published", "attenuation")
    docs.mkdir(parents=True, exist_ok=True)
    target = docs / "report_attenuation.png"
    with mpl.rc_context(plots.STYLE):
        atomic_write(target, lambda p: fig.savefig(p, dpi=100, format="png"), force=True)
    section = readme_section(rep, f"{docs.name}/{target.name}")
    text = readme.read_text(encoding="utf-8")  # read late: others may have edited it meanwhile
    if not markers_ok(text):
        raise BadValueError(f"{readme} lost its report markers while the report was built")
    if _README_BEGIN in text and _README_END in text:
        pre, rest = text.split(_README_BEGIN, 1)
        _, post = rest.split(_README_END, 1)
        new = pre + section + post
    else:
        new = text.replace("<!-- SECTION:report -->", section, 1)
    atomic_write(readme, new, force=True)
    print(f"attenfit report: rewrote {readme} and {target}", flush=True)


def main(argv: Sequence[str] | None = None) -> int:
    """`python -m attenfit.report --readme`: rebuild the README's report section and figure."""
    import argparse

    p = argparse.ArgumentParser(prog="python -m attenfit.report")
    p.add_argument("--readme", action="store_true", help="regenerate README.md's report section")
    p.add_argument("--readme-path", default="README.md")
    p.add_argument("--docs", default="docs")
    args = p.parse_args(argv)
    if not args.readme:
        p.print_help()
        return 2
    _update_readme(Path(args.readme_path), Path(args.docs))
    return 0


if __name__ == "__main__":
    import sys

    sys.exit(main())
