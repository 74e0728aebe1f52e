"""Fitting area-light models (`fit`, `fit_dataset`, `fit_many`) on receivers of any orientation.

References are independent of the fit: the known parameter a synthetic target was drawn with,
and attenfit's exact irradiance (`Dataset.E`) for the loss a fitted model must beat.
"""

from __future__ import annotations

import numpy as np
import pytest

import attenfit as af
from attenfit import area

R = 0.25


def _receivers(n: int, seed: int) -> area.AreaInputs:
    """Sphere receivers at d/r 1.05-4 with cosines over the whole horizon band and above it."""
    rng = np.random.default_rng(seed)
    d = R * rng.uniform(1.05, 4.0, n)
    cos_r = rng.uniform(-0.6, 1.0, n)
    one = np.ones(n)
    return area.AreaInputs(d, cos_r, one, R * one, cos_r, one)


def test_fit_recovers_a_wrap_amount_on_tilted_receivers():
    x = _receivers(300, 1)
    target = np.asarray(area.UnrealWrap(k=1.3)(*x))
    keep = target > 0
    x, target = x.take(keep), target[keep]
    res = af.fit(area.UnrealWrap(), x, target)
    assert isinstance(res.model, area.UnrealWrap)
    assert res.model.k == pytest.approx(1.3, rel=1e-6)
    assert res.metrics["max_rel_error"] < 1e-6
    # the stacked (6, n) array is the same problem
    again = af.fit(area.UnrealWrap(k=0.7), x.stack(), target)
    assert again.model.k == pytest.approx(1.3, rel=1e-6)


@pytest.mark.slow  # a second compile (about 10 s); fit_many's batching is the families' own
def test_fit_many_recovers_each_problems_parameter():
    x = _receivers(200, 2)
    ks = (0.6, 1.3, 2.0)
    targets = np.stack([np.asarray(area.UnrealWrap(k=k)(*x)) for k in ks])
    keep = np.all(targets > 0, axis=0)
    xs = np.stack([np.asarray(x.take(keep).stack())] * len(ks))
    res = af.fit_many(area.UnrealWrap(), xs, targets[:, keep])
    assert [r.model.k for r in res] == pytest.approx(ks, rel=1e-5)


def test_fit_dataset_finds_the_best_wrap_against_exact_irradiance():
    sphere = af.SphereEmitter([0.0, 0.0, 0.0], R, intensity=2.0)
    ds = af.random_receivers(sphere, 400, 1.02 * R, 3 * R, seed=3)
    lit = ds.E > 0

    def rms_rel(model):
        pred = np.asarray(area.area_irradiance(model, sphere, ds.points, ds.normals))
        return float(np.sqrt(np.mean(((pred[lit] - ds.E[lit]) / ds.E[lit]) ** 2)))

    res = af.fit_dataset(area.UnrealWrap(), ds)
    assert res.metrics["n"] == int(lit.sum())
    best = rms_rel(res.model)
    assert res.metrics["rms_rel_error"] == pytest.approx(best, rel=1e-6)
    assert best < rms_rel(area.UnrealWrap())
    # a minimum: moving the wrap amount either way is worse against the exact irradiance
    k = float(res.model.k)
    assert best <= min(rms_rel(area.UnrealWrap(k=k * 0.99)), rms_rel(area.UnrealWrap(k=k * 1.01)))


@pytest.mark.parametrize(
    ("x", "match"),
    [
        (np.ones((5, 4)), "shape"),
        (np.stack([np.ones(4), np.full(4, 1.5), *np.ones((4, 4))]), "cos_r"),
        (np.stack([*np.ones((3, 4)), np.zeros(4), *np.ones((2, 4))]), "r out of range"),
        (np.stack([np.full(4, np.nan), *np.ones((5, 4))]), "finite"),
    ],
)
def test_bad_inputs_are_refused_by_name(x, match):
    with pytest.raises(af.BadValueError, match=match):
        af.fit(area.UnrealWrap(), x, np.ones(4))


def test_targets_must_match_the_receivers():
    with pytest.raises(af.BadValueError, match="receivers"):
        af.fit(area.UnrealWrap(), _receivers(5, 0), np.ones(4))


@pytest.mark.slow
def test_point_light_fits_as_its_family_does():
    """`PointLight(family)` fitted to a disk's facing sweep is the family fitted to it."""
    disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], R)
    ds = af.facing_sweep(disk, 0.1 * R, 30 * R, 64)
    fam = af.fit_dataset(af.Yuksel(r=0.5 * R), ds)
    pl = af.fit_dataset(area.PointLight(af.Yuksel(r=0.5 * R)), ds)
    assert pl.model.family.r == pytest.approx(float(fam.model.r), rel=1e-5)
