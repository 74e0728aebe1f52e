"""Datasets: builders (checked against formulas written here), files, corrupt files, the CLI verb."""

import io
import json
import math
import zipfile

import numpy as np
import pytest

import attenfit as af
from attenfit.cli import main

SPHERE = af.SphereEmitter([0.0, 0.0, 1.0], 0.5, 2.0)
DISK = af.DiskEmitter([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 0.5, 2.0)
CAPSULE = af.CapsuleEmitter([-0.5, 0.0, 1.0], [0.5, 0.0, 1.0], 0.2, 2.0)


# ----------------------------------------------------------------------------- builders
def test_facing_sweep_sphere_is_inverse_square_and_disk_is_exact():
    ds = af.facing_sweep(SPHERE, 0.6, 100.0, n=16)
    d = np.geomspace(0.6, 100.0, 16)
    np.testing.assert_allclose(ds.distance(), d, rtol=1e-14)
    np.testing.assert_allclose(ds.E, 2.0 / d**2, rtol=1e-14)  # facing sphere = point light
    np.testing.assert_allclose(ds.attenuation(), 1 / d**2, rtol=1e-14)
    dd = af.facing_sweep(DISK, 1e-3, 100.0, n=16)
    d = np.geomspace(1e-3, 100.0, 16)
    np.testing.assert_allclose(dd.E, 2.0 / (d**2 + 0.25), rtol=1e-14)  # Howell B-12
    assert dd.provenance["generator"] == "attenfit.irradiance"
    assert np.all(dd.stderr == 0) and len(dd) == 16


def test_facing_sweep_capsule_tends_to_inverse_square():
    ds = af.facing_sweep(CAPSULE, 0.3, 1e4, n=16)
    att = ds.attenuation() * ds.distance() ** 2
    assert att[-1] == pytest.approx(1.0, rel=1e-6)
    assert np.all(np.isfinite(att)) and np.all(ds.weight() > 0)


def test_plane_receivers_grid_touching_and_crossing():
    touching = af.plane_receivers(SPHERE, 0.5, 2.0, n=9)
    assert touching.provenance["shape"] == [9, 9]
    img = touching.grid_image()
    assert img.shape == (9, 9)
    # the grid's centre is the contact point: on the sphere, so left out
    assert np.isnan(img[4, 4]) and np.sum(np.isnan(img)) == 1
    crossing = af.plane_receivers(SPHERE, 0.2, 2.0, n=9)
    inside = np.linalg.norm(crossing.points - np.array([0.0, 0.0, 1.0]), axis=1) <= 0.5
    assert not inside.any()
    assert len(crossing) == 81 - np.sum(np.isnan(crossing.grid_image()))
    # receivers on a plane through a sphere: exact values next to the rim are finite
    assert np.all(np.isfinite(crossing.E))
    # plane through the light's centre with a downward-facing disk: everything behind it
    flat = af.plane_receivers(DISK, 0.0, 2.0, n=4)
    assert np.all(flat.E == 0)
    with pytest.raises(af.BadValueError, match="not a receiver grid"):
        af.facing_sweep(SPHERE, 1, 2, n=4).grid_image()


def test_plane_receivers_values_match_irradiance_of_its_points():
    ds = af.plane_receivers(CAPSULE, 0.5, 1.5, n=(8, 12))
    assert ds.provenance["shape"] == [8, 12]
    assert ds.grid_image().shape == (8, 12)
    pad = 128 - len(ds)  # the builder's batch size: no new compilation
    p = np.concatenate([ds.points, np.repeat(ds.points[:1], pad, 0)])
    n = np.concatenate([ds.normals, np.repeat(ds.normals[:1], pad, 0)])
    E = np.asarray(af.irradiance(CAPSULE, p, n))[: len(ds)]
    np.testing.assert_array_equal(ds.E, E)
    x = np.linspace(-1.5, 1.5, 12)
    np.testing.assert_allclose(ds.points[:12, 0], x, rtol=1e-14)  # first row: x varies fastest
    np.testing.assert_allclose(ds.provenance["x_axis"], [1.0, 0.0, 0.0])


def test_random_receivers_cover_clipped_and_below_cases():
    for em in (SPHERE, DISK, CAPSULE):
        ds = af.random_receivers(em, 120, 0.6, 20.0, seed=3)
        again = af.random_receivers(em, 120, 0.6, 20.0, seed=3)
        np.testing.assert_array_equal(ds.points, again.points)
        d = ds.distance()
        assert np.all(d >= 0.6 * (1 - 1e-9)) and np.all(d <= 20.0 * (1 + 1e-9) + 1.0)
        assert np.mean(ds.E == 0) > 0.1  # wholly below the horizon (or behind the disk)
        # horizon-clipped: the centre direction is within the light's angular radius of the horizon
        l = (np.asarray(em.reference_point()) - ds.points) / np.linalg.norm(
            np.asarray(em.reference_point()) - ds.points, axis=1, keepdims=True
        )
        cos_t = np.sum(l * ds.normals, axis=1)
        clipped = np.abs(cos_t) < float(em.radius) / np.linalg.norm(
            np.asarray(em.reference_point()) - ds.points, axis=1
        )
        assert np.mean(clipped & (ds.E > 0)) > 0.1


def test_builders_reject_bad_arguments():
    with pytest.raises(af.BadValueError, match=r"d_min \(0.4\) must exceed the sphere's radius"):
        af.facing_sweep(SPHERE, 0.4, 2.0)
    with pytest.raises(af.BadValueError, match="d_max"):
        af.random_receivers(DISK, 10, 2.0, 1.0)
    with pytest.raises(af.BadTypeError, match="n must be an integer"):
        af.facing_sweep(DISK, 0.1, 2.0, n=2.5)
    with pytest.raises(af.BadValueError, match="every grid point lies inside"):
        af.plane_receivers(SPHERE, 0.0, 0.1, n=3)
    with pytest.raises(af.BadTypeError, match="dtype must be float32 or float64"):
        af.facing_sweep(DISK, 0.1, 2.0, dtype=np.int32)
    # found by the fuzz test: an intensity whose irradiance (up to pi L = I / r^2) overflows
    # float32 was an internal error; it is the user's choice of values, said in one line
    bright = af.SphereEmitter([0.0, 0.0, 0.0], 1.0, intensity=1e300)
    with pytest.raises(af.BadValueError, match=r"irradiance up to 1e\+300\) overflows float32"):
        af.facing_sweep(bright, 1.5, 2.0, n=4, dtype=np.float32)
    big = af.SphereEmitter([0.0, 0.0, 0.0], 40.0, intensity=1e40)  # I itself overflows float32
    with pytest.raises(af.BadValueError, match=r"intensity 1e\+40 .* overflows float32"):
        af.facing_sweep(big, 50.0, 60.0, n=4, dtype=np.float32)
    assert np.all(np.isfinite(af.facing_sweep(bright, 1.5, 2.0, n=4, dtype=np.float64).E))


def test_float32_datasets_stay_float32():
    ds = af.facing_sweep(DISK, 0.1, 10.0, n=16, dtype=np.float32)
    assert ds.E.dtype == np.float32 and ds.points.dtype == np.float32
    d = np.geomspace(0.1, 10.0, 16)
    np.testing.assert_allclose(ds.E, 2.0 / (d**2 + 0.25), rtol=2e-6)


# ----------------------------------------------------------------------------- Dataset
def _small():
    return af.Dataset(
        SPHERE,
        np.array([[0.0, 0.0, -1.0], [1.0, 0.0, 0.0]]),
        np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]]),
        np.array([0.5, 0.25]),
        np.array([0.01, 0.02]),
        {"generator": "test", "seed": 1},
    )


def test_dataset_validates_its_fields():
    p = np.zeros((2, 3))
    n = np.ones((2, 3))
    with pytest.raises(af.BadValueError, match=r"points must have shape \(N, 3\)"):
        af.Dataset(SPHERE, np.zeros((2, 2)), n, np.zeros(2), np.zeros(2))
    with pytest.raises(af.BadValueError, match="E must be finite"):
        af.Dataset(SPHERE, p, n, np.array([1.0, np.nan]), np.zeros(2))
    with pytest.raises(af.BadValueError, match="stderr must be >= 0"):
        af.Dataset(SPHERE, p, n, np.zeros(2), np.array([0.0, -1.0]))
    with pytest.raises(af.BadValueError, match="normals must be non-zero"):
        af.Dataset(SPHERE, p, np.zeros((2, 3)), np.zeros(2), np.zeros(2))
    with pytest.raises(af.BadTypeError, match="E must be a float array"):
        af.Dataset(SPHERE, p, n, np.array([1, 2]), np.zeros(2))
    with pytest.raises(af.BadValueError, match="JSON-serialisable"):
        af.Dataset(SPHERE, p, n, np.zeros(2), np.zeros(2), {"when": object()})
    ds = af.Dataset(SPHERE, p, n, np.zeros(2), 0.0)  # scalar stderr broadcasts
    assert ds.stderr.shape == (2,)
    with pytest.raises(ValueError):
        ds.E[0] = 1.0  # read-only


def test_attenuation_is_nan_where_weight_is_zero():
    ds = _small()
    att = ds.attenuation()
    assert att[0] == pytest.approx(0.5 / 2.0)  # facing: weight = I
    assert ds.weight()[1] == pytest.approx(2.0 * 1 / math.sqrt(2))
    ds2 = af.Dataset(SPHERE, ds.points, -ds.normals, ds.E, ds.stderr)
    assert np.all(np.isnan(ds2.attenuation()))


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_save_load_round_trip(tmp_path, dtype):
    ds = af.random_receivers(CAPSULE, 16, 0.5, 5.0, seed=2, dtype=dtype)
    path = ds.save(tmp_path / "d.npz")
    back = af.Dataset.load(path)
    for name in ("points", "normals", "E", "stderr"):
        got, want = getattr(back, name), getattr(ds, name)
        assert got.dtype == want.dtype
        np.testing.assert_array_equal(got, want)
    assert back.emitter.to_dict() == ds.emitter.to_dict()
    assert back.provenance == ds.provenance
    with pytest.raises(af.OutputExistsError, match="exists"):
        ds.save(path)
    ds.save(path, force=True)
    assert [p.name for p in tmp_path.iterdir()] == ["d.npz"]  # no temporary left behind


def _write_npz(path, **arrays):
    buf = io.BytesIO()
    np.savez(buf, **arrays)
    path.write_bytes(buf.getvalue())


def test_load_refuses_missing_truncated_corrupt_and_foreign_files(tmp_path):
    good = _small().save(tmp_path / "good.npz")
    raw = good.read_bytes()
    with pytest.raises(af.DataFileError, match="does not exist"):
        af.Dataset.load(tmp_path / "missing.npz")
    (tmp_path / "trunc.npz").write_bytes(raw[: len(raw) // 2])
    with pytest.raises(af.DataFileError, match="not a readable attenfit dataset"):
        af.Dataset.load(tmp_path / "trunc.npz")
    (tmp_path / "noise.npz").write_bytes(b"\x00garbage" * 50)
    with pytest.raises(af.DataFileError, match="not a readable attenfit dataset"):
        af.Dataset.load(tmp_path / "noise.npz")
    _write_npz(tmp_path / "foreign.npz", x=np.arange(3))
    with pytest.raises(af.DataFileError, match="no header"):
        af.Dataset.load(tmp_path / "foreign.npz")
    with np.load(good) as z:
        arrays = {k: z[k] for k in z.files}
    header = json.loads(str(arrays["header"]))

    def variant(name, **changes):
        a = dict(arrays)
        h = dict(header)
        for k, v in changes.items():
            if k in ("format", "version", "n", "emitter"):
                h[k] = v
            else:
                a[k] = v
        a["header"] = np.asarray(json.dumps(h))
        _write_npz(tmp_path / name, **a)
        return tmp_path / name

    with pytest.raises(af.DataFileError, match="header format"):
        af.Dataset.load(variant("fmt.npz", format="other"))
    with pytest.raises(af.DataFileError, match="format version 99"):
        af.Dataset.load(variant("ver.npz", version=99))
    with pytest.raises(af.DataFileError, match="E must be finite"):
        af.Dataset.load(variant("nan.npz", E=np.array([np.nan, 1.0])))
    with pytest.raises(af.DataFileError, match=r"E must have shape \(2,\)"):
        af.Dataset.load(variant("shape.npz", E=np.zeros(3)))
    with pytest.raises(af.DataFileError, match="unknown emitter kind"):
        af.Dataset.load(variant("em.npz", emitter={"kind": "cube"}))
    with pytest.raises(af.DataFileError, match="header says 5 receivers"):
        af.Dataset.load(variant("n.npz", n=5))
    # a pickled object array is refused, not executed
    with zipfile.ZipFile(tmp_path / "pickle.npz", "w") as zf:
        buf = io.BytesIO()
        np.save(buf, np.array([{"a": 1}], dtype=object), allow_pickle=True)
        zf.writestr("header.npy", buf.getvalue())
    with pytest.raises(af.DataFileError):
        af.Dataset.load(tmp_path / "pickle.npz")


# ----------------------------------------------------------------------------- CLI
def test_cli_truth_writes_a_dataset(tmp_path, capsys):
    out = tmp_path / "t.npz"
    rc = main(
        [
            "truth",
            "--emitter",
            "disk",
            "--radius",
            "0.5",
            "--range",
            "0.1:10",
            "--samples",
            "16",
            "--out",
            str(out),
        ]
    )
    assert rc == 0
    assert "wrote" in capsys.readouterr().out
    ds = af.Dataset.load(out)
    d = np.geomspace(0.1, 10, 16)
    np.testing.assert_allclose(ds.E, 1 / (d**2 + 0.25), rtol=1e-14)
    rc = main(
        [
            "truth",
            "--emitter",
            "sphere",
            "--radius",
            "0.5",
            "--receivers",
            "plane",
            "--samples",
            "4",
            "--out",
            str(out),
        ]
    )
    assert rc == 2
    assert capsys.readouterr().err.startswith("attenfit: error: output file")
    rc = main(
        [
            "truth",
            "--emitter",
            "capsule",
            "--radius",
            "0.2",
            "--receivers",
            "random",
            "--samples",
            "16",
            "--range",
            "0.3:3",
            "--seed",
            "4",
            "--out",
            str(out),
            "--force",
        ]
    )
    assert rc == 0
    assert af.Dataset.load(out).provenance["seed"] == 4


@pytest.mark.parametrize(
    "args, message",
    [
        (["--range", "3:1"], "attenfit: error: --range A:B needs 0 < A <= B < inf, got '3:1'"),
        (["--range", "x"], "attenfit: error: --range must be A:B with two numbers, got 'x'"),
        (["--radius", "-1"], "attenfit: error: --radius must be > 0, got -1.0"),
        (["--samples", "0"], "attenfit: error: --samples must be >= 1, got 0"),
        (
            ["--range", "0.1:2"],
            "attenfit: error: d_min (0.1) must exceed the sphere's radius (0.5): receivers would be inside",
        ),
    ],
)
def test_cli_truth_bad_input_exits_2(tmp_path, capsys, args, message):
    base = {"--emitter": "sphere", "--radius": "0.5", "--out": str(tmp_path / "x.npz")}
    for k in range(0, len(args), 2):
        base[args[k]] = args[k + 1]
    argv = ["truth"] + [x for kv in base.items() for x in kv]
    assert main(argv) == 2
    assert capsys.readouterr().err.strip() == message
    assert not (tmp_path / "x.npz").exists()
