"""One family on one configuration: its values, the metrics of its errors (a result row),
and what it costs."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .._shaders import compiled_cost, cost_table, in_parallel, precision
from . import _metrics as M
from ._configs import Config
from ._published import range_of


# ============================================================================ evaluation
def eval_f64(model: Any, d: np.ndarray) -> np.ndarray:
    """f(d) in float64 (call inside `jax.enable_x64(True)`)."""
    import jax.numpy as jnp

    with np.errstate(all="ignore"):
        return np.asarray(model(jnp.asarray(d, jnp.float64)), np.float64)


def model_values(model: Any, cfg: Config) -> dict[str, np.ndarray]:
    """The model on every distance a configuration needs, from one evaluation."""
    parts: dict[str, np.ndarray] = {}
    if cfg.sweep is not None:
        parts["sweep"] = cfg.sweep.d
        parts["zero"] = np.zeros(1)
        if cfg.sweep.dense_d is not None:
            parts["dense"] = cfg.sweep.dense_d
    for name, rs in cfg.receivers.items():
        parts[f"rx_{name}"] = rs.d
    if cfg.plane is not None:
        parts["plane"] = cfg.plane.dist.ravel()
        if cfg.plane.rho is not None:
            parts["radial"] = cfg.plane.rdist
    f = eval_f64(model, np.concatenate(list(parts.values())))
    out, i = {}, 0
    for k, v in parts.items():
        out[k] = f[i : i + v.size]
        i += v.size
    if "plane" in out:
        out["plane"] = out["plane"].reshape(cfg.plane.dist.shape)
    return out


def sweep_metrics(
    model: Any, cfg: Config, vals: Mapping[str, np.ndarray], rng: float | None
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


def receiver_metrics(
    cfg: Config, vals: Mapping[str, np.ndarray], rng: float | None
) -> dict[str, Any]:
    """`_metrics.receiver_errors` on each receiver set of the configuration."""
    out = {}
    for name, rs in cfg.receivers.items():
        E_model = rs.weight * vals[f"rx_{name}"]
        out[name] = M.receiver_errors(E_model, rs.E, rs.ref, rs.d, rs.gap, cfg.radius, range_=rng)
    return out


def plane_metrics(model: Any, cfg: Config, vals: Mapping[str, np.ndarray]) -> dict[str, Any]:
    pl = cfg.plane
    img = pl.weight * vals["plane"]
    out: dict[str, Any] = {"image": M.image_errors(img, pl.E, coords=pl.xy)}
    if pl.rho is not None:
        model_e = M.plane_energy(pl.rho, pl.rweight * vals["radial"])
        true_e = M.plane_energy(pl.rho, pl.rE)
        out["energy"] = {"true": true_e, "model": model_e, "ratio": model_e / true_e}
        rng = range_of(model)
        if rng is not None:
            out["energy"]["discarded_fraction"] = M.discarded_fraction(pl.rho, pl.rE, pl.rdist, rng)
    return out


def window_metrics(model: Any) -> dict[str, Any] | None:
    rng = range_of(model)
    if rng is None or not math.isfinite(rng) or rng <= 0:
        return None
    out = M.window_edge(model, rng)
    out["range"] = rng
    return out


def json_params(model: Any) -> dict[str, Any]:
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


def family_costs(
    names: Sequence[str], instances: Mapping[str, Any], *, measure: bool = True
) -> dict[str, Any]:
    """Cost of each family: the compiled cost of its shader form (`attenfit.cost.compiled_cost`:
    SPIR-V and SASS instruction counts, or the labelled estimate without compilers) beside its
    stable form's, the shader form's precision in float32 and float16, and
    `attenfit.cost.cost_table` (operation counts of the traced expression and, unless
    `measure` is False, the measured ns/eval and its ratio to inverse-square in the same run);
    the stand-in `_ns_per_eval` if the tracer cannot read a family."""
    try:
        table = cost_table([instances[n] for n in names], measure=measure, n=1 << 16, repeats=5)
    except Exception as exc:  # a family the tracer cannot read: time them all the plain way
        note = f"attenfit.cost unavailable ({type(exc).__name__}: {exc}); "
        return {
            n: {
                "ns_per_eval": _ns_per_eval(instances[n]),
                "method": note + "jit float32, 65536 distances, median of 7",
            }
            for n in names
        }
    out = {}
    both = in_parallel(
        lambda n: (compiled_cost(instances[n]), compiled_cost(instances[n], form="stable")), names
    )
    for n, (shader, stable) in zip(names, both, strict=True):
        prec = {dt: precision(instances[n], dt) for dt in ("float32", "float16")}
        timed = (
            "; time: attenfit.cost.cost_table, float32, jitted, 65536 distances, median of 5 "
            "interleaved repeats"
            if measure
            else ""
        )
        out[n] = {
            "ns_per_eval": table[n].ns_per_eval,
            "ns_iqr": table[n].ns_iqr,
            "ratio_to_inverse_square": table[n].ratio_to_inverse_square,
            "shader_cost": shader.cost,
            "cost_label": shader.label(),
            "compiled": {"shader": shader.to_dict(), "stable": stable.to_dict()},
            "precision": {dt: (p.to_dict() if p else None) for dt, p in prec.items()},
            "estimate": table[n].shader_cost,
            "ops": dict(table[n].ops),
            "method": f"cost of the shader form (what `attenfit export` writes): {shader.label()}"
            + timed,
        }
    return out


def truth_interpolator(c: Config) -> Callable[[float], float] | None:
    if c.sweep is None:
        return None
    sw = c.sweep

    def at(d: float) -> float:
        # log-log interpolation of the sampled truth (the sweep starts at or below r)
        return float(np.exp(np.interp(np.log(d), np.log(sw.d), np.log(sw.truth))))

    return at


def evaluate_row(
    fam: str,
    c: Config,
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
        "params": json_params(model),
        "sweep": None,
        "plane": None,
        "window": None,
    }
    if fit is not None:
        row["fit"] = fit
    try:
        vals = model_values(model, c)
        if store is not None:
            store[(fam, c.name, mode)] = vals
        rng = range_of(model) if range_ is None else range_
        if c.sweep is not None:
            row["sweep"] = sweep_metrics(model, c, vals, rng)
        if c.receivers:
            row["receivers"] = receiver_metrics(c, vals, rng)
        if c.plane is not None:
            row["plane"] = plane_metrics(model, c, vals)
        row["window"] = window_metrics(model)
    except Exception as exc:  # a family that fails to evaluate is marked, not dropped
        row["status"] = f"error: {type(exc).__name__}: {exc}"
        row["sweep"] = row["plane"] = row["window"] = None
        row.pop("receivers", None)
    return row


def failed_row(fam: str, c: Config, status: str, info: dict | None = None) -> dict[str, Any]:
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
