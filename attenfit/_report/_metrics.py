"""Error metrics of an attenuation curve against the truth: pure functions over arrays.

Every function takes plain arrays (NumPy, JAX or lists), computes in float64 NumPy on the
host and returns plain Python numbers in dicts, ready for JSON. Conventions (docs/architecture.md
and docs/report.md):

* `d` is the distance from the light's centre; `r` the light's radius. The distance bands are
  near (d < r), mid (r <= d <= 10 r) and far (d > 10 r): `BANDS`, in units of r.
* The relative error of a model value `m` against a truth `t > 0` is `(m - t) / t`: 0 is
  exact, +1 is twice too bright, -1 is black. Samples whose truth is not finite and positive
  carry no relative error (NaN) and are left out of every statistic; `n` says how many counted.
* Plane energies integrate irradiance over a receiving plane. For a light whose plane
  irradiance is rotationally symmetric about the foot point (a sphere, a disk facing the
  plane) the profile along one ray suffices: energy = integral of 2 pi rho E(rho) d rho.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from jaxtyping import ArrayLike

from .. import _judge
from .._errors import BadValueError

#: The distance bands, as (low, high) in units of the light's radius r: near is d < r,
#: mid is r <= d <= 10 r, far is d > 10 r.
BANDS: Mapping[str, tuple[float, float]] = {
    "near": (0.0, 1.0),
    "mid": (1.0, 10.0),
    "far": (10.0, math.inf),
}


#: The bands of the decision table, on the distance from the light's surface (`gap`, d - r
#: for a sphere, d for a disk) in units of r: contact to r, r to 10 r, beyond 10 r; defined
#: once, with the receiver spaces the worst case is searched in (`attenfit._judge`).
GAP_BANDS: Mapping[str, tuple[float, float]] = _judge.GAP_BANDS
#: How the decision table names each of `GAP_BANDS`.
GAP_BAND_LABELS: Mapping[str, str] = _judge.GAP_BAND_LABELS


def receiver_errors(
    E_model: ArrayLike,
    E_true: ArrayLike,
    ref: ArrayLike,
    d: ArrayLike,
    gap: ArrayLike,
    r: float,
    *,
    range_: float | None = None,
) -> dict[str, Any]:
    """Errors of a model's irradiance at a receiver set, relative to `ref` (the truth itself,
    or the facing irradiance there): `overall` and per `GAP_BANDS` band (`error_stats`, with
    `worst_at` the worst receiver's d / r). Receivers with `ref` not finite and positive carry
    no error; for a windowed curve (`range_`) only those with d <= range_/2 are judged, and
    `covers` says which bands lie wholly inside range_/2."""
    Em, Et, R = _f64("E_model", E_model), _f64("E_true", E_true), _f64("ref", ref)
    dd, g = _f64("d", d), _f64("gap", gap)
    ok = np.isfinite(R) & (R > 0)
    if range_ is not None:
        ok &= dd <= 0.5 * range_
    with np.errstate(invalid="ignore", over="ignore", divide="ignore"):
        e = np.where(ok, (Em - Et) / np.where(ok, R, 1.0), np.nan)
    x = dd / float(r)
    out: dict[str, Any] = {"overall": error_stats(e, x), "bands": {}}
    for band, (lo, hi) in GAP_BANDS.items():
        sel = (g >= lo * r) & (g < hi * r)
        out["bands"][band] = error_stats(np.where(sel, e, np.nan), x)
    if range_ is not None:
        out["covers"] = [
            b
            for b, (lo, hi) in GAP_BANDS.items()
            if math.isfinite(hi) and np.all(dd[(g >= lo * r) & (g < hi * r)] <= 0.5 * range_)
        ]
    return out


def _f64(name: str, x: ArrayLike) -> np.ndarray:
    try:
        arr = np.asarray(x, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise BadValueError(f"{name} must be an array of real numbers, got {x!r}") from exc
    return arr


def _same_shape(**arrays: np.ndarray) -> None:
    shapes = {k: v.shape for k, v in arrays.items()}
    if len(set(shapes.values())) > 1:
        raise BadValueError(f"arrays must have the same shape, got {shapes}")


def _num(x: Any) -> float | None:
    """A JSON-friendly float: None for NaN (no data); +-inf kept as float."""
    x = float(x)
    return None if math.isnan(x) else x


def relative_error(model: ArrayLike, truth: ArrayLike) -> np.ndarray:
    """`(model - truth) / truth`, elementwise, in float64.

    NaN where the truth is not finite and positive (no relative error is defined there);
    +-inf where the model is infinite (a singular curve at d = 0) and the truth is finite.
    """
    m = _f64("model", model)
    t = _f64("truth", truth)
    m, t = np.broadcast_arrays(m, t)
    ok = np.isfinite(t) & (t > 0)
    safe_t = np.where(ok, t, 1.0)
    with np.errstate(invalid="ignore", over="ignore"):
        rel = np.where(ok, (m - safe_t) / safe_t, np.nan)
        # inf - t is inf, and nan model stays nan
    return rel


def error_stats(rel: ArrayLike, at: ArrayLike | None = None) -> dict[str, Any]:
    """Statistics of relative errors `rel` (NaN entries are left out).

    Returns `max_abs` (the largest |error|), `rms` (root mean square), `worst` (the signed
    error of largest magnitude), `mean`, `n` (entries counted) and, when `at` (e.g. the
    distances) is given, `worst_at` (its value at the worst entry). With no entry counted the
    statistics are None.
    """
    e = _f64("rel", rel).ravel()
    keep = ~np.isnan(e)
    n = int(keep.sum())
    out: dict[str, Any] = {"max_abs": None, "rms": None, "worst": None, "mean": None, "n": n}
    if at is not None:
        out["worst_at"] = None
    if n == 0:
        return out
    ek = e[keep]
    i = int(np.argmax(np.abs(ek)))
    with np.errstate(over="ignore", invalid="ignore"):
        out["max_abs"] = float(np.abs(ek[i]))
        out["rms"] = float(np.sqrt(np.mean(np.square(ek))))
        out["mean"] = float(np.mean(ek))
    out["worst"] = float(ek[i])
    if at is not None:
        a = _f64("at", at).ravel()
        if a.shape != e.shape:
            raise BadValueError(f"`at` must have the shape of `rel`, got {a.shape} and {e.shape}")
        out["worst_at"] = float(a[keep][i])
    return out


def band_errors(d: ArrayLike, rel: ArrayLike, r: float) -> dict[str, dict[str, Any]]:
    """`error_stats` of `rel` in each band of `BANDS` (near d < r, mid r..10 r, far > 10 r)."""
    dd, e = _f64("d", d), _f64("rel", rel)
    _same_shape(d=dd, rel=e)
    if not (np.isfinite(r) and r > 0):
        raise BadValueError(f"radius r must be finite and positive, got {r!r}")
    out = {}
    for band, (lo, hi) in BANDS.items():
        if band == "near":
            sel = dd < hi * r
        elif band == "mid":
            sel = (dd >= lo * r) & (dd <= hi * r)
        else:
            sel = dd > lo * r
        out[band] = error_stats(np.where(sel, e, np.nan), dd)
    return out


def attenuation_errors(
    d: ArrayLike,
    model: ArrayLike,
    truth: ArrayLike,
    r: float,
    *,
    range_: float | None = None,
) -> dict[str, Any]:
    """All distance-sweep error metrics of `model` against `truth` sampled at distances `d`.

    Returns `overall` (`error_stats` with `worst_at` the distance of the worst error), `bands`
    (near/mid/far) and, when the curve has a range (a window), `in_range`: the same statistics
    over the samples with d < range_ only (beyond it a window is black by design, error -1),
    `inner_half`: over d <= range_/2 (away from the edge, where every window must deviate),
    and `reach`: `window_reach` for 1% and 10%.
    """
    dd, m, t = _f64("d", d), _f64("model", model), _f64("truth", truth)
    _same_shape(d=dd, model=m, truth=t)
    rel = relative_error(m, t)
    out: dict[str, Any] = {
        "overall": error_stats(rel, dd),
        "bands": band_errors(dd, rel, r),
    }
    if range_ is not None:
        out["in_range"] = error_stats(np.where(dd < range_, rel, np.nan), dd)
        out["inner_half"] = error_stats(np.where(dd <= 0.5 * range_, rel, np.nan), dd)
        out["reach"] = {
            "1%": window_reach(dd, rel, range_, 0.01),
            "10%": window_reach(dd, rel, range_, 0.1),
        }
    return out


def window_reach(d: ArrayLike, rel: ArrayLike, range_: float, threshold: float) -> float | None:
    """How far in from its range a window's deviation reaches, as a fraction of the range.

    Scanning inward from `range_`, the first sampled distance where |rel| <= `threshold`,
    divided by `range_`: the curve is off by more than `threshold` everywhere between that
    distance and the range (e.g. 0.27 for Unreal's window at 1%: (1 - x^4)^2 = 0.99 at
    x = 0.266). None when no sample inside the range is within `threshold`.
    """
    dd, e = _f64("d", d), _f64("rel", rel)
    _same_shape(d=dd, rel=e)
    inside = np.where((dd < range_) & ~np.isnan(e))[0]
    if inside.size == 0:
        return None
    order = inside[np.argsort(dd[inside])[::-1]]
    for i in order:
        if abs(e[i]) <= threshold:
            return float(dd[i] / range_)
    return None


def value_at_zero(
    f0: float, truth0: float | None, truth_max: float | None = None
) -> dict[str, Any]:
    """The curve's value at d = 0 against the truth there.

    `f0` is f(0); `truth0` the true attenuation at d = 0 (None where there is none, e.g. the
    centre of a sphere is inside the light); `truth_max` the largest true value anywhere (for
    a sphere: 1/r^2 at contact). Returns `value`, `finite`, `truth`, `ratio` = f0 / truth0 and
    `ratio_to_max` = f0 / truth_max (None where undefined; inf for a singular curve).
    """
    f0 = float(f0)
    out: dict[str, Any] = {
        "value": _num(f0),
        "finite": bool(np.isfinite(f0)),
        "truth": None if truth0 is None else _num(truth0),
        "ratio": None,
        "ratio_to_max": None,
    }
    with np.errstate(divide="ignore", invalid="ignore"):
        if truth0 is not None and truth0 > 0:
            out["ratio"] = _num(np.float64(f0) / truth0)
        if truth_max is not None and truth_max > 0:
            out["ratio_to_max"] = _num(np.float64(f0) / truth_max)
    return out


def window_edge(f: Callable[[Any], Any], range_: float, *, inside: float = 1e-4) -> dict[str, Any]:
    """Value and slope of a windowed curve `f` just inside its range.

    Evaluated at `d = (1 - inside) range_` (the left limit that matters for a hard cut), with
    the slope from `jax.jvp`. Also returned relative to inverse-square there:
    `value_rel` = f d^2 (0 for a window that closes, 1 for no window) and
    `slope_rel` = f'(d) / (-2 / d^3) (0 for a window that closes smoothly; 1 for inverse-square).
    `f` is any JAX-differentiable callable of distance, e.g. a family instance.
    """
    import jax
    import jax.numpy as jnp

    if not (np.isfinite(range_) and range_ > 0):
        raise BadValueError(f"range must be finite and positive, got {range_!r}")
    d = float(range_) * (1.0 - inside)
    x = jnp.asarray(d)
    value, slope = jax.jvp(f, (x,), (jnp.ones_like(x),))
    value, slope = float(value), float(slope)
    return {
        "at": d,
        "value": value,
        "slope": slope,
        "value_rel": value * d * d,
        "slope_rel": slope / (-2.0 / d**3),
    }


def plane_energy(rho: ArrayLike, E: ArrayLike) -> float:
    """Energy (flux) on a plane from a rotationally symmetric irradiance profile.

    `rho` are increasing distances from the foot point along one ray of the plane (start at
    0 for the whole disc), `E` the irradiance there; returns the trapezoid integral of
    2 pi rho E over [rho[0], rho[-1]], in the units of E times length^2 (W for W/m^2 and m).
    """
    p, e = _f64("rho", rho), _f64("E", E)
    _same_shape(rho=p, E=e)
    if p.ndim != 1 or p.size < 2 or np.any(np.diff(p) <= 0) or p[0] < 0:
        raise BadValueError("rho must be one increasing run of at least 2 non-negative distances")
    return float(np.trapezoid(2.0 * np.pi * p * e, p))


def discarded_fraction(rho: ArrayLike, E_true: ArrayLike, d: ArrayLike, range_: float) -> float:
    """Fraction of the true plane energy that falls where a window is black (d >= range_).

    `rho`, `E_true` as in `plane_energy`; `d` the distance of each sample from the light's
    centre. For a point-equivalent light at height h above an infinite plane this is h / range_.
    """
    p, e, dd = _f64("rho", rho), _f64("E_true", E_true), _f64("d", d)
    _same_shape(rho=p, E_true=e, d=dd)
    total = plane_energy(p, e)
    if not total > 0:
        raise BadValueError("the true plane energy must be positive")
    return plane_energy(p, np.where(dd >= range_, e, 0.0)) / total


def grid_energy(E: ArrayLike, cell_area: float) -> float:
    """Energy on a regular grid of irradiance samples: sum of E times the cell area (NaN skipped)."""
    e = _f64("E", E)
    return float(np.nansum(e) * cell_area)


def image_errors(
    model: ArrayLike,
    truth: ArrayLike,
    *,
    floor: float = 1e-6,
    coords: tuple[ArrayLike, ArrayLike] | None = None,
) -> dict[str, Any]:
    """Error of a rendered plane image (irradiance on a grid) against the true image.

    The relative error is `(model - truth) / max(truth, floor * max(truth))`: relative where
    the plane is lit, and measured against `floor` times the peak where the truth is (nearly)
    black, so a black pixel that the model lights counts without dividing by 0. Returns
    `max_abs`, `rms`, `worst`, `n`, the peak's pixel index `peak_index` and, with `coords` =
    (x, y) arrays of the image's shape, its position `peak_xy`. Also the energy ratio
    `energy_ratio` = sum(model) / sum(truth) over the image.
    """
    m, t = _f64("model", model), _f64("truth", truth)
    _same_shape(model=m, truth=t)
    peak = np.nanmax(t) if np.any(np.isfinite(t)) else np.nan
    if not (np.isfinite(peak) and peak > 0):
        raise BadValueError("the true image must have a finite positive maximum")
    denom = np.maximum(np.where(np.isfinite(t), t, np.nan), floor * peak)
    with np.errstate(invalid="ignore", over="ignore"):
        rel = (m - t) / denom
    stats = error_stats(rel)
    out: dict[str, Any] = dict(stats)
    out["peak_index"] = None
    if stats["n"]:
        flat = np.where(np.isnan(rel), -1.0, np.abs(rel)).ravel()
        idx = np.unravel_index(int(np.argmax(flat)), rel.shape)
        out["peak_index"] = [int(i) for i in idx]
        if coords is not None:
            xs, ys = _f64("x", coords[0]), _f64("y", coords[1])
            out["peak_xy"] = [float(xs[idx]), float(ys[idx])]
    with np.errstate(invalid="ignore", divide="ignore"):
        out["energy_ratio"] = _num(np.nansum(m) / np.nansum(t))
    return out
