"""The decision table re-judged independently (issue 28's goal): benchmarks/bench_rejudge.py's
own truth (scipy quadrature over the light's visible solid angle) and own search (grid plus
Nelder-Mead), against the table in README.md's generated section.

The truth is checked here against closed forms and `scipy.integrate.dblquad` over the disk's
area; the re-judging runs one cell per light and band (the benchmark runs the whole table).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import integrate

from benchmarks import bench_rejudge as rj


@pytest.mark.parametrize("d", [1.0 + 1e-6, 1.5, 11.0, 900.0])
@pytest.mark.parametrize("cos_t", [1.0, 0.7])
def test_sphere_truth_closed_form_above_the_horizon(d, cos_t):
    # wholly above the horizon (cos t >= sin a): E = pi L (r/d)^2 cos t (Snyder 1996)
    if cos_t < 1.0 / d:
        pytest.skip("straddles the horizon")
    assert rj.sphere_truth(d, cos_t) == pytest.approx(math.pi * cos_t / d**2, rel=1e-10)


def test_sphere_truth_at_the_horizon():
    # n.l = 0 at d = 2 r: (a - sin a cos a) / (pi sin^2 a) of the facing value, sin a = 1/2
    # (docs/judging.md; Snyder 1996's form at cos t = 0)
    a = math.asin(0.5)
    facing = math.pi * 0.25
    assert rj.sphere_truth(2.0, 0.0) == pytest.approx(
        (a - math.sin(a) * math.cos(a)) / (math.pi * 0.25) * facing, rel=1e-10
    )


@pytest.mark.parametrize("z", [1e-6, 0.3, 2.0, 100.0])
def test_disk_truth_on_its_axis(z):
    # facing on the axis: E = pi L r^2 / (r^2 + z^2)
    assert rj.disk_truth(0.0, z, (0.0, 0.0, -1.0)) == pytest.approx(math.pi / (1 + z * z), 1e-10)


@pytest.mark.parametrize(
    "rho, z, n",
    [(0.5, 0.2, (0.3, 0.2, -0.9)), (1.5, 0.1, (-0.6, 0.3, -0.5)), (3.0, 1.0, (-0.2, 0, -0.97))],
)
def test_disk_truth_against_dblquad(rho, z, n):
    # clipped by the receiver's horizon: against the integrand over the disk's area
    n = tuple(np.asarray(n) / np.linalg.norm(n))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        want = rj.disk_truth_dblquad(rho, z, n)
    assert rj.disk_truth(rho, z, n) == pytest.approx(want, rel=1e-8)


def test_disk_truth_parallel_floor_closed_form():
    # a floor facing the disk, wholly in front: the parallel coaxial-disk form factor
    # (Howell's catalogue B-13 with a point receiver): E/L = pi/2 (1 - (h^2 + rho^2 - 1) /
    # sqrt((h^2 + rho^2 + 1)^2 - 4 rho^2))
    for rho, h in ((0.5, 0.3), (2.0, 0.5), (40.0, 3.0)):
        s = h * h + rho * rho
        want = math.pi / 2 * (1 - (s - 1) / math.sqrt((s + 1) ** 2 - 4 * rho * rho))
        assert rj.disk_truth(rho, h, (0.0, 0.0, -1.0)) == pytest.approx(want, rel=1e-9)


#: Coarse grids: the test re-judges one cell per light and band, the benchmark all of them.
_GRIDS = {"facing": (21,), "floor": (11, 11), "any-sphere": (21, 25), "any-disk": (5, 7, 11, 4)}


def _subset() -> list[rj.Cell]:
    """One cell per light and band: the most tolerant one (the cheapest model named)."""
    picked: dict[tuple[str, str], rj.Cell] = {}
    for c in rj.read_table():
        picked[(c.light, c.band)] = c
    return list(picked.values())


@pytest.mark.parametrize("rho, tilt", [(1.0, 1e-9), (0.5, 3e-9)])
def test_clipped_disk_at_contact_near_the_plane(rho, tilt):
    """A tilt below 1e-8 rad, which cos_n cannot carry (it rounds to 1): found by this
    re-judge, once 100-200% off in both clipped_disk and attenfit's truth."""
    n = np.array([tilt, 0.0, -1.0]) / math.hypot(tilt, 1.0)
    rx = rj.Rx(rho, 1e-9, tuple(n), rho - 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        cell = next(c for c in rj.read_table() if c.light == "disk" and c.band == "contact")
        err = rj.errors(rj.build(cell), "disk", rj.judge_set("disk", "any", [rx]))[0]
    assert err <= 0.01


@pytest.mark.slow
def test_decision_table_rejudged():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", integrate.IntegrationWarning)
        verdicts = rj.rejudge(_subset(), grids=_GRIDS, starts=2, maxfev=120)
    report = rj.table(verdicts)
    assert len(verdicts) == 6, report
    assert sum(v.understated for v in verdicts) == 0, report
    assert sum(v.misses for v in verdicts) == 0, report


@pytest.mark.parametrize("rho, tilt", [(1.0, 1e-9), (1.0 + 1e-9, 1e-9), (0.5, 3e-9)])
def test_attenfits_truth_near_the_plane_with_a_tilt_below_1e_8(rho, tilt):
    """attenfit's exact disk 1e-9 r in front of it, the normal tilted less than `1 - n.m^2`
    can carry in float64 (its horizon cuts the disk about r from the foot): against this
    file's independent truth (once 0 where the truth is pi L, docs/judging.md)."""
    import jax

    from attenfit._truth import DiskEmitter, irradiance

    n = np.array([tilt, 0.0, -1.0]) / math.hypot(tilt, 1.0)
    with jax.enable_x64(True):
        got = irradiance(DiskEmitter([0, 0, 0], [0, 0, 1], 1.0, math.pi), [[rho, 0, 1e-9]], [n])
    # intensity pi: radiance I / (pi r^2) = 1, the units of `rj.disk_truth`
    want = rj.disk_truth(rho, 1e-9, tuple(n), rho - 1.0)  # the same float receiver
    # 1e-9 r from the rim the two agree to 1.1e-6 (which of them holds the last digits is
    # not settled here); the fault this guards against was 0 against 0.46 and pi
    assert float(np.asarray(got)[0]) == pytest.approx(want, rel=1e-5)
