"""The Mitsuba witness vouches only for what it can know (issue 22, item 5).

* Receivers near a light: Mitsuba's spawn offset, `(1 + max|p|) * 1500 * 2^-24` along the
  normal (`Interaction::offset_p`), put receivers 1.2e-5 m in front of a disk behind it
  (0.0146 for an exact 10.47, z = -6006). `data_gen` now spawns shadow rays from the light and
  cosine rays from the receiver; what float32 cannot resolve (2^-16 of the scene's scale) is
  kept out by the same rule in `attenfit truth`'s builders and `data_gen`.
* Calibration: over a few hundred random receivers, |z| of a calibrated standard error has
  median 0.674 (the median of |N(0, 1)|); the float32 bounds only enter where they are real.
"""

from __future__ import annotations

import numpy as np
import pytest

mi = pytest.importorskip("mitsuba")

import attenfit as af  # noqa: E402
from attenfit._truth._clearance import (  # noqa: E402
    CLEARANCE,
    RAY_EPSILON,
    SHADOW_EPSILON,
    scene_scale,
    surface_distance,
    too_close,
)
from data_gen.render import render_dataset  # noqa: E402

SCALAR = "scalar_rgb"


@pytest.fixture(autouse=True)
def _x64():
    import jax

    jax.config.update("jax_enable_x64", True)


def _z(mc, exact):
    lit = np.asarray(mc.stderr) > 0
    return (np.asarray(mc.E)[lit] - np.asarray(exact.E)[lit]) / np.asarray(mc.stderr)[lit]


def test_mitsuba_constants_transcribed():
    """`include/mitsuba/core/math.h`: RayEpsilon = Epsilon * 1500, ShadowEpsilon = 10 x that."""
    mi.set_variant(SCALAR)
    assert RAY_EPSILON == pytest.approx(float(mi.math.RayEpsilon), rel=1e-7)
    assert SHADOW_EPSILON == pytest.approx(float(mi.math.ShadowEpsilon), rel=1e-7)
    # `Interaction::offset_p`: a ray spawned at p moves (1 + max|p|) RayEpsilon along n
    it = mi.Interaction3f()
    it.p, it.n = mi.Point3f(0.3, -0.1, 0.0), mi.Normal3f(0.0, 0.0, 1.0)
    ray = it.spawn_ray(mi.Vector3f(0.0, 0.0, 1.0))
    assert float(ray.o[2]) == pytest.approx(1.3 * RAY_EPSILON, rel=1e-5)


def test_issue_disk_receivers_in_front_of_the_disk():
    """`gen --emitter disk --radius 0.3 --receivers random --spp 20000 --seed 3`: two receivers
    1.2e-5 and 3.2e-5 m in front of the disk gave z = -6006 and -5003."""
    disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.3)
    exact = af.random_receivers(disk, 256, 3e-4, 300.0, seed=3)
    gap = surface_distance(disk, np.asarray(exact.points))
    near = np.flatnonzero(gap < 1e-4)
    assert near.size >= 2 and gap[near].min() < 2e-5  # the issue's receivers are still there
    sub = af.Dataset(
        exact.emitter,
        exact.points[near],
        exact.normals[near],
        exact.E[near],
        exact.stderr[near],
        {},
    )
    mc = render_dataset(sub, spp=4096, seed=3, variant=SCALAR)
    lit = np.asarray(sub.E) > 0
    assert lit.sum() >= 2 and np.asarray(sub.E)[lit].max() > 5.0  # E = 10.47 was rendered 0.0146
    z = (np.asarray(mc.E) - np.asarray(sub.E))[lit] / np.asarray(mc.stderr)[lit]
    assert np.abs(z).max() < 4.0, z


def test_sphere_receivers_near_the_surface():
    """Receivers 1.5e-5 r to 1e-2 r above a sphere, tilted: were off by up to 89%."""
    sph = af.SphereEmitter([0.0, 0.0, 0.0], 0.5)
    rng = np.random.default_rng(7)
    k = 24
    up = rng.normal(size=(k, 3))
    up /= np.linalg.norm(up, axis=1, keepdims=True)
    gap = 0.5 * np.geomspace(3e-5, 1e-2, k)
    pts = up * (0.5 + gap)[:, None]
    tilt = np.linspace(0.0, 1.5, k)
    side = np.cross(up, [0.3, 0.5, 0.8])
    side /= np.linalg.norm(side, axis=1, keepdims=True)
    normals = -np.cos(tilt)[:, None] * up + np.sin(tilt)[:, None] * side
    E = np.asarray(af.irradiance(sph, pts, normals))
    exact = af.Dataset(sph, pts, normals, E, np.zeros_like(E), {})
    mc = render_dataset(exact, spp=2048, seed=1, variant=SCALAR)
    z = _z(mc, exact)
    assert z.size == k and np.abs(z).max() < 4.0, z
    rel = np.asarray(mc.stderr) / np.asarray(exact.E)
    assert rel[gap > 5e-3 * 0.5].max() < 0.05  # and informative where the sampler is sound


@pytest.mark.parametrize(
    "emitter",
    [
        af.SphereEmitter([0.0, 0.0, 0.0], 0.5),
        af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.5),
    ],
    ids=["sphere", "disk"],
)
def test_builders_keep_receivers_out_of_float32_reach(emitter):
    lo = 1e-7 if isinstance(emitter, af.DiskEmitter) else 0.5 * (1 + 1e-7)
    rand = af.random_receivers(emitter, 500, lo, 0.6, seed=0)
    assert not too_close(emitter, np.asarray(rand.points)).any()
    grid = af.plane_receivers(emitter, 0.5, 1.0, n=21)  # touches the sphere at the centre
    assert not too_close(emitter, np.asarray(grid.points)).any()
    full = 21 * 21  # 441 and 500 receivers share one compiled size (512)
    if isinstance(emitter, af.DiskEmitter):
        assert len(grid) == full
    else:  # the contact point (inside: distance r), nothing more
        gap = surface_distance(emitter, np.asarray(grid.points))
        assert len(grid) == full - 1 and gap.min() >= CLEARANCE * 0.5


def test_facing_sweep_names_the_smallest_d_min():
    disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.01)
    with pytest.raises(af.BadValueError, match=r"d_min must be at least 1\.5258"):
        af.facing_sweep(disk, 1e-9, 1.0)
    need = CLEARANCE * float(scene_scale(disk, np.zeros((1, 3)))[0])
    assert len(af.facing_sweep(disk, need * 1.001, 1.0)) == 256


def test_readme_command_receivers_are_all_accepted():
    """`gen --emitter disk --radius 0.5 --receivers random --samples 512 --seed 1` exited 2."""
    from data_gen.clearance import check_clearance
    from data_gen.scenes import lights_from_emitter

    disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.5)
    for seed in range(8):
        ds = af.random_receivers(disk, 512, 5e-4, 500.0, seed=seed)
        check_clearance(lights_from_emitter(disk), np.asarray(ds.points))


@pytest.mark.parametrize(
    ("emitter", "n", "spp"),
    [
        (af.SphereEmitter([0.0, 0.0, 0.0], 0.5), 500, 256),
        # half are behind the disk; 1024 samples: at 256, 2 of 600 receivers within 1e-3 r
        # of it had |z| of 6.4 and 12.6 (a rare-sample tail the sample variance had not seen)
        (af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.3), 500, 1024),
        pytest.param(
            af.CapsuleEmitter([-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], 0.25),
            300,
            256,
            marks=pytest.mark.slow,  # compiling the capsule's quadrature: 15 s
        ),
        # a one-sided rectangle: as the disk, half the receivers behind it, 1024 samples
        # (measured: 207 lit, median 0.642, max 3.23)
        pytest.param(
            af.RectEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], 0.6, 0.3),
            500,
            1024,
            marks=pytest.mark.slow,
        ),
        # the capsule's tube without its ends: Mitsuba's open `cylinder` (measured: 232 lit,
        # median 0.625, max 2.82; a thinner tube, r = 0.1, gave 0.54-0.55: its horizon-straddling
        # receivers, drawn within r / d of the centre's direction, see slivers of a tube five
        # times longer than wide, where the rare-hit floor widens the errors on purpose)
        pytest.param(
            af.TubeEmitter([-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], 0.25),
            300,
            256,
            marks=pytest.mark.slow,
        ),
    ],
    ids=["sphere", "disk", "capsule", "rect", "tube"],
)
def test_standard_errors_are_calibrated(emitter, n, spp):
    """Median |z| over a few hundred lit random receivers near 0.674 (0.33 before: the float32
    cone bound applied where the bias it bounds was not there), and no |z| beyond 4.5."""
    r = float(emitter.radius)
    lo = 1e-3 * r if isinstance(emitter, af.DiskEmitter | af.RectEmitter) else 1.001 * r
    exact = af.random_receivers(emitter, n, lo, 1000 * r, seed=11)
    mc = render_dataset(exact, spp=spp, seed=5, variant="auto")  # llvm_ad_rgb where it works
    lit = np.asarray(exact.E) > 0
    z = np.abs(np.asarray(mc.E) - np.asarray(exact.E))[lit] / np.asarray(mc.stderr)[lit]
    assert z.size >= 200
    assert 0.55 <= float(np.median(z)) <= 0.8, float(np.median(z))
    # ~250 draws: P(max |Z| > 4.5) = 250 * 6.8e-6 = 0.2% for calibrated Gaussian errors
    assert z.max() < 4.5, z.max()


# ----------------------------------------------------------------------------- the report's section
def _pair(z, se=0.01):
    from attenfit._truth import Dataset

    n = len(z)
    pts = np.column_stack([np.linspace(1.0, 2.0, n), np.zeros(n), np.zeros(n)])
    nrm = np.tile([-1.0, 0.0, 0.0], (n, 1))
    em = af.SphereEmitter([0.0, 0.0, 0.0], 0.5)
    E = np.linspace(0.1, 1.0, n)
    exact = Dataset(em, pts, nrm, E, np.zeros(n), {})
    rendered = Dataset(
        em, pts, nrm, E + z * se, np.full(n, se), {"variant": "scalar_rgb", "spp": 64}
    )
    return exact, rendered


def test_witness_section_numbers_markdown_and_figure():
    from attenfit._report._witness import HALF_NORMAL_MEDIAN, witness_section

    z1 = np.random.default_rng(0).normal(size=200)
    z2 = np.array([0.5, -7.0, 1.0])  # one far beyond the histogram's edge
    sec = witness_section([("sphere floor", *_pair(z1)), ("disk random", *_pair(z2))], seconds=2)
    every = np.abs(np.concatenate([z1, z2]))
    assert sec.data["n"] == 203
    assert sec.data["median_abs_z"] == pytest.approx(np.median(every), rel=1e-9)
    assert sec.data["max_abs_z"] == pytest.approx(7.0, rel=1e-9)
    assert [s["n"] for s in sec.data["sets"]] == [200, 3]
    assert HALF_NORMAL_MEDIAN == pytest.approx(0.6744897501960817, abs=1e-15)
    md = sec.markdown("figures/witness_z.png")
    assert "## Mitsuba witness" in md and "median |z| = " in md and "witness_z.png" in md
    assert "| disk random | 3 | 1.00 | 7.00 |" in md
    assert sec.png.startswith(b"\x89PNG")


def test_witness_refuses_other_receivers_and_missing_errors():
    from attenfit._report._witness import witness_z
    from attenfit._truth import Dataset

    exact, rendered = _pair(np.zeros(4))
    other = Dataset(exact.emitter, exact.points[::-1], exact.normals, exact.E, exact.stderr, {})
    with pytest.raises(af.BadValueError, match="same receivers"):
        witness_z(other, rendered)
    with pytest.raises(af.BadValueError, match="without a standard error"):
        witness_z(
            exact, Dataset(exact.emitter, exact.points, exact.normals, exact.E + 1, np.zeros(4), {})
        )


def test_report_includes_the_witness_by_default(tmp_path):
    """`attenfit report` renders each light's floor and random receivers with Mitsuba."""
    import json

    from attenfit.cli import main

    out = tmp_path / "rep"
    argv = ["report", "--out", str(out), "--families", "inverse_square", "--emitters", "disk"]
    assert main([*argv, "--no-fit", "--sweep-n", "16", "--plane-px", "16"]) == 0
    md = (out / "report.md").read_text()
    assert "## Mitsuba witness" in md and (out / "figures" / "witness_z.png").is_file()
    w = json.loads((out / "report.json").read_text())["witness"]
    assert [s["label"] for s in w["sets"]] == ["disk floor", "disk random"]
    assert w["spp"] >= 1024 and w["n"] > 200
    assert 0.45 <= w["median_abs_z"] <= 0.95 and w["max_abs_z"] < 5.0
