"""Data-derived starts (`attenfit._fit._guess`): a family's clamped distance
(`Family.clamp_param`) starts at its exact optimum.

Every curve here is written out in numpy from its published formula (RTR4 eq. 5.13 and the
engines' windows cited on each class), not from attenfit's code, with random parameters;
the fits start 8x off. The optimum a fit must reach is found independently, by the loss on
a dense grid of the clamp parameter (the loss is flat in p between samples only up to the
quadratic in 1/p^2, so the grid is refined around its best point by a bounded scalar
minimisation).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

import attenfit as af


def _window(d, r_max, n, p):
    """RTR4 eq. 5.14's window, (1 - (d/r_max)^n)+^p."""
    return np.clip(1 - (d / r_max) ** n, 0, None) ** p


def _fade(d, r_max):
    """CRYENGINE shadeLib.cfi::GetPhysicalLightAttenuation's fade, squared."""
    return np.clip((r_max - d) / (0.2 * r_max), 0, 1) ** 2


#: family -> (clamp parameter, g(d) with f = g / max(d, p)^2, the fixed parameters)
CURVES = {
    "clamped": ("r_min", lambda d: np.ones_like(d), {}),
    "madams_sphere": ("r", lambda d: np.ones_like(d), {}),
    "frostbite_window": ("r_min", lambda d: _window(d, 10.0, 4, 2), {"r_max": 10.0}),
    "cryengine_linear": ("r_min", lambda d: _fade(d, 10.0), {"r_max": 10.0}),
}


def _relative_loss(g, d, t, p):
    return 0.5 * np.sum((g / np.maximum(d, p) ** 2 / t - 1) ** 2)


def _grid_optimum(g, d, t):
    """The least relative loss over p, by a grid and a bounded refinement of its best."""
    grid = np.geomspace(d.min() / 10, d.max() * 10, 4001)
    losses = [_relative_loss(g, d, t, p) for p in grid]
    i = int(np.argmin(losses))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    fine = minimize_scalar(
        lambda p: _relative_loss(g, d, t, p),
        bounds=(lo, hi),
        method="bounded",
        options={"xatol": 1e-14},
    )
    return min(losses[i], fine.fun)


@pytest.mark.parametrize("name", sorted(CURVES))
def test_a_clamp_parameter_is_recovered_from_its_own_curve(name):
    param, g, fixed = CURVES[name]
    rng = np.random.default_rng(7)
    for _ in range(5):
        p_true = float(np.exp(rng.uniform(np.log(0.02), np.log(0.5))))
        d = np.geomspace(p_true / 4, min(20 * p_true, 5.0), 96)
        target = g(d) / np.maximum(d, p_true) ** 2
        start = p_true * (8.0 if rng.uniform() < 0.5 else 1 / 8)
        model = af.get_family(name)(**fixed, **{param: start})
        res = af.fit(model, d, target)
        assert res.converged
        np.testing.assert_allclose(res.params[param], p_true, rtol=1e-9)
        assert res.loss < 1e-20


@pytest.mark.parametrize("name", sorted(CURVES))
def test_the_clamp_start_is_the_global_optimum(name):
    # noisy samples of two lights' worth of shapes: a curve brighter near the light than
    # any clamp gives (the optimum clamps nothing) and one dimmer (it clamps some)
    param, g, fixed = CURVES[name]
    rng = np.random.default_rng(11)
    batch = 24
    d = np.geomspace(0.05, 5.0, 128)
    soft = rng.uniform(0.02, 0.4, batch)[:, None]
    bright = rng.uniform(-0.5, 1.5, batch)[:, None]
    target = g(d) / (d * d + soft**2) * (1 + bright * np.exp(-d / soft))
    target *= np.exp(0.05 * rng.standard_normal(target.shape))
    cls = af.get_family(name)
    starts = np.exp(rng.uniform(np.log(0.01), np.log(1.0), batch))
    res = af.fit_many(cls(**fixed, **{param: starts}), d, target)
    assert res.converged.all()
    for i in range(batch):
        best = _grid_optimum(g(d), d, target[i])
        assert res.loss[i] <= best * (1 + 1e-9), i
        single = af.fit(cls(**fixed, **{param: float(starts[i])}), d, target[i])
        np.testing.assert_allclose(single.loss, res.loss[i], rtol=1e-12)


def test_samples_in_decreasing_distance_give_the_same_fit():
    rng = np.random.default_rng(5)
    d = np.geomspace(0.05, 5.0, 64)
    target = 1 / (d * d + 0.1**2) * np.exp(0.05 * rng.standard_normal(d.shape))
    up = af.fit(af.Clamped(r_min=0.3), d, target)
    down = af.fit(af.Clamped(r_min=0.3), d[::-1], target[::-1])
    # the same interval and its optimum; read backwards, the clamped samples' sums are
    # the total less a running sum (rounding at n eps of the total)
    np.testing.assert_allclose(down.params["r_min"], up.params["r_min"], rtol=1e-10)
    np.testing.assert_allclose(down.loss, up.loss, rtol=1e-10)
    assert up.steps == down.steps == 0  # known optimal: the solver takes no step


def test_shuffled_samples_still_fit():
    # out of order the exact start does not apply: the scan's candidates and the solver
    # take over, and a problem of the same batch in order keeps its exact start
    rng = np.random.default_rng(6)
    d = np.geomspace(0.05, 5.0, 64)
    target = 1 / np.maximum(d, 0.2) ** 2
    shuffled = rng.permutation(len(d))
    ds = np.stack([d, d[shuffled]])
    ts = np.stack([target, target[shuffled]])
    res = af.fit_many(af.Clamped(r_min=np.array([0.03, 0.03])), ds, ts)
    assert res.converged.all()
    np.testing.assert_allclose(res.params["r_min"], [0.2, 0.2], rtol=1e-6)
    assert res.steps[0] == 0


def test_float32_fits_polish_the_exact_start():
    d = np.geomspace(0.05, 5.0, 64).astype(np.float32)
    target = (_window(d, 10.0, 4, 2) / np.maximum(d, 0.2) ** 2).astype(np.float32)
    res = af.fit(af.FrostbiteWindow(r_min=np.float32(1.5), r_max=np.float32(10.0)), d, target)
    assert res.converged
    np.testing.assert_allclose(res.params["r_min"], 0.2, rtol=1e-4)
