"""attenfit.metrics against values computed by hand."""

import math

import jax.numpy as jnp
import numpy as np
import pytest

from attenfit import BadValueError, metrics


def test_relative_error_by_hand():
    rel = metrics.relative_error([2.0, 1.0, 0.0, 3.0, np.inf], [1.0, 2.0, 4.0, 0.0, 1.0])
    assert rel[0] == 1.0  # twice too bright
    assert rel[1] == -0.5
    assert rel[2] == -1.0  # black
    assert math.isnan(rel[3])  # no truth to be relative to
    assert rel[4] == math.inf  # a singular curve


def test_error_stats_by_hand():
    s = metrics.error_stats([0.1, -0.3, np.nan, 0.2], at=[1.0, 2.0, 3.0, 4.0])
    assert s["n"] == 3
    assert s["max_abs"] == pytest.approx(0.3)
    assert s["worst"] == pytest.approx(-0.3)
    assert s["worst_at"] == 2.0
    assert s["rms"] == pytest.approx(math.sqrt((0.01 + 0.09 + 0.04) / 3))
    assert s["mean"] == pytest.approx(0.0)
    empty = metrics.error_stats([np.nan])
    assert empty["n"] == 0 and empty["max_abs"] is None


def test_bands_split_at_r_and_10r():
    r = 2.0
    d = np.array([1.0, 2.0, 10.0, 20.0, 30.0])  # near, mid, mid, mid (=10 r), far
    rel = np.array([0.5, 0.1, -0.2, 0.05, 0.01])
    b = metrics.band_errors(d, rel, r)
    assert b["near"]["n"] == 1 and b["near"]["max_abs"] == 0.5
    assert b["mid"]["n"] == 3 and b["mid"]["worst"] == pytest.approx(-0.2)
    assert b["mid"]["worst_at"] == 10.0
    assert b["far"]["n"] == 1 and b["far"]["max_abs"] == pytest.approx(0.01)
    with pytest.raises(BadValueError):
        metrics.band_errors(d, rel, 0.0)


def test_attenuation_errors_yuksel_against_facing_disk():
    # Yuksel eq. 7 over the facing disk is 2 sqrt(d^2+r^2) / (sqrt(d^2+r^2) + d), written
    # out here by hand (shared/reference/groundtruth.md §4): 2 at d = 0, 1.171572875 at d = r.
    r = 1.0
    d = np.array([0.0, 1.0, 100.0])
    truth = 1.0 / (d**2 + r**2)
    s = np.sqrt(d**2 + r**2)
    f7 = 2.0 / (s * (s + d))
    e = metrics.attenuation_errors(d, f7, truth, r, range_=50.0)
    assert e["overall"]["max_abs"] == pytest.approx(1.0, rel=1e-12)
    assert e["overall"]["worst_at"] == 0.0
    assert e["bands"]["mid"]["max_abs"] == pytest.approx(0.171572875, rel=1e-8)
    assert e["bands"]["far"]["max_abs"] == pytest.approx(2.4999e-5, rel=1e-3)
    assert e["in_range"]["n"] == 2  # d = 100 is beyond the range


def test_value_at_zero():
    v = metrics.value_at_zero(2.0, 1.0)
    assert v == {"value": 2.0, "finite": True, "truth": 1.0, "ratio": 2.0, "ratio_to_max": None}
    s = metrics.value_at_zero(np.inf, None, truth_max=4.0)
    assert s["finite"] is False and s["ratio"] is None and s["ratio_to_max"] == math.inf


def test_window_edge_unreal_window_by_hand():
    # (1 - (d/R)^4)^2 / d^2 near d = R: with u = 1 - (d/R)^4 ~ 4 delta, value ~ 16 delta^2 / R^2
    R = 3.0

    def f(d):
        u = jnp.clip(1.0 - (d / R) ** 4, 0.0, None)
        return u**2 / d**2

    w = metrics.window_edge(f, R, inside=1e-4)
    d = R * (1 - 1e-4)
    u = 1.0 - (d / R) ** 4
    assert w["value"] == pytest.approx(u**2 / d**2, rel=1e-6)
    # derivative of u^2/d^2: 2u u'/d^2 - 2u^2/d^3, u' = -4 d^3/R^4
    slope = 2 * u * (-4 * d**3 / R**4) / d**2 - 2 * u**2 / d**3
    assert w["slope"] == pytest.approx(slope, rel=1e-6)
    assert abs(w["value_rel"]) < 1e-6 and abs(w["slope_rel"]) < 1e-2
    inv = metrics.window_edge(lambda d: 1.0 / d**2, R)
    assert inv["value_rel"] == pytest.approx(1.0) and inv["slope_rel"] == pytest.approx(1.0)


def test_plane_energy_and_discarded_fraction_of_a_point_light():
    # A unit point light at height h over a plane: E = h / (h^2+rho^2)^(3/2); the flux over
    # the disc rho < P is 2 pi (1 - h / sqrt(h^2+P^2)) and the part beyond distance R is
    # 2 pi h / R, so the fraction beyond R within the disc is (h/R - h/dP) / (1 - h/dP).
    h, P, R = 1.0, 1000.0, 10.0
    rho = np.concatenate([[0.0], np.geomspace(1e-4, P, 20001)])
    d = np.sqrt(h**2 + rho**2)
    E = h / d**3
    dP = math.hypot(h, P)
    assert metrics.plane_energy(rho, E) == pytest.approx(2 * math.pi * (1 - h / dP), rel=1e-6)
    frac = metrics.discarded_fraction(rho, E, d, R)
    assert frac == pytest.approx((h / R - h / dP) / (1 - h / dP), rel=1e-4)
    with pytest.raises(BadValueError):
        metrics.plane_energy([1.0, 0.5], [1.0, 1.0])


def test_image_errors_by_hand():
    truth = np.array([[1.0, 2.0], [4.0, 0.0]])
    model = np.array([[1.5, 2.0], [3.0, 0.004]])
    xs, ys = np.meshgrid([0.0, 1.0], [10.0, 20.0])
    e = metrics.image_errors(model, truth, floor=1e-3, coords=(xs, ys))
    # errors: 0.5, 0, -0.25, and the black pixel 0.004 / (1e-3 * 4) = 1.0
    assert e["max_abs"] == pytest.approx(1.0)
    assert e["peak_index"] == [1, 1]
    assert e["peak_xy"] == [1.0, 20.0]
    assert e["rms"] == pytest.approx(math.sqrt((0.25 + 0 + 0.0625 + 1.0) / 4))
    assert e["energy_ratio"] == pytest.approx(6.504 / 7.0)
    assert metrics.grid_energy(truth, 0.5) == 3.5


def test_window_reach_of_unreals_window():
    # (1 - x^4)^2 is within 1% of 1 up to x = (1 - sqrt(0.99))^(1/4) = 0.2660, 10%: 0.4762
    R = 2.0
    d = np.linspace(1e-3, R, 200001)
    rel = (1 - (d / R) ** 4) ** 2 - 1
    assert metrics.window_reach(d, rel, R, 0.01) == pytest.approx(
        (1 - math.sqrt(0.99)) ** 0.25, abs=1e-4
    )
    assert metrics.window_reach(d, rel, R, 0.1) == pytest.approx(
        (1 - math.sqrt(0.9)) ** 0.25, abs=1e-4
    )
    assert metrics.window_reach(d, np.full_like(d, -1.0), R, 0.01) is None
    e = metrics.attenuation_errors(d, 1 + rel, np.ones_like(d), 0.1, range_=R)
    assert e["inner_half"]["max_abs"] == pytest.approx(1 - (1 - 1 / 16) ** 2, rel=1e-4)
