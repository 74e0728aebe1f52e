"""A large batch is solved in two rounds (`attenfit._fit._compiled._in_rounds`): the problems
left unfinished after the first round's steps are solved again from their start. Each
problem must come out as the one-round solve gives it (and as `fit` gives it), stragglers
included.
"""

from __future__ import annotations

import numpy as np

import attenfit as af
from attenfit._fit import _compiled as _compile


def test_two_rounds_give_the_one_round_results(monkeypatch):
    # Yuksel's curve for radii over two decades, fitted from starts up to 1e4 times off and
    # without the start scan: the far starts take more than the first round's steps
    rng = np.random.default_rng(3)
    batch = _compile._ROUNDS_MIN_BATCH
    d = np.geomspace(0.01, 10.0, 64)
    radii = np.exp(rng.uniform(np.log(0.01), np.log(1.0), batch))
    s = np.sqrt(d[None] ** 2 + radii[:, None] ** 2)
    target = 2 / (s * (s + d[None]))
    target *= 1 + 0.01 * np.sin(7 * d)[None]  # not in the family: a residual remains
    starts = radii * np.exp(rng.uniform(-np.log(1e4), np.log(1e4), batch))
    model = af.Yuksel(r=starts)
    two = af.fit_many(model, d, target, guess=False)
    assert (two.steps > _compile._FIRST_ROUND).sum() >= 5  # the second round has work
    monkeypatch.setattr(_compile, "_ROUNDS_MIN_BATCH", 10**9)
    monkeypatch.setattr(_compile, "_COMPILED", {})
    one = af.fit_many(model, d, target, guess=False)
    np.testing.assert_array_equal(two.steps, one.steps)
    np.testing.assert_array_equal(two.converged, one.converged)
    np.testing.assert_allclose(two.params["r"], one.params["r"], rtol=1e-12)
    np.testing.assert_allclose(two.loss, one.loss, rtol=1e-12)
    i = int(np.argmax(two.steps))  # the slowest, against a fit of its own
    alone = af.fit(af.Yuksel(r=float(starts[i])), d, target[i], guess=False)
    assert alone.steps == two.steps[i]
    np.testing.assert_allclose(alone.params["r"], two.params["r"][i], rtol=1e-9)
