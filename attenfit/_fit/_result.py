"""What a fit returns: `FitResult` for one problem, `FitResults` for a batch, read from the
packed outputs of the compiled solve."""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Sequence
from typing import Any

import jax.numpy as jnp
import numpy as np

from .._curves import Model
from ._layout import packed_slices, unpack_columns
from ._spec import free_size, free_slices, free_values, rebuild

# ----------------------------------------------------------------------------- results
#: What a fit's `model` may be besides a `(fn, params)` pair.
_MODELS = Model


def max_steps_code() -> int:
    """optimistix's code for "stopped at max_steps" (0 is success)."""
    import optimistix as optx  # on demand: a result read from the cache has no other need

    return optx.RESULTS.nonlinear_max_steps_reached._value.item()


def _optimistix_message(code: int) -> str:
    import optimistix as optx

    return optx.RESULTS._index_to_message[code]


def _converged(code, start_finite, loss, grad_ok):
    """Converged: optimistix succeeded, or stopped at max steps on a first-order optimum."""
    code = np.asarray(code)
    ok = code == 0
    if not np.all(ok):
        ok = ok | ((code == max_steps_code()) & np.asarray(grad_ok))
    return ok & np.asarray(start_finite) & np.isfinite(loss)


def _message(
    code: int, start_finite: bool, loss: float, at_bound: Sequence[str], grad_ok: bool
) -> tuple[bool, str]:
    notes = []
    if at_bound:
        notes.append(f"on its bound: {', '.join(at_bound)}")
    if not start_finite:
        msg = "the residuals are not finite (NaN or inf) at the starting parameters"
        if code:
            msg += f"; optimistix: {_optimistix_message(code).splitlines()[0]}"
        return False, msg
    if not math.isfinite(loss):
        return False, "the loss at the solution is not finite"
    if code and code == max_steps_code() and grad_ok:
        note = "converged (first-order optimal: residuals orthogonal to the Jacobian within rtol, or at rounding level; optimistix reached max_steps)"
        return True, "; ".join([note, *notes])
    if code:
        return False, "; ".join(
            [f"optimistix: {' '.join(_optimistix_message(code).split())}", *notes]
        )
    return True, "; ".join(["converged", *notes])


def _covariance(jtj: np.ndarray, loss: float, n: int, k: int) -> np.ndarray:
    """`pinv(J^T J) * sum(r^2) / (n - k)`, as `scipy.optimize.curve_fit` (inf if n == k)."""
    jtj = np.asarray(jtj, dtype=np.float64)
    if not np.all(np.isfinite(jtj)):
        return np.full((k, k), np.inf)
    w, v = np.linalg.eigh(jtj)
    smax = math.sqrt(max(w.max(initial=0.0), 0.0))
    keep = np.sqrt(np.clip(w, 0, None)) > np.finfo(np.float64).eps * max(n, k) * smax
    if smax == 0 or not keep.any():
        return np.full((k, k), np.inf)
    inv = (v[:, keep] / w[keep]) @ v[:, keep].T
    if n <= k:
        return np.full((k, k), np.inf)
    return inv * (2 * loss / (n - k))


@dataclasses.dataclass(frozen=True)
class FitResult:
    """The outcome of one fit: fitted model and parameters, whether and how it converged.

    Attributes:
        model: the fitted model: a family instance with the fitted values, or for a
            `(fn, params)` model the pair `(fn, fitted params)`.
        params: every parameter (fitted and fixed) as Python floats (lists for arrays).
        converged: whether optimistix reported success with finite residuals.
        message: "converged", or why not (optimistix's message); notes parameters on bound.
        steps: solver steps taken.
        loss: `0.5 * sum(residual^2)` at the solution.
        metrics: `max_rel_error`, `rms_rel_error` (unweighted |f - t| / t over the fitted
            samples with t > 0), `start_loss`, `n` (samples), `k` (free values).
        covariance: `(k, k)` covariance of the free parameters, in `free` order (curve_fit's),
            computed on first use from `normal_matrix`.
        free: the fitted parameter names. at_bound: those that ended on a bound.
        objective: the loss kind; solver: its name; dtype: the float dtype of the fit.
        normal_matrix: `J^T J`, J the Jacobian of the residuals with respect to the free
            parameters at the solution.
    """

    model: Any
    params: dict[str, Any]
    converged: bool
    message: str
    steps: int
    loss: float
    metrics: dict[str, float]
    free: tuple[str, ...]
    at_bound: tuple[str, ...] = ()
    objective: str = "relative"
    solver: str = "levenberg_marquardt"
    dtype: str = "float64"
    normal_matrix: np.ndarray = dataclasses.field(default=None, repr=False)  # type: ignore[assignment]

    @functools.cached_property
    def covariance(self) -> np.ndarray:
        """`(k, k)` covariance of the free parameters (`scipy.optimize.curve_fit`'s)."""
        k = len(self.normal_matrix)
        return _covariance(self.normal_matrix, self.loss, int(self.metrics["n"]), k)

    @property
    def stderr(self) -> dict[str, float]:
        """Standard errors of the free (scalar) parameters: sqrt of the covariance diagonal."""
        diag = np.sqrt(np.abs(np.diag(self.covariance)))
        out, i = {}, 0
        for p in self.free:
            size = np.size(self.params[p])
            out[p] = float(diag[i]) if size == 1 else diag[i : i + size].tolist()
            i += size
        return out

    def to_dict(self) -> dict[str, Any]:
        """A JSON-ready summary (no model object; `family` names the family, if any)."""

        def plain(x):
            x = float(x)
            return x if math.isfinite(x) else str(x)

        def plain_tree(v):  # strict JSON: NaN/inf parameters and errors become strings
            return [plain_tree(x) for x in v] if isinstance(v, list | tuple) else plain(v)

        name = getattr(self.model, "name", None) if isinstance(self.model, _MODELS) else None
        return {
            "family": name,
            "params": {k: plain_tree(v) for k, v in self.params.items()},
            "free": list(self.free),
            "stderr": {k: plain_tree(v) for k, v in self.stderr.items()},
            "converged": self.converged,
            "message": self.message,
            "steps": self.steps,
            "loss": plain(self.loss),
            "objective": self.objective,
            "solver": self.solver,
            "dtype": self.dtype,
            "at_bound": list(self.at_bound),
            "metrics": {k: plain(v) for k, v in self.metrics.items()},
            "covariance": [[plain(x) for x in row] for row in np.asarray(self.covariance)],
        }

    def __str__(self) -> str:
        name = (
            getattr(self.model, "name", "custom model")
            if isinstance(self.model, _MODELS)
            else "custom model (fn, params)"
        )
        m = self.metrics
        lines = [
            f"[[Fit]] {name}",
            f"    solver     = {self.solver}, loss = {self.objective}, dtype = {self.dtype}",
            f"    converged  = {self.converged} ({self.message.splitlines()[0]})",
            f"    steps      = {self.steps}",
            f"    samples    = {int(m.get('n', 0))}, free values = {int(m.get('k', 0))}",
            f"    loss       = {self.loss:.6g}  (0.5 * sum of squared residuals)",
            f"    rel. error = max {m.get('max_rel_error', math.nan):.3g}, rms {m.get('rms_rel_error', math.nan):.3g}",
            "[[Parameters]]",
        ]
        se = self.stderr
        for p, v in self.params.items():
            if p in self.free and np.size(v) == 1:
                s = se[p]
                rel = f" ({100 * s / abs(v):.2f}%)" if v != 0 and math.isfinite(s) else ""
                bound = "  (on bound)" if p in self.at_bound else ""
                lines.append(f"    {p:<10} = {v:.8g} +/- {s:.3g}{rel}{bound}")
            elif p in self.free:
                lines.append(f"    {p:<10} = {v}")
            else:
                lines.append(f"    {p:<10} = {v if np.size(v) > 1 else format(v, '.8g')}  (fixed)")
        k = len(self.covariance)
        if k > 1 and all(np.size(self.params[p]) == 1 for p in self.free):
            cov = np.asarray(self.covariance)
            sd = np.sqrt(np.abs(np.diag(cov)))
            pairs = []
            for i in range(k):
                for j in range(i + 1, k):
                    if sd[i] > 0 and sd[j] > 0 and np.isfinite(sd[i] * sd[j]):
                        pairs.append(
                            (abs(cov[i, j] / (sd[i] * sd[j])), cov[i, j] / (sd[i] * sd[j]), i, j)
                        )
            shown = [p for p in sorted(pairs, reverse=True) if p[0] > 0.1]
            if shown:
                lines.append("[[Correlations]] (|corr| > 0.1)")
                for _, c, i, j in shown:
                    lines.append(f"    C({self.free[i]}, {self.free[j]}) = {c:+.4f}")
        return "\n".join(lines)


def _field_value(v: np.ndarray, dtype) -> Any:
    """A fitted family field: a Python float for a scalar, else an array of the fit's dtype."""
    return v if isinstance(v, float) else float(v) if np.ndim(v) == 0 else jnp.asarray(v, dtype)


def _python_value(v: np.ndarray) -> Any:
    return float(v) if v.ndim == 0 else v.tolist()


@functools.cache
def _dtype_name(dtype: np.dtype) -> str:
    return np.dtype(dtype).name


def make_result(
    spec, template, values, free, row, i, n, loss_kind, solver_name, dtype
) -> FitResult:
    """One FitResult from one problem's packed outputs `row` (`packed_layout`); `i`: the
    problem's index in batched `values`, or None."""
    k = free_size(spec, free)
    at = packed_slices(k)
    out = row.tolist()
    pvec = out[at["pvec"]]
    where = free_slices(spec, free)
    params, fitted = {}, {}
    for nm, shape in zip(spec.names, spec.shapes, strict=True):
        if nm in free:
            if shape == ():
                params[nm] = fitted[nm] = pvec[where[nm].start]
            else:
                fitted[nm] = np.asarray(pvec[where[nm]]).reshape(shape)
                params[nm] = fitted[nm].tolist()
        else:
            v = values[nm]
            v = np.asarray(v[i] if i is not None and np.ndim(v) > len(shape) else v)
            fitted[nm] = v
            params[nm] = _python_value(v)
    bound = zip(free_values(spec, free), out[at["at_bound"]], strict=True)
    at_bound = tuple(dict.fromkeys(p for p, b in bound if b))
    (code,), (loss,) = out[at["result"]], out[at["loss"]]
    converged, message = _message(
        int(code), bool(out[at["start_finite"]][0]), loss, at_bound, bool(out[at["grad_ok"]][0])
    )
    metrics = {
        "max_rel_error": out[at["max_rel"]][0],
        "rms_rel_error": out[at["rms_rel"]][0],
        "start_loss": out[at["start_loss"]][0],
        "n": n,
        "k": k,
    }
    if isinstance(template, _MODELS):
        model = rebuild(spec, template, [_field_value(fitted[nm], dtype) for nm in spec.names])
    else:
        model = (template[0], {nm: params[nm] for nm in spec.names})
    return FitResult(
        model=model,
        params=params,
        converged=converged,
        message=message,
        steps=int(out[at["steps"]][0]),
        loss=loss,
        metrics=metrics,
        normal_matrix=np.array(row[at["jtj"]]).reshape(k, k),
        free=free,
        at_bound=at_bound,
        objective=loss_kind,
        solver=solver_name,
        dtype=_dtype_name(dtype),
    )


class FitResults(Sequence):
    """Per-problem results of `fit_many`: a sequence of `FitResult` plus batched arrays.

    `results[i]` builds the i-th `FitResult` on demand; `params` (name -> array with a
    leading batch axis), `converged`, `steps` and `loss` are arrays over the batch.
    """

    def __init__(self, spec, template, values, free, flat, n, loss_kind, solver_name, dtype):
        self._args = (spec, template, values, free, flat, n, loss_kind, solver_name, dtype)
        out = unpack_columns(flat, free_size(spec, free))
        self._out = out
        self.free = free
        batch = len(out["loss"])
        where = free_slices(spec, free)
        self.params: dict[str, np.ndarray] = {}
        for nm, shape in zip(spec.names, spec.shapes, strict=True):
            if nm in free:
                self.params[nm] = out["pvec"][:, where[nm]].reshape((batch, *shape))
            else:
                self.params[nm] = np.broadcast_to(values[nm], (batch, *shape))
        codes = out["result"]
        self.converged: np.ndarray = _converged(
            codes, out["start_finite"], out["loss"], out["grad_ok"]
        )
        self.steps: np.ndarray = out["steps"]
        self.loss: np.ndarray = out["loss"]

    def __len__(self) -> int:
        return len(self._out["loss"])

    def __getitem__(self, i):  # type: ignore[override]
        if isinstance(i, slice):
            return [self[j] for j in range(*i.indices(len(self)))]
        i = range(len(self))[i]
        spec, template, values, free, flat, n, loss_kind, solver_name, dtype = self._args
        if isinstance(template, _MODELS):
            one = rebuild(spec, template, [np.asarray(values[nm][i]) for nm in spec.names])
        else:
            one = (template[0], {nm: values[nm][i] for nm in spec.names})
        return make_result(spec, one, values, free, flat[i], i, n, loss_kind, solver_name, dtype)

    def __repr__(self) -> str:
        return f"FitResults({len(self)} fits, {int(self.converged.sum())} converged)"
