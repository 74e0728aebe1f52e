"""Tests of the fitting engine (`attenfit.fit`, `fit_many`, `fit_dataset`, the `fit` verb).

Reference values are written out here independently (closed forms in numpy, scipy's
`curve_fit` for the covariance), never taken from the code under test. Every distinct
(family, solver, loss, guess, shape, dtype) compiles once (~1-3 s), so the tests share a
few configurations: 256 samples, float64 unless a test is about float32.
"""

from __future__ import annotations

import json

import jax.numpy as jnp
import numpy as np
import pytest

import attenfit as af
from attenfit._fit import _api, _problem
from attenfit._fit import _compiled as _compile
from attenfit.cli import main

N = 256
D = np.linspace(0.01, 20.0, N)


def yuksel_np(d, r):
    """Yuksel 2020 eq. 7 written out: 2/r^2 (1 - d/sqrt(d^2 + r^2))."""
    return 2 / r**2 * (1 - d / np.sqrt(d * d + r * r))


def yuksel_stable(d, r):
    s = np.sqrt(d * d + r * r)
    return 2 / (s * (s + d))


# ----------------------------------------------------------------------------- known answers
def test_self_generated_data_recovers_parameters():
    target = yuksel_stable(D, 0.7)
    res = af.fit(af.Yuksel(r=3.0), D, target)
    assert res.converged, res.message
    assert abs(res.params["r"] - 0.7) < 1e-6
    assert isinstance(res.params["r"], float)
    assert res.dtype == "float64"
    assert res.metrics["max_rel_error"] < 1e-9
    assert isinstance(res.model, af.Yuksel) and float(res.model.r) == res.params["r"]


def test_far_start_converges_or_says_so():
    target = yuksel_stable(D, 0.7)
    for start in (1e-4, 1e4):
        res = af.fit(af.Yuksel(r=start), D, target)
        if res.converged:
            assert abs(res.params["r"] - 0.7) < 1e-6
        else:
            assert res.message != "converged"
    # without the data-derived start too
    res = af.fit(af.Yuksel(r=1e4), D, target, guess=False)
    assert (res.converged and abs(res.params["r"] - 0.7) < 1e-6) or not res.converged


def test_polynomial_recovers_madams_sphere_curve():
    # Madams 2011: f = 1/(d_s + r)^2 in surface distance d_s. Times r^2 that is
    # 1/(1 + 2 d_s/r + d_s^2/r^2): kc = 1, kl = 2/r, kq = 1/r^2.
    r = 0.25
    ds = np.linspace(0.0, 10.0, N)
    target = r**2 / (ds + r) ** 2
    res = af.fit(af.Polynomial(kc=2.0, kl=1.0, kq=1.0), ds, target)
    assert res.converged, res.message
    got = [res.params["kc"], res.params["kl"], res.params["kq"]]
    np.testing.assert_allclose(got, [1, 2 / r, 1 / r**2], rtol=1e-6)
    assert res.at_bound == ()


def test_bound_optimum_is_reached_and_reported():
    # 1/(d^2 + r^2) is the polynomial with kl = 0: its optimum sits on the bound kl >= 0.
    r = 1.3
    target = 1 / (D**2 + r**2)
    res = af.fit(af.Polynomial(kc=3.0, kl=1.0, kq=0.5), D, target, guess=False)
    assert res.converged, res.message
    assert res.params["kl"] == 0.0 and not np.signbit(res.params["kl"])  # +0, not -0
    assert res.at_bound == ("kl",) and "bound" in res.message
    np.testing.assert_allclose([res.params["kc"], res.params["kq"]], [r**2, 1.0], rtol=1e-6)
    assert "(on bound)" in str(res)


def test_bound_optimum_with_residual_stays_on_the_bound():
    # Against the inverse square law 1/d^2 (d >= 1) the best polynomial wants kc < 0:
    # it must stop on kc = 0 and say so.
    d = np.linspace(1.0, 20.0, N)
    target = 1 / d**2 * (1 + 0.05 * np.sin(d))
    res = af.fit(af.Polynomial(kc=1.0, kl=0.5, kq=1.0), d, target, guess=False)
    assert res.converged, res.message
    assert min(res.params.values()) >= 0
    for p in res.at_bound:
        assert res.params[p] == 0.0


@pytest.mark.parametrize("solver", ["dogleg", "bfgs"])
def test_other_solvers_reach_the_same_answer(solver):
    r = 0.25
    ds = np.linspace(0.0, 10.0, N)
    target = r**2 / (ds + r) ** 2
    res = af.fit(af.Polynomial(kc=2.0, kl=1.0, kq=1.0), ds, target, solver=solver)
    assert res.converged, res.message
    assert res.solver == solver
    np.testing.assert_allclose(
        [res.params["kc"], res.params["kl"], res.params["kq"]], [1, 2 / r, 1 / r**2], rtol=1e-5
    )


@pytest.mark.parametrize("k", [3, 11])  # the unrolled Cholesky, and LAPACK's above UNROLL_MAX
def test_damped_step_solves_the_augmented_least_squares_problem(k):
    # The LM step solves (J^T J + lam D) x = J^T r with D = diag(J^T J); that is the least
    # squares solution of [J; sqrt(lam D)] x = [r; 0], here from numpy's lstsq.
    from attenfit._fit._solvers import UNROLL_MAX, gram, spd_solve

    assert (k > UNROLL_MAX) == (k == 11)
    rng = np.random.default_rng(3)
    jac = rng.normal(size=(N, k)) * np.logspace(-3, 3, k)  # badly scaled columns
    r = rng.normal(size=N)
    for lam in (1e-6, 1.0, 1e4):
        scale = np.sqrt(lam * np.sum(jac * jac, axis=0))
        aug = np.vstack([jac, np.diag(scale)])
        want = np.linalg.lstsq(aug, np.concatenate([r, np.zeros(k)]), rcond=None)[0]
        jtj, jtr = gram([jnp.asarray(jac[:, i]) for i in range(k)], jnp.asarray(r))
        got = spd_solve(jtj + lam * jnp.diag(jnp.diagonal(jtj)), jtr)
        np.testing.assert_allclose(np.asarray(got), want, rtol=1e-7, atol=1e-12)


def test_default_lm_matches_optimistix_lm():
    # attenfit's LM (normal equations, settling) against optimistix's own LM, from a far
    # start without the data-derived guess (so the solvers do the work).
    target = 1 / (1.0 + 0.3 * D + 0.05 * D**2)
    start = af.Polynomial(kc=50.0, kl=10.0, kq=0.01)
    default = af.fit(start, D, target, guess=False)
    stock = af.fit(start, D, target, guess=False, solver="optimistix_lm")
    assert default.converged and stock.converged, (default.message, stock.message)
    for p, want in (("kc", 1.0), ("kl", 0.3), ("kq", 0.05)):
        assert abs(default.params[p] - want) < 1e-6 * want
        assert abs(default.params[p] - stock.params[p]) < 1e-6 * want
    # from this far start both take about 20 steps (measured 21 and 22)
    assert default.steps <= stock.steps + 3


def test_weakly_seen_parameter_does_not_run_off():
    # Just Cause 2's window fitted to its own curve on d <= 5 m (range 13 m): among the
    # data-derived starts the best is a range 2560 m, where the residuals barely see r_max.
    # Undamped by Marquardt's scaling, r_max ran to 1e126 and the fit stopped there on a
    # vanishing gradient ("converged", loss 0.42); the floored scaling reaches the curve.
    d = np.geomspace(0.01, 5.0, 200)
    target = 1.3 * (1 - (d / 13.0) ** 2) ** 2
    res = af.fit(af.JustCause2(), d, target)
    assert res.converged, res.message
    assert abs(res.params["r_max"] - 13.0) < 1e-6 * 13 and abs(res.params["scale"] - 1.3) < 1e-6


def test_lm_stops_at_an_optimum_it_starts_on():
    # Started on the (nonzero-residual) optimum, the first-order test ends the solve at
    # once; optimistix's LM keeps rejecting steps whose acceptance ratio is rounding noise.
    target = yuksel_stable(D, 0.7)
    best = af.fit(af.Polynomial(), D, target)
    again = af.fit(best.model, D, target, guess=False)
    assert again.converged and again.steps <= 1, (again.steps, again.message)
    assert again.loss <= best.loss * (1 + 1e-12)


def test_lm_stops_at_an_exact_fit_it_starts_on():
    # A family fitted to its own curve from the truth: the residuals are rounding noise
    # (not all 0: the compiled solve contracts f / t - 1 into an FMA), where the relative
    # tests read noise; the rounding-level loss ends the solve at once (it took 11 steps).
    truth = af.get_family("threejs")()
    d = np.linspace(0.01, 9.0, N)
    res = af.fit(truth, d, np.asarray(truth(d)))
    assert res.converged and res.steps == 0, (res.steps, res.message)
    assert res.loss < 1e-25


def test_singular_jacobian_with_normal_equations():
    # Two parameters entering only as a sum: J^T J is singular and the damped normal
    # equations lean on the damping alone. The fit must still land on a + b = 1.5.
    target = 1 / (1.5 + D * D)
    res = af.fit(
        (lambda d, p: 1 / (p["a"] + p["b"] + d * d), {"a": 3.0, "b": 1.0}), D, target, guess=False
    )
    assert res.converged, res.message
    assert abs(res.params["a"] + res.params["b"] - 1.5) < 1e-9
    assert res.loss < 1e-20


def test_gauss_newton_without_damping_fails_visibly_on_a_rational_family():
    # Undamped Gauss-Newton from a far start jumps past the pole of 1/(kc + kl d + kq d^2):
    # the result must say it did not converge (never raise, never claim success wrongly).
    target = 1 / (D**2 + 1.3**2)
    res = af.fit(
        af.Polynomial(kc=50.0, kl=10.0, kq=0.01), D, target, solver="gauss_newton", guess=False
    )
    assert res.converged is False
    assert res.message.startswith("optimistix:")
    lm = af.fit(af.Polynomial(kc=50.0, kl=10.0, kq=0.01), D, target, guess=False)
    assert lm.converged and abs(lm.params["kc"] - 1.69) < 1e-6


# ----------------------------------------------------------------------------- user models
def _hyperbolic(d, p):
    return 1 / (p["a"] + d * d) ** p["b"]


def test_user_function_pair_and_nan_start_is_data():
    target = 1 / (D * D + 0.5)
    res = af.fit((_hyperbolic, {"a": 2.0, "b": 0.7}), D, target)
    assert res.converged, res.message
    np.testing.assert_allclose([res.params["a"], res.params["b"]], [0.5, 1.0], rtol=1e-6)
    fn, params = res.model
    assert fn is _hyperbolic and params == res.params
    # a start where the model is NaN (negative base to a fractional power): data, not error
    bad = af.fit((_hyperbolic, {"a": -1.0, "b": 0.7}), D, target)
    assert not bad.converged
    assert "not finite" in bad.message


# ----------------------------------------------------------------------------- covariance
def test_covariance_matches_scipy_curve_fit():
    from scipy.optimize import curve_fit

    rng = np.random.default_rng(3)
    r = 0.25
    ds = np.linspace(0.0, 10.0, N)
    truth = r**2 / (ds + r) ** 2
    target = truth * (1 + 0.01 * rng.standard_normal(N))
    res = af.fit(af.Polynomial(kc=2.0, kl=1.0, kq=1.0), ds, target)
    assert res.converged

    def model(d, kc, kl, kq):
        return 1 / (kc + kl * d + kq * d * d)

    # the relative loss is curve_fit with sigma = target (absolute_sigma=False)
    popt, pcov = curve_fit(
        model, ds, target, p0=[1, 8, 16], sigma=target, xtol=1e-14, ftol=1e-14, gtol=1e-14
    )
    np.testing.assert_allclose([res.params[p] for p in res.free], popt, rtol=1e-7)
    np.testing.assert_allclose(res.covariance, pcov, rtol=1e-5)
    np.testing.assert_allclose(list(res.stderr.values()), np.sqrt(np.diag(pcov)), rtol=1e-5)


# ----------------------------------------------------------------------------- batches
def test_fit_many_matches_a_loop_of_fit():
    radii = np.array([0.05, 0.3, 0.7, 2.0])
    target = np.stack([yuksel_stable(D, r) for r in radii])
    target[2] *= 1 + 0.02 * np.cos(D)  # not in the family: a residual remains
    starts = np.array([1.0, 0.1, 5.0, 0.5])
    many = af.fit_many(af.Yuksel(r=starts), D, target)
    assert len(many) == 4 and many.params["r"].shape == (4,)
    for i in range(4):
        one = af.fit(af.Yuksel(r=float(starts[i])), D, target[i])
        assert many[i].converged == one.converged
        np.testing.assert_allclose(many[i].params["r"], one.params["r"], rtol=1e-9)
        np.testing.assert_allclose(many[i].loss, one.loss, rtol=1e-7, atol=1e-25)
    np.testing.assert_allclose(many.params["r"][[0, 1, 3]], radii[[0, 1, 3]], rtol=1e-6)


def test_fit_many_snaps_only_the_problems_whose_optimum_is_on_the_bound():
    # Polynomial against 1/(d^2 + r^2) (optimum kl = 0, on the bound) and against
    # Yuksel's sphere curve (all three coefficients inside): in one batch the bound test
    # runs for all (a batch-wide branch), and must not move the inside ones.
    target = np.stack([1 / (D**2 + 1.3**2), yuksel_stable(D, 0.4), 1 / (D**2 + 0.2**2)])
    start = af.Polynomial(kc=np.array([3.0, 0.1, 1.0]), kl=np.ones(3), kq=np.full(3, 0.5))
    many = af.fit_many(start, D, target)
    assert many[0].params["kl"] == 0.0 and many[0].at_bound == ("kl",)
    assert many[2].params["kl"] == 0.0 and many[2].at_bound == ("kl",)
    assert many[1].at_bound == () and min(many[1].params.values()) > 0
    for i in range(3):
        one = af.fit(
            af.Polynomial(kc=float(start.kc[i]), kl=float(start.kl[i]), kq=float(start.kq[i])),
            D,
            target[i],
        )
        assert many[i].at_bound == one.at_bound
        for k in ("kc", "kl", "kq"):
            np.testing.assert_allclose(many[i].params[k], one.params[k], rtol=1e-9)
    # the bound-free batch takes the other branch and reaches the same answer
    inside = af.fit_many(
        af.Polynomial(kc=np.array([0.1]), kl=np.ones(1), kq=np.full(1, 0.5)), D, target[1:2]
    )
    for k in ("kc", "kl", "kq"):
        np.testing.assert_allclose(inside[0].params[k], many[1].params[k], rtol=1e-9)


def test_more_nonnegative_parameters_than_one_pass_tries_at_zero():
    # Four nonnegative coefficients (more than `_SUBSETS_MAX`: each is tried at 0 in its
    # own pass); the data use two of them, so the other two end exactly on 0.
    def fn(d, p):
        return 1 / (p["a"] + p["b"] * d + p["c"] * d * d + p["e"] * d * d * d)

    params = {"a": 0.5, "b": 0.5, "c": 0.5, "e": 0.5}
    kinds = dict.fromkeys(params, "nonnegative")
    assert len(kinds) > _problem._SUBSETS_MAX
    d = np.linspace(0.0, 5.0, N)
    res = af.fit((fn, params, kinds), d, 1 / (2.0 + 0.7 * d * d))
    assert res.converged, res.message
    assert res.params["b"] == 0.0 and res.params["e"] == 0.0
    assert set(res.at_bound) == {"b", "e"}
    np.testing.assert_allclose([res.params["a"], res.params["c"]], [2.0, 0.7], rtol=1e-6)


def test_reported_loss_is_the_loss_at_the_returned_parameters():
    # The LM ends with a Gauss-Newton step it does not evaluate; the fit evaluates the end
    # point and reports its loss (0.5 sum r^2), recomputed here in numpy.
    d = D
    target = yuksel_stable(d, 0.8)
    res = af.fit(af.Polynomial(kc=0.3, kl=0.1, kq=1.0), d, target, rtol=1e-8, atol=1e-8)
    p = res.params
    f = 1 / (p["kc"] + p["kl"] * d + p["kq"] * d * d)
    np.testing.assert_allclose(res.loss, 0.5 * np.sum(((f - target) / target) ** 2), rtol=1e-12)
    np.testing.assert_allclose(
        res.metrics["max_rel_error"], np.max(np.abs(f - target) / target), rtol=1e-9
    )


def test_sums_and_maxima_in_one_reduction():
    from attenfit._fit._solvers import reduce_samples

    rng = np.random.default_rng(3)
    x, y = rng.normal(size=(2, 257))
    got = reduce_samples([jnp.asarray(x), jnp.asarray(x * y)], [jnp.asarray(y)])
    np.testing.assert_allclose(got, [x.sum(), (x * y).sum(), y.max()], rtol=1e-12)
    y[5] = np.nan
    assert all(np.isnan(v) for v in reduce_samples([jnp.asarray(y)], [jnp.asarray(y)]))


def test_sums_and_maxima_over_the_last_axis_keep_leading_axes():
    from attenfit._fit._solvers import reduce_samples

    x = np.random.default_rng(4).normal(size=(3, 50))
    s, m = reduce_samples([jnp.asarray(x)], [jnp.asarray(x)])
    np.testing.assert_allclose(s, x.sum(axis=1), rtol=1e-12)
    np.testing.assert_array_equal(m, x.max(axis=1))


def test_maps_by_kind_match_each_coordinate_mapped_alone():
    from attenfit._fit._reparam import by_kind, param_slope, to_param

    kinds = ("positive", "real", "nonnegative", "unit", "positive")
    u = jnp.array([-1.5, -2.0, -0.25, 0.3, 2.0])
    for fn in (to_param, param_slope):
        want = [float(fn(k, u[i])) for i, k in enumerate(kinds)]
        np.testing.assert_allclose(by_kind(fn, kinds, u), want, rtol=1e-15)
    # one coordinate per kind, on and off its bound
    on = by_kind(_problem._on_bound, ("nonnegative", "positive", "unit", "real"), jnp.zeros(4))
    np.testing.assert_array_equal(on, [True, False, False, False])
    far = jnp.array([1.0, -200.0, 60.0, -1e300])
    on = by_kind(_problem._on_bound, ("nonnegative", "positive", "unit", "real"), far)
    np.testing.assert_array_equal(on, [False, True, True, False])


def test_scale_candidates_scale_only_the_free_lengths():
    from attenfit._fit._guess import SCALES, scale_candidates

    start = {"r": jnp.asarray(0.5), "eps": jnp.asarray(2.0), "fixed": jnp.asarray(7.0)}
    got = scale_candidates(start, ("r", "eps"), ("r",))
    assert set(got) == {"r", "eps"}
    np.testing.assert_allclose(got["r"], 0.5 * np.array(SCALES), rtol=1e-15)
    np.testing.assert_array_equal(got["eps"], np.full(len(SCALES), 2.0))
    assert scale_candidates(start, ("eps",), ()) == {}


def test_free_parameters_named_out_of_the_models_order():
    # `free` in another order than the family's fields: each parameter still gets its own
    # value, and the covariance follows `free`.
    target = 1 / (2.0 + 3.0 * D * D)
    start = af.Polynomial(kc=1.0, kl=0.0, kq=1.0)
    ab = af.fit(start, D, target * (1 + 0.01 * np.sin(D)), free=("kc", "kq"))
    ba = af.fit(start, D, target * (1 + 0.01 * np.sin(D)), free=("kq", "kc"))
    assert ba.free == ("kq", "kc")
    for p in ("kc", "kq"):
        np.testing.assert_allclose(ba.params[p], ab.params[p], rtol=1e-9)
        np.testing.assert_allclose(ba.stderr[p], ab.stderr[p], rtol=1e-6)
    np.testing.assert_allclose(ba.covariance, ab.covariance[::-1, ::-1], rtol=1e-6)
    exact = af.fit(start, D, target, free=["kq", "kc"])
    np.testing.assert_allclose([exact.params["kc"], exact.params["kq"]], [2.0, 3.0], rtol=1e-9)
    many = af.fit_many(
        af.Polynomial(kc=np.ones(2), kl=np.zeros(2), kq=np.ones(2)),
        D,
        np.stack([target, target]),
        free=("kq", "kc"),
    )
    np.testing.assert_allclose(many.params["kc"], [2.0, 2.0], rtol=1e-9)
    np.testing.assert_allclose(many[1].params["kq"], 3.0, rtol=1e-9)


def test_float32_fit_works_and_says_so():
    d32 = D.astype(np.float32)
    target = yuksel_np(D, 0.7).astype(np.float32)
    res = af.fit(af.Yuksel(r=2.0), d32, target)
    assert res.dtype == "float32"
    assert res.converged, res.message
    assert abs(res.params["r"] - 0.7) < 1e-4
    assert res.model(jnp.asarray(d32)).dtype == jnp.float32


def test_float32_fit_with_dogleg_while_x64_is_on():
    # The tests run with JAX's x64 mode on; optimistix's dogleg then mixed float64 into a
    # float32 solve and failed to trace (a TypeError, not a result). A float32 solve runs
    # with x64 off, as JAX runs float32 by default.
    d32 = D.astype(np.float32)
    target = (1 / (2.0 + 0.5 * D + 3.0 * D * D)).astype(np.float32)
    res = af.fit(af.Polynomial(kc=1.0, kl=1.0, kq=1.0), d32, target, solver="dogleg")
    assert res.dtype == "float32" and res.converged, res.message
    np.testing.assert_allclose(
        [res.params[p] for p in ("kc", "kl", "kq")], [2.0, 0.5, 3.0], rtol=1e-3
    )


@pytest.mark.parametrize("dtype", ["float32", "float64"])
def test_compiled_solve_options_keep_the_answer(monkeypatch, dtype):
    """The solve is compiled with XLA's reassociating fast math (`_COMPILER_OPTIONS`); at
    extreme scales it gives the answer of a strict IEEE compilation, within the tolerance."""
    d = 1e6 * np.geomspace(1e-3, 1e9, N)  # a 1e6 m light seen from 1 km to 1e15 m
    target = yuksel_stable(d, 0.7e6)
    start = af.Yuksel(r=2e6)
    fast = af.fit(start, d.astype(dtype), target.astype(dtype))
    monkeypatch.setattr(_compile, "_COMPILER_OPTIONS", None)
    monkeypatch.setattr(_compile, "_COMPILED", {})
    strict = af.fit(start, d.astype(dtype), target.astype(dtype))
    assert fast.converged and strict.converged, (fast.message, strict.message)
    tol = 1e-5 if dtype == "float32" else 1e-9
    assert fast.params["r"] == pytest.approx(strict.params["r"], rel=tol)
    assert fast.params["r"] == pytest.approx(0.7e6, rel=10 * tol)
    assert fast.loss == pytest.approx(strict.loss, rel=1e-3, abs=1e-12)


# ----------------------------------------------------------------------------- datasets
class _FakeDataset:
    """The `attenfit.Dataset` interface `fit_dataset` uses, with known weights."""

    def __init__(self, d, weight, E, stderr):
        self._d, self._w, self.E, self.stderr = d, weight, E, stderr

    def distance(self):
        return self._d

    def weight(self):
        return self._w


def test_fit_dataset_fits_irradiance_and_drops_unlit_receivers():
    r = 0.7
    weight = np.where(np.arange(N) % 5 == 0, 0.0, 0.5 + np.cos(D) ** 2)  # some unlit
    E = weight * yuksel_stable(D, r)
    E[weight == 0] = 123.0  # garbage where unlit: must be ignored
    res = af.fit_dataset(af.Yuksel(r=2.0), _FakeDataset(D, weight, E, np.zeros(N)))
    assert res.converged and abs(res.params["r"] - r) < 1e-6
    assert res.metrics["n"] == int(np.sum(weight > 0))
    # with standard errors: residuals divided by them; an exact dataset fits the same
    noisy = af.fit_dataset(af.Yuksel(r=2.0), _FakeDataset(D, weight, E, 1e-3 * E + 1e-9))
    assert noisy.converged and abs(noisy.params["r"] - r) < 1e-6


# ----------------------------------------------------------------------------- bad input
@pytest.mark.parametrize(
    ("kwargs", "error", "words"),
    [
        (dict(d=D[:10]), af.BadValueError, "d has shape (10,)"),
        (dict(target=np.full(N, np.nan)), af.BadValueError, "target must be finite"),
        (dict(target=-np.ones(N)), af.BadValueError, "target must be > 0"),
        (dict(solver="newton"), af.UnknownNameError, "unknown solver 'newton'"),
        (dict(loss="l1"), af.UnknownNameError, "unknown loss 'l1'"),
        (dict(free=("radius",)), af.UnknownNameError, "free names 'radius'"),
        (dict(d=np.array([]), target=np.array([])), af.BadValueError, "target is empty"),
        (dict(d=D.astype(complex)), af.BadTypeError, "floating-point"),
        (dict(weights=-np.ones(N)), af.BadValueError, "weights must be finite and >= 0"),
        (dict(max_steps=0), af.BadValueError, "max_steps"),
        (
            dict(model=(_hyperbolic, {"a": -1.0, "b": 1.0}, {"a": "positive"})),
            af.BadValueError,
            "start value of 'a' must be > 0",
        ),
        (dict(model=af.Yuksel), af.BadTypeError, "call it"),
    ],
)
def test_bad_arguments_raise_before_compiling(kwargs, error, words):
    args = dict(model=af.Yuksel(), d=D, target=yuksel_stable(D, 1.0))
    args.update(kwargs)
    model, d, target = args.pop("model"), args.pop("d"), args.pop("target")
    before = len(_compile._COMPILED)
    with pytest.raises(error) as info:
        af.fit(model, d, target, **args)
    assert words in str(info.value)
    assert "\n" not in str(info.value)
    assert len(_compile._COMPILED) == before


def test_fit_many_rejects_wrong_batch_shape():
    with pytest.raises(af.BadValueError, match="target must have shape"):
        af.fit_many(af.Yuksel(), D, yuksel_stable(D, 1.0))


# ----------------------------------------------------------------------------- result
def test_result_report_and_json():
    res = af.fit(af.Yuksel(r=3.0), D, yuksel_stable(D, 0.7) * (1 + 0.01 * np.sin(D)))
    text = str(res)
    assert text.startswith("[[Fit]] yuksel") and "[[Parameters]]" in text and "+/-" in text
    row = json.loads(json.dumps(res.to_dict()))
    assert row["family"] == "yuksel" and row["converged"] is True
    assert row["params"]["r"] == res.params["r"] and row["dtype"] == "float64"


# ----------------------------------------------------------------------------- CLI
def test_cli_fit_built_in_configuration(tmp_path, capsys):
    out = tmp_path / "fits"
    code = main(["fit", "--family", "yuksel,polynomial", "--emitter", "disk", "--radius", "0.5",
                 "--out", str(out), "--json"])  # fmt: skip
    assert code == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["family"] for r in rows] == ["yuksel", "polynomial"]
    # the facing disk is 1/(d^2 + r^2): the polynomial kc = r^2, kl = 0, kq = 1
    poly = rows[1]["params"]
    np.testing.assert_allclose([poly["kc"], poly["kl"], poly["kq"]], [0.25, 0, 1], atol=1e-9)
    assert json.loads((out / "fits.json").read_text())[0]["family"] == "yuksel"
    assert "[[Fit]] polynomial" in (out / "fits.txt").read_text()
    # refuses to overwrite without --force
    code = main(
        ["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "0.5", "--out", str(out)]
    )
    assert code == 2 and "exists" in capsys.readouterr().err


def test_cli_fit_exit_codes(monkeypatch, capsys):
    assert main(["fit", "--family", "nope", "--emitter", "disk", "--radius", "1"]) == 2
    assert "unknown family 'nope'" in capsys.readouterr().err
    assert main(["fit", "--family", "yuksel", "--emitter", "disk"]) == 2
    assert "--radius" in capsys.readouterr().err
    assert (
        main(["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "1", "--solver", "x"])
        == 2
    )
    assert "unknown solver 'x'" in capsys.readouterr().err
    real_fit = _api.fit

    def failing_fit(*args, **kwargs):
        res = real_fit(*args, **kwargs)
        return type(res)(**{**res.__dict__, "converged": False, "message": "optimistix: stuck"})

    monkeypatch.setattr(_api, "fit", failing_fit)
    assert main(["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "0.5"]) == 3
    assert "did not converge" in capsys.readouterr().err
