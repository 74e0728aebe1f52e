"""Tests of the fitting engine (`attenfit.fit`, `fit_many`, `fit_dataset`, the `fit` verb).

Reference values are written out here independently (closed forms in numpy, scipy's
`curve_fit` for the covariance), never taken from the code under test. The small families
below are defined here so these tests do not depend on the family catalogue.
"""

from __future__ import annotations

from typing import ClassVar

import jax.numpy as jnp
import numpy as np

import attenfit as af


class Poly(af.Family):
    """1/(kc + kl d + kq d^2) (the OpenGL polynomial), all coefficients nonnegative."""

    kc: float = 1.0
    kl: float = 0.0
    kq: float = 1.0
    name: ClassVar[str] = "polynomial"
    formula: ClassVar[str] = "1/(kc + kl d + kq d^2)"
    source: ClassVar[str] = "test"
    default_free: ClassVar[tuple[str, ...]] = ("kc", "kl", "kq")
    constraints: ClassVar[dict[str, str]] = {
        "kc": "nonnegative",
        "kl": "nonnegative",
        "kq": "nonnegative",
    }

    def __call__(self, d):
        d = jnp.asarray(d)
        return 1 / (self.kc + d * (self.kl + self.kq * d))


class Yuk(af.Family):
    """Yuksel 2020 eq. 7, 2/(s (s + d)), s = sqrt(d^2 + r^2)."""

    r: float = 0.1
    name: ClassVar[str] = "yuk_test"
    formula: ClassVar[str] = "2/(s(s+d))"
    source: ClassVar[str] = "test"
    default_free: ClassVar[tuple[str, ...]] = ("r",)
    length_params: ClassVar[tuple[str, ...]] = ("r",)

    def __call__(self, d):
        d = jnp.asarray(d)
        s = jnp.sqrt(d * d + self.r * self.r)
        return 2 / (s * (s + d))


D = np.linspace(0.01, 20.0, 256)


def yuksel_np(d, r):
    s = np.sqrt(d * d + r * r)
    return 2 / (s * (s + d))


def test_self_generated_data_recovers_parameters():
    target = yuksel_np(D, 0.7)
    res = af.fit(Yuk(r=3.0), D, target)
    assert res.converged, res.message
    assert abs(res.params["r"] - 0.7) < 1e-6
    assert res.dtype == "float64"
    assert res.metrics["max_rel_error"] < 1e-9


def test_polynomial_recovers_madams_sphere_curve():
    # Madams 2011: f = 1/(d_s + r)^2 in surface distance d_s; times r^2 it is
    # 1/(1 + 2 d_s/r + d_s^2/r^2), so kc = 1, kl = 2/r, kq = 1/r^2.
    r = 0.25
    ds = np.linspace(0.0, 10.0, 256)
    target = r**2 / (ds + r) ** 2
    res = af.fit(Poly(kc=2.0, kl=1.0, kq=1.0), ds, target)
    assert res.converged, res.message
    np.testing.assert_allclose(
        [res.params["kc"], res.params["kl"], res.params["kq"]], [1, 2 / r, 1 / r**2], rtol=1e-6
    )


def test_bound_optimum_is_reached_and_reported():
    # 1/(d^2 + r^2) is the polynomial with kl = 0 exactly: the optimum is on the bound.
    r = 1.3
    target = 1 / (D**2 + r**2)
    res = af.fit(Poly(kc=3.0, kl=1.0, kq=0.5), D, target, guess=False)
    assert res.converged, res.message
    assert res.params["kl"] == 0.0
    assert "kl" in res.at_bound and "bound" in res.message
    np.testing.assert_allclose([res.params["kc"], res.params["kq"]], [r**2, 1.0], rtol=1e-6)
