"""Fits that fail stay honest: in `FitResult`, in `fit_many`, in JSON and on the command line.

A fit that does not converge, whose residuals are NaN, or whose parameter ends on a bound
says so (`converged`, `message`, `at_bound`), its JSON stays strict (no bare NaN/Infinity),
and `attenfit fit` exits 3 while still writing what it found. The report's side (failed
fits marked, never shown as results) is checked end to end in `test_extremes.py`.
"""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np

import attenfit as af
from attenfit.cli import main

D = np.geomspace(1.0, 10.0, 16)


def _strict_json(obj) -> str:
    return json.dumps(obj, allow_nan=False)  # raises on NaN/inf


def test_max_steps_is_not_convergence():
    res = af.fit(af.Yuksel(r=1.0), D, 1 / D**2, max_steps=2, guess=False)
    assert not res.converged
    assert "maximum number of steps" in res.message
    assert res.steps == 2
    assert "converged  = False" in str(res)
    back = json.loads(_strict_json(res.to_dict()))
    assert back["converged"] is False and back["steps"] == 2


def _nan_model(d, p):
    # finite only at a == 1 exactly: every step away from the start is NaN
    return p["a"] / (d * d) + jnp.nan * (p["a"] - 1.0)


def _nan_everywhere(d, p):
    return p["a"] / (d * d) * jnp.nan


def test_nan_residuals_are_reported_not_hidden():
    res = af.fit((_nan_everywhere, {"a": 1.0}), D, 2 / D**2)
    assert not res.converged
    assert "not finite" in res.message
    assert not np.isfinite(res.loss)
    d = res.to_dict()
    _strict_json(d)
    assert d["loss"] in ("inf", "nan")


def test_fit_many_marks_only_the_failed_problem():
    """One problem with a NaN target region next to a healthy one: only the bad one fails."""
    d = np.broadcast_to(D, (2, D.size))
    target = np.stack([2 / D**2, 2 / D**2])
    fn = lambda d, p: p["a"] / (d * d) * jnp.where(p["b"] > 0, 1.0, jnp.nan)  # noqa: E731
    res = af.fit_many((fn, {"a": 1.0, "b": np.array([1.0, -1.0])}), d, target, free=("a",))
    assert res.converged.tolist() == [True, False]
    assert res[0].params["a"] == np.float64(2.0) or abs(res[0].params["a"] - 2.0) < 1e-8
    assert "not finite" in res[1].message
    _strict_json(res[1].to_dict())


def test_parameter_on_its_bound_is_flagged():
    # the data are exactly inverse-square: the best eps is 0, the bound of a nonnegative eps
    res = af.fit((lambda d, p: 1 / (d * d + p["e"]), {"e": 1.0}, {"e": "nonnegative"}), D, 1 / D**2)
    assert res.at_bound == ("e",)
    assert res.params["e"] == 0.0
    assert "bound" in res.message
    assert "(on bound)" in str(res)
    assert res.to_dict()["at_bound"] == ["e"]


def test_cli_fit_that_fails_exits_3_and_keeps_its_numbers(tmp_path, capsys, monkeypatch):
    """`attenfit fit` with a non-converging fit: exit 3, a line saying so, strict JSON written.

    The CLI has no max-steps option; the fit is made to fail for real by running the
    solver for one step from the family's default start (no data-derived guess).
    """
    from attenfit._fit import _api

    real_fit = _api.fit
    monkeypatch.setattr(
        _api, "fit", lambda *a, **k: real_fit(*a, **{**k, "max_steps": 1, "guess": False})
    )
    out = tmp_path / "fits"
    argv = ["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "0.5"]
    code = main([*argv, "--json", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 3, captured.err
    assert "1 of 1 fits did not converge" in captured.err
    assert "Traceback" not in captured.err
    rows = json.loads(captured.out)
    assert rows[0]["converged"] is False and rows[0]["message"]
    saved = json.loads((out / "fits.json").read_text())
    assert saved == rows
    _strict_json(saved)
