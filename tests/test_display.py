"""Display-referred images and errors in stops (`attenfit._report._display`), against the
Khronos PBR Neutral specification's formula and the sRGB standard, worked by hand."""

import numpy as np
import pytest

from attenfit._report._display import (
    display,
    exposure,
    pbr_neutral,
    plot_display_models,
    srgb_encode,
    stops,
    stops_bound,
)


def test_pbr_neutral_follows_the_specification():
    # x = 0.04 <= 2 F90: f = x - x^2/(4 F90) = 0.04 - 0.0016/0.16 = 0.03, out = x - f = 0.01
    assert pbr_neutral(0.04) == pytest.approx(0.01, rel=1e-15)
    # x = 0.5: f = F90 = 0.04, p = 0.46 < Ks = 0.76: out = 0.46
    assert pbr_neutral(0.5) == pytest.approx(0.46, rel=1e-15)
    # x = 2: p = 1.96 > Ks: p_n = 1 - 0.24^2 / (1.96 + 1 - 1.52) = 1 - 0.0576/1.44 = 0.96
    assert pbr_neutral(2.0) == pytest.approx(0.96, rel=1e-15)
    # continuous at the compression's start, monotone, below 1 however bright
    x = np.geomspace(1e-4, 1e6, 2001)
    y = pbr_neutral(x)
    assert np.all(np.diff(y) > 0) and y[-1] < 1
    ks = 0.76 + 0.04
    assert pbr_neutral(ks * (1 - 1e-12)) == pytest.approx(pbr_neutral(ks * (1 + 1e-12)), abs=1e-9)


def test_srgb_encoding_matches_the_standard():
    # IEC 61966-2-1: 12.92 v below 0.0031308, 1.055 v^(1/2.4) - 0.055 above; 0.18 -> 0.4614
    assert srgb_encode(0.001) == pytest.approx(0.01292, rel=1e-12)
    assert srgb_encode(0.18) == pytest.approx(1.055 * 0.18 ** (1 / 2.4) - 0.055, rel=1e-15)
    assert float(srgb_encode(0.18)) == pytest.approx(0.4614, abs=1e-4)
    assert srgb_encode(1.0) == pytest.approx(1.0, rel=1e-12)


def test_exposure_puts_the_brightest_lit_pixels_at_one():
    truth = np.concatenate([[0.0], np.arange(1.0, 101.0)])  # 0 is unlit: not metered
    k = exposure(truth)
    assert k == pytest.approx(1 / np.percentile(np.arange(1.0, 101.0), 99))
    assert display(truth, k)[1] == pytest.approx(srgb_encode(pbr_neutral(k)))


def test_stops_are_log2_ratios_and_bounds():
    s = stops([2.0, 1.0, 0.0, 1.0, 0.0], [1.0, 2.0, 1.0, 0.0, 0.0])
    assert s[0] == 1.0 and s[1] == -1.0 and s[2] == -np.inf and s[3] == np.inf and s[4] == 0.0
    assert stops_bound(0.5) == pytest.approx(1.0)  # half the light: one stop dark
    assert stops_bound(0.01) == pytest.approx(-np.log2(0.99))
    assert stops_bound(1.0) == np.inf and stops_bound(None) is None


def test_the_display_figure_draws_truth_models_and_stops():
    y, x = np.mgrid[-1:1:32j, -1:1:32j]
    truth = 1 / (x * x + y * y + 0.1)
    _, axes = plot_display_models(truth, {"half": truth / 2}, (-1, 1, -1, 1), unit="r")
    assert axes.shape == (2, 2)
    assert "max 1 stops" in axes[1, 1].get_title()
    _, axes = plot_display_models(truth, {"same": truth * (1 + 1e-9)}, (-1, 1, -1, 1))
    assert "max < 0.001 stops" in axes[1, 1].get_title()
    shown = axes[0, 1].images[0].get_array()
    assert np.all((shown >= 0) & (shown <= 1))
