"""Robustness II: input that tries to hang, exhaust or mislead attenfit (issue 22).

Each class of defect is tested through the mechanism that fixes it, with the issue's own
examples among the cases:

* inputs that hang or exhaust the machine: special files, sizes, nesting, npz members, the
  memory budget (`attenfit/_input.py`, `attenfit/_budget.py`);
* internal errors on bad input: each of the issue's examples exits 2 with one line, and an
  internal error names itself as a bug with the way to get its traceback;
* silently wrong results: infinite ranges, fits that cannot be judged, receivers too far to
  judge, parameters that a float32 shader would round to 0, concurrent and symlinked
  outputs, outputs that would replace an input.

The CLI runs in-process (`attenfit.cli.main`), except where the case is a hang (a FIFO),
which runs in a subprocess with a timeout.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest
from _stderr import without_progress

import attenfit as af
from attenfit import _atomic, _budget, _input
from attenfit.cli import main
from attenfit.scene import Scene

REPO = Path(__file__).resolve().parent.parent


def _cli(capsys, *argv: str) -> tuple[int, str]:
    """The exit code and stderr, its progress lines left out (`_stderr`)."""
    code = main([str(a) for a in argv])
    return code, without_progress(capsys.readouterr().err.strip())


def _exit2(capsys, *argv: str, fragment: str) -> None:
    code, err = _cli(capsys, *argv)
    assert code == 2, err
    assert "\n" not in err and "Traceback" not in err, err
    assert fragment in err, err


SCENE = """tolerance = 0.05
[constraints]
families = ["inverse_square"]
[[lights]]
kind = "sphere"
radius = 0.1
height = 2
[[receivers]]
kind = "plane"
extent = 1
resolution = 4
"""


# ----------------------------------------------------------------------------- special files
@pytest.mark.parametrize("verb", ["scene", "export"])
def test_fifo_is_refused_not_waited_on(tmp_path, verb):
    fifo = tmp_path / ("s.toml" if verb == "scene" else "fits.json")
    os.mkfifo(fifo)
    proc = subprocess.run(
        [sys.executable, "-m", "attenfit", verb, str(fifo)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=tmp_path,
    )
    assert proc.returncode == 2, proc.stderr
    assert "is not a regular file (a pipe, device or socket)" in proc.stderr


@pytest.mark.parametrize("verb", ["scene", "export", "fit"])
def test_dev_zero_is_refused_before_reading(capsys, verb):
    argv = (
        ["fit", "--family", "yuksel", "--data", "/dev/zero"]
        if verb == "fit"
        else [verb, "/dev/zero"]
    )
    _exit2(capsys, *argv, fragment="is not a regular file")


def test_size_limit_before_parsing(tmp_path, capsys):
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:  # sparse: 5 MiB that take no disk
        fh.truncate(5 << 20)
    _exit2(capsys, "scene", big, fragment="is 5 MiB, over the 4 MiB")


# ----------------------------------------------------------------------------- nesting
def test_deep_json_is_refused(tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    _exit2(capsys, "export", deep, fragment="attenfit reads at most 32")


@pytest.mark.parametrize(
    "text",
    [
        "a = " + "[" * 10_000 + "]" * 10_000,
        "a = " + "{b = " * 5_000 + "1" + "}" * 5_000,
        "\n".join(f"k{i}" + ".x" * 40 + " = 1" for i in range(50)),  # dotted-key chains
        "[" + ".".join(f"t{i}" for i in range(50_000)) + "]",  # one 50,000-segment table
    ],
    ids=["arrays", "inline-tables", "dotted-keys", "table-header"],
)
def test_deep_toml_is_refused(tmp_path, capsys, text):
    path = tmp_path / "deep.toml"
    path.write_text(text)
    _exit2(capsys, "scene", path, fragment="attenfit reads at most 32")


def test_nesting_counts_brackets_outside_strings_only():
    assert _input.load_json('{"a": "[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[[["}', "x") == {
        "a": "[" * 38
    }
    text = 'name = "' + "[" * 40 + '"\n' + "# " + "{" * 40 + "\n"
    assert _input.load_toml(text, "x")["name"] == "[" * 40


# ----------------------------------------------------------------------------- npz archives
def _npz(path: Path, **arrays) -> Path:
    np.savez_compressed(path, **arrays)
    return path


def test_npz_declaring_more_than_the_budget_is_refused(tmp_path, monkeypatch):
    # 8 MB of zeros compress to a few kB: refused from the zip directory, before inflating
    path = _npz(tmp_path / "bomb.npz", E=np.zeros(1 << 20))
    assert path.stat().st_size < 100_000
    monkeypatch.setenv(_budget.ENV, "4M")
    with pytest.raises(af.DataFileError, match=r"unpacks to 8 MiB, over the 3\.81 MiB"):
        af.Dataset.load(path)


def test_sparse_file_that_starts_like_a_zip_is_not_read(tmp_path):
    path = tmp_path / "sparse.npz"
    with open(path, "wb") as fh:
        fh.write(b"PK\x03\x04")
        fh.truncate(6 << 30)  # 6 GB, sparse: reading it would take minutes and the memory
    with pytest.raises(af.DataFileError, match="is not a readable"):
        af.Dataset.load(path)


def test_npz_member_whose_header_lies_about_its_size(tmp_path):
    path = tmp_path / "liar.npz"
    header = b"{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000,), }"
    header += b" " * (118 - len(header)) + b"\n"
    with zipfile.ZipFile(path, "w") as zf:
        zf.writestr("E.npy", b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header)
    with pytest.raises(af.DataFileError, match=r"disagree|declares|holds"):
        _input.read_npz(path, "liar.npz", 1 << 30)


def test_big_endian_npz_is_read_in_native_order_and_longdouble_refused(tmp_path):
    ds = af.random_receivers(af.SphereEmitter([0, 0, 0], 0.5), 16, 1.0, 4.0, seed=1)
    ds.save(tmp_path / "ok.npz")
    arrays = dict(np.load(tmp_path / "ok.npz"))
    big = {
        k: (v.astype(v.dtype.newbyteorder(">")) if v.dtype.kind == "f" else v)
        for k, v in arrays.items()
    }
    loaded = af.Dataset.load(_npz(tmp_path / "big.npz", **big))
    np.testing.assert_array_equal(loaded.E, ds.E)
    assert loaded.E.dtype.isnative
    long = {**arrays, "E": arrays["E"].astype(np.longdouble)}
    with pytest.raises(
        af.DataFileError, match="holds float128; attenfit reads float32 and float64"
    ):
        af.Dataset.load(_npz(tmp_path / "long.npz", **long))


# ----------------------------------------------------------------------------- memory budget
def test_budget_parses_sizes_and_refuses_nonsense(monkeypatch):
    assert _budget.parse("512M") == 512_000_000
    assert _budget.parse("1.5GiB") == 3 << 29
    for bad in ("lots", "0", "-1G", "12 parsecs"):
        with pytest.raises(af.BadValueError, match=_budget.ENV):
            _budget.parse(bad)
    monkeypatch.setenv(_budget.ENV, "64M")
    assert _budget.budget() == 64_000_000


def test_scene_too_big_for_the_budget_is_refused_before_work(tmp_path, capsys):
    planes = "".join(
        f'[[receivers]]\nkind = "plane"\nextent = 3\ncenter = [0, 0, {-0.001 * i}]\n'
        "resolution = 256\n"
        for i in range(400)
    )
    path = tmp_path / "huge.toml"
    path.write_text(SCENE.split("[[receivers]]")[0] + planes)
    _exit2(capsys, "scene", path, fragment="26,214,400 receivers needs about")


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["report", "--plane-px", "100000", "--out", "{tmp}/r"], "--plane-px"),
        (["report", "--sweep-n", "10000000000", "--out", "{tmp}/r"], "--sweep-n"),
        (["gen", "--emitter", "sphere", "--radius", "0.5", "--receivers", "plane", "--samples", "100000",
          "--out", "{tmp}/g.npz"], "fewer receivers"),
    ],
    ids=["plane-px", "sweep-n", "gen-samples"],
)  # fmt: skip
def test_commands_announce_what_they_would_need(tmp_path, capsys, argv, fragment):
    argv = [a.format(tmp=tmp_path) for a in argv]
    _exit2(capsys, *argv, fragment=fragment)
    assert not any(tmp_path.iterdir())


def test_truth_evaluation_is_chunked():
    """Past a chunk, the exact irradiance is evaluated in pieces (flat memory); the values
    agree with the unchunked evaluation to the last bits."""
    from attenfit._truth import _irradiance

    em = af.DiskEmitter([0, 0, 0], [0, 0, -1], 0.5)
    rng = np.random.default_rng(0)
    n = _irradiance._CHUNK + 17
    p = rng.normal(size=(n, 3))
    p[:, 2] = -np.abs(p[:, 2]) - 0.01
    nrm = rng.normal(size=(n, 3))
    whole = np.asarray(af.irradiance(em, p, nrm))
    parts = np.concatenate([np.asarray(af.irradiance(em, p[:40000], nrm[:40000])),
                            np.asarray(af.irradiance(em, p[40000:], nrm[40000:]))])  # fmt: skip
    np.testing.assert_allclose(whole, parts, rtol=1e-9, atol=0)


# ----------------------------------------------------------------------------- exit 2, not 1
def test_spot_whose_cone_holds_no_receiver(tmp_path, capsys):
    path = tmp_path / "spot.toml"
    path.write_text(
        'tolerance = 0.05\n[[lights]]\nkind = "spot"\nradius = 0.05\nheight = 3\numbra = 5\n'
        'penumbra = 3\n[[receivers]]\nkind = "distribution"\ndistance = [1, 3]\n'
        "angle = [40, 80]\nn = 16\n"
    )
    _exit2(capsys, "scene", path, "--out", tmp_path / "o", fragment="inside its cone")


def test_mathtext_in_a_scene_name_is_text(tmp_path, capsys):
    path = tmp_path / "name.toml"
    path.write_text('name = "$x^$ and $\\\\frac{"\n' + SCENE)
    code, err = _cli(capsys, "scene", path, "--out", tmp_path / "o", "--quiet")
    assert code == 0, err
    assert (tmp_path / "o" / "errors.png").stat().st_size > 1000


def test_tiny_and_huge_normals_are_normalised():
    em = af.DiskEmitter([0, 0, 0], [0, 0, -1e-200], 0.5)
    np.testing.assert_array_equal(np.asarray(em.normal), [0, 0, -1])
    p = np.array([[0.0, 0.0, -1.0]] * 3)
    n = np.array([[0, 0, 1e-200], [0, 0, 1.0], [0, 0, 1e300]])
    E = np.asarray(af.irradiance(em, p, n))
    assert np.all(np.isfinite(E)) and E[0] == E[1] == E[2] > 0


def test_plane_with_a_tiny_normal_in_a_scene(tmp_path):
    scene = Scene.from_dict(
        {
            "tolerance": 0.05,
            "lights": [{"kind": "sphere", "radius": 0.1, "height": 2}],
            "receivers": [
                {"kind": "plane", "extent": 1, "resolution": 3, "normal": [0, 0, 1e-200]}
            ],
        }
    )
    (truth,) = scene.ground_truth()
    assert np.all(np.isfinite(truth.dataset.E)) and np.all(truth.dataset.E > 0)


@pytest.mark.parametrize(
    "E, fragment",
    [(np.zeros(8), "nothing to judge"), (-np.ones(8), "E must be >= 0"), (np.zeros(0), "")],
    ids=["zero", "negative", "empty"],
)
def test_report_refuses_a_dataset_it_cannot_judge_up_front(tmp_path, capsys, E, fragment):
    n = len(E)
    p = np.column_stack([np.zeros(n), np.zeros(n), -np.linspace(1, 2, n)])
    try:
        ds = af.Dataset(af.SphereEmitter([0, 0, 0], 0.5), p, np.tile([0, 0, 1.0], (n, 1)), E, 0.0)
    except af.BadValueError as exc:  # refused where it is made
        assert fragment in str(exc)
        return
    ds.save(tmp_path / "w.npz")
    _exit2(capsys, "report", "--mitsuba", tmp_path / "w.npz", "--out", tmp_path / "r",
           fragment=fragment or "nothing to judge")  # fmt: skip
    assert not (tmp_path / "r").exists()


@pytest.mark.parametrize(
    "fit, fragment",
    [
        ({"family": "spline", "params": {"knot_values": [1, [2, 3]]}}, "list of numbers"),
        ({"family": "yuksel", "params": {"r": [[0.1], [0.2, 0.3]]}}, "list of numbers"),
        ({"family": "yuksel", "params": {"r": 0.1}, "metrics": {"m": [1, [2, "x\ny"]]}}, None),
    ],
    ids=["ragged-knots", "ragged-param", "ragged-metric"],
)
def test_ragged_fit_files(tmp_path, capsys, fit, fragment):
    path = tmp_path / "fits.json"
    path.write_text(json.dumps(fit))
    if fragment is None:
        code, err = _cli(capsys, "export", path, "--lang", "c")
        assert code == 0, err
    else:
        _exit2(capsys, "export", path, fragment=fragment)


def test_spline_knots_must_keep_their_length(capsys):
    _exit2(capsys, "export", "spline", "--param", "knot_values=1", fragment="must have shape (6,)")


def test_file_names_that_are_not_utf8(tmp_path, capsys):
    folder = os.fsencode(tmp_path) + b"/n\xffu"
    os.mkdir(folder)
    with open(folder + b"/s.toml", "w") as fh:
        fh.write("tolerance = [")
    code, err = _cli(capsys, "scene", os.fsdecode(folder + b"/s.toml"))
    assert code == 2 and "TOML syntax error" in err, err
    code, err = _cli(capsys, "export", "yuksel", "--out", os.fsdecode(folder + b"/y.glsl"))
    assert code == 0, err


def test_report_into_an_unwritable_place_is_refused_before_work(tmp_path, capsys):
    target = tmp_path / "file" / "a" / "b"
    (tmp_path / "file").write_text("x")
    _exit2(capsys, "report", "--out", target, fragment="which is a file")


def test_internal_error_is_a_bug_report(monkeypatch, capsys):
    from attenfit._cli import _cmd_families as _families

    def boom(args):
        raise ZeroDivisionError("deliberately")

    monkeypatch.setattr(_families, "_run_families", boom)  # read when the parser is made
    code, err = _cli(capsys, "families")
    assert code == 1
    assert "internal error (a bug in attenfit" in err and "ATTENFIT_TRACEBACK=1" in err
    monkeypatch.setenv("ATTENFIT_TRACEBACK", "1")
    code, err = _cli(capsys, "families")
    assert code == 1 and "Traceback" in err and "ZeroDivisionError: deliberately" in err


# ----------------------------------------------------------------------------- silent wrongs
WINDOWED = [n for n in af.list_families() if af.get_family(n).range_param]


@pytest.mark.parametrize("name", WINDOWED)
def test_an_infinite_range_is_refused_with_the_way_out(name):
    cls = af.get_family(name)
    with pytest.raises(af.BadValueError, match=r"must be finite.*without a window"):
        cls(**{cls.range_param: float("inf")})


@pytest.mark.parametrize(
    "target, weights, fragment",
    [
        (np.full(50, 1e308), None, "target values must lie within"),
        (None, np.full(50, 1e-160), "weights must lie within"),
        (np.full(50, 1e-310), None, "target values must lie within"),
    ],
    ids=["target-1e308", "weights-1e-160", "target-1e-310"],
)
def test_a_fit_that_cannot_be_judged_is_refused(target, weights, fragment):
    d = np.linspace(1, 10, 50)
    target = 1 / d**2 if target is None else target
    with pytest.raises(af.BadValueError, match=fragment):
        af.fit(af.Polynomial(), d, target, weights=weights)


def test_receivers_too_far_to_judge(tmp_path, capsys):
    path = tmp_path / "far.toml"
    path.write_text(
        'tolerance = 0.05\n[[lights]]\nkind = "sphere"\nradius = 0.1\nheight = 2\n'
        '[[receivers]]\nkind = "distribution"\ndistance = [0.2, 1e300]\nn = 64\n'
    )
    _exit2(capsys, "scene", path, fragment="beyond the 1e+12 radii")


@pytest.mark.parametrize(
    "param, fragment",
    [("r=1e-50", "rounds to 0 in float32"), ("r=1e40", "is not a finite float32")],
)
@pytest.mark.parametrize("form", ["shader", "stable"])
def test_parameters_a_float32_shader_cannot_hold(capsys, param, fragment, form):
    _exit2(capsys, "export", "yuksel", "--form", form, "--param", param, fragment=fragment)


def test_a_rival_output_that_appears_meanwhile_is_not_replaced(tmp_path):
    out = tmp_path / "report"
    with pytest.raises(af.OutputExistsError, match=r"exists and is not empty|appeared"):
        with _atomic.atomic_dir(out) as tmp:
            (tmp / "mine.md").write_text("mine")
            out.mkdir()  # a second run committed first
            (out / "theirs.md").write_text("theirs")
    assert [p.name for p in out.iterdir()] == ["theirs.md"]
    assert [p.name for p in tmp_path.iterdir()] == ["report"]  # no temporary left
    target = tmp_path / "file.txt"

    def rival(path):
        target.write_text("theirs")
        path.write_text("mine")

    with pytest.raises(af.OutputExistsError, match="appeared while writing"):
        _atomic.atomic_write(target, rival)
    assert target.read_text() == "theirs"


def test_force_through_a_symlinked_folder_keeps_the_link(tmp_path):
    real = tmp_path / "real"
    real.mkdir()
    (real / "old.md").write_text("old")
    link = tmp_path / "link"
    link.symlink_to(real)
    for i in range(3):
        with _atomic.atomic_dir(link, force=True) as tmp:
            (tmp / "new.md").write_text(str(i))
        assert link.is_symlink() and (link / "new.md").read_text() == str(i)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real"]


def test_an_output_may_not_replace_an_input(tmp_path, capsys):
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"family": "yuksel", "params": {"r": 0.2}}))
    before = fit.read_text()
    _exit2(capsys, "export", fit, "--out", fit, "--force", fragment="is an input of this command")
    assert fit.read_text() == before
    ds = af.random_receivers(af.SphereEmitter([0, 0, 0], 0.5), 16, 1.0, 4.0, seed=1)
    (tmp_path / "data").mkdir()
    ds.save(tmp_path / "data" / "w.npz")
    _exit2(capsys, "report", "--mitsuba", tmp_path / "data" / "w.npz", "--out", tmp_path / "data",
           "--force", fragment="holds an input of this command")  # fmt: skip
    assert (tmp_path / "data" / "w.npz").exists()
    with _input.tracking():  # outside a command (a notebook) nothing is tracked for long
        assert _input.inputs() == frozenset()
    assert _input.inputs() == frozenset()


@pytest.mark.slow
def test_a_builder_needs_no_more_memory_than_it_announces():
    """Measured in a fresh process: the peak of 300,000 receivers above the resident memory
    before them (after a small warm-up call). Slow, and not in CI: run standalone it measures
    0.36 GB (estimate 0.61 GB), but inside a full test run a child once peaked 2.7 GB above
    its baseline, not yet explained (docs/errors.md)."""
    sys.path.insert(0, str(REPO))
    from benchmarks.bench_memory import estimate, measure

    m = measure("builder", 300_000)
    assert 0 < m["peak"] - m["base"] <= estimate("builder", 300_000), m
