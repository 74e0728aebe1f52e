"""Robustness III: the cache as untrusted input, the environment, and the command line's last
internal errors (an attacker's round).

* **The cache** (`attenfit/_cache.py`): whatever sits where an entry belongs (a FIFO, a link
  to /dev/zero, a folder, a huge file, a checksum-valid entry of the wrong shape, a linked
  folder leading out of the cache) is ignored with one notice and rebuilt; `attenfit
  families` exits 0 whatever the cache holds.
* **The environment**: `ATTENFIT_MEMORY_BUDGET` beyond any integer, an ASCII locale with a
  non-ASCII file name.
* **The command line**: a negative seed, names over NAME_MAX or PATH_MAX, 100 kB arguments,
  names that are not UTF-8, a `--mitsuba` dataset whose grid is malformed, and errors the
  file system raises: each a one-line exit 2 naming the value.

Where the failure would be a hang, the command runs in a subprocess with a timeout (only to
catch the hang); the rest run in-process (`attenfit.cli.main`).
"""

from __future__ import annotations

import errno
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from _stderr import without_progress

import attenfit as af
from attenfit import _cache
from attenfit.cli import MAX_ARGUMENT, main

REPO = Path(__file__).resolve().parent.parent


def _cli(capsys, *argv) -> tuple[int, str, str]:
    code = main([str(a) if isinstance(a, Path) else a for a in argv])
    out = capsys.readouterr()
    return code, out.out, without_progress(out.err.strip())


def _exit2(capsys, *argv, fragment: str) -> str:
    code, _, err = _cli(capsys, *argv)
    assert code == 2, err
    assert "\n" not in err and "Traceback" not in err and "internal error" not in err, err
    assert fragment in err, err
    return err


# ----------------------------------------------------------------------------- the cache
@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(folder))
    return folder


def _families_entry() -> Path:
    return _cache._entry("families", "describe")


def _entry_bytes(payload: bytes) -> bytes:
    """An entry with a valid header and checksum around `payload`."""
    return _cache._MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload


def _families_subprocess(cache_dir: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(cache_dir), "PYTHONPATH": str(REPO)}
    return subprocess.run(
        [sys.executable, "-m", "attenfit", "families"],
        capture_output=True,
        text=True,
        timeout=300,  # catches a hang only
        env=env,
    )


def _assert_rebuilt(entry: Path) -> None:
    assert entry.is_file() and not entry.is_symlink()
    assert _cache.read("families", "describe") is not None  # a good entry again


def test_a_fifo_entry_is_ignored_not_waited_on(cache_dir):
    entry = _families_entry()
    entry.parent.mkdir(parents=True)
    os.mkfifo(entry)
    proc = _families_subprocess(cache_dir)
    assert proc.returncode == 0, proc.stderr
    assert "inverse_square" in proc.stdout
    assert proc.stderr.count("\n") == 1 and "is not a regular file" in proc.stderr
    _assert_rebuilt(entry)


def test_an_entry_linked_to_dev_zero_is_ignored_not_read(cache_dir):
    entry = _families_entry()
    entry.parent.mkdir(parents=True)
    entry.symlink_to("/dev/zero")
    proc = _families_subprocess(cache_dir)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr.count("\n") == 1 and "is a symbolic link" in proc.stderr
    _assert_rebuilt(entry)
    assert Path("/dev/zero").exists()  # the link was replaced, not written through


@pytest.mark.parametrize(
    "payload, fragment",
    [
        (b"[1, 2]", "no listing of families and area models"),
        (b"{}", "no listing of families and area models"),
        (b'{"families": [], "area_models": []}', "no list of families"),
        (b'{"families": [1, 2], "area_models": []}', "a model that is not a JSON object"),
        (
            b'{"families": [{"name": "x", "formula": 1, "source": "s", "params": {}}], '
            b'"area_models": []}',
            "'formula' is not text",
        ),
        (
            b'{"families": [{"name": "x", "formula": "f", "source": "s"}], "area_models": []}',
            "without a 'params' object",
        ),
        (
            b'{"families": [], "area_models": [{"name": "x", "formula": "f", "source": "s", '
            b'"params": {"r": {"default": [[1]]}}}]}',
            "no list of families",
        ),
        (
            b'{"families": [{"name": "x", "formula": "f", "source": "s", '
            b'"params": {"r": {"default": [[1]]}}}], "area_models": []}',
            "parameter 'r' without a numeric default",
        ),
        (b"[" * 100_000 + b"]" * 100_000, "no valid JSON"),
        (b"\xff\xfe not text", "no valid JSON"),
    ],
    ids=[
        "list",
        "object",
        "empty",
        "ints",
        "formula",
        "params",
        "no-families",
        "nested-default",
        "deep",
        "bytes",
    ],
)
def test_a_checksum_valid_entry_of_the_wrong_shape_is_rebuilt(cache_dir, capsys, payload, fragment):
    entry = _families_entry()
    entry.parent.mkdir(parents=True)
    entry.write_bytes(_entry_bytes(payload))
    code, out, err = _cli(capsys, "families")
    assert code == 0, err
    assert "inverse_square" in out and "f(d)   = 1/d^2" in out
    assert err.count("\n") == 0 and "ignoring a cache entry that holds" in err
    assert fragment in err, err
    _assert_rebuilt(entry)
    assert main(["families", "--json"]) == 0  # and the rebuilt one serves
    rows = json.loads(capsys.readouterr().out)
    assert [r["name"] for r in rows["families"]] == af.list_families()
    assert [r["name"] for r in rows["area_models"]] == af.list_area_models()


def test_an_oversized_entry_is_refused_before_reading(cache_dir, capsys):
    entry = _families_entry()
    entry.parent.mkdir(parents=True)
    with open(entry, "wb") as fh:  # sparse: 2 GiB that take no disk
        fh.write(_entry_bytes(b"[]"))
        fh.truncate(2 << 30)
    code, _, err = _cli(capsys, "families")
    assert code == 0 and "over the 1,048,576 an entry of its kind may be" in err, err
    assert entry.stat().st_size < 1 << 20  # rebuilt


def test_a_folder_where_an_entry_belongs(cache_dir, capsys):
    entry = _families_entry()
    (entry / "inside").mkdir(parents=True)
    code, _, err = _cli(capsys, "families")
    assert code == 0 and "is not a regular file" in err, err
    _assert_rebuilt(entry)


def test_a_linked_folder_leading_out_of_the_cache(cache_dir, tmp_path, capsys):
    """A valid entry reached through a link to a folder outside the cache is not read; the
    link is replaced by a folder of the cache's own, and the outside is left alone."""
    entry = _families_entry()
    outside = tmp_path / "outside"
    outside.mkdir()
    rows = [{"name": "planted", "formula": "0", "source": "?", "params": {}}]
    (outside / entry.name).write_bytes(_entry_bytes(json.dumps(rows).encode()))
    entry.parent.parent.mkdir(parents=True)
    entry.parent.symlink_to(outside)
    code, out, err = _cli(capsys, "families")
    assert code == 0 and "planted" not in out and "inverse_square" in out
    assert "lies outside the cache folder" in err, err
    assert entry.parent.is_dir() and not entry.parent.is_symlink()
    assert [p.name for p in outside.iterdir()] == [entry.name]  # untouched
    _assert_rebuilt(entry)


@pytest.mark.parametrize(
    "kind, payload",
    [
        ("compiled", b'{"tool": "t", "total": "6", "classes": {}}'),
        ("compiled", b'{"tool": "t", "total": 6, "classes": [1]}'),
        ("compiled", b'{"total": 6, "classes": {}}'),
        ("compilers", b'{"ptxas": 12}'),
        ("compilers", b"[null]"),
    ],
)
def test_the_other_json_kinds_are_checked_in_shape(cache_dir, capsys, kind, payload):
    assert _cache.write(kind, "k", payload)
    assert _cache.read(kind, "k") is None
    assert "ignoring a cache entry that holds" in capsys.readouterr().err
    good = (
        b'{"tool": "t", "total": 6, "classes": {"arithmetic": 6}}'
        if kind == "compiled"
        else b'{"ptxas": "V12", "nvrtc": null}'
    )
    assert _cache.write(kind, "k", good) and _cache.read(kind, "k") == good


@pytest.mark.parametrize("where", ["under-a-file", "dev-null"])
def test_families_never_fails_because_of_the_cache_folder(tmp_path, monkeypatch, capsys, where):
    blocker = tmp_path / "a-file"
    blocker.write_text("x")
    folder = blocker / "cache" if where == "under-a-file" else Path("/dev/null/cache")
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(folder))
    code, out, err = _cli(capsys, "families")
    assert code == 0 and "inverse_square" in out and err == ""


def test_cache_clear_removes_a_link_never_what_it_points_to(cache_dir, tmp_path, capsys):
    keep = tmp_path / "precious"
    keep.mkdir()
    (keep / "file.bin").write_bytes(b"x" * 1000)
    cache_dir.mkdir()
    (cache_dir / "entries").symlink_to(keep)
    (cache_dir / "jax").mkdir()
    (cache_dir / "jax" / "a").write_bytes(b"y" * 10)
    code, out, _ = _cli(capsys, "cache", "--info")
    assert code == 0 and "no entries for this version yet" in out
    code, out, _ = _cli(capsys, "cache", "--clear")
    assert code == 0 and "removed 1 files" in out
    assert (keep / "file.bin").read_bytes() == b"x" * 1000
    assert not os.path.lexists(cache_dir / "entries") and not (cache_dir / "jax").exists()


# ----------------------------------------------------------------------------- environment
@pytest.mark.parametrize("value", ["1e400", "1e308G", "99999999999999999999T"])
def test_a_memory_budget_beyond_any_integer(monkeypatch, capsys, tmp_path, value):
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", value)
    _exit2(
        capsys,
        "truth", "--emitter", "sphere", "--radius", "0.1", "--out", tmp_path / "x.npz",
        fragment=f"ATTENFIT_MEMORY_BUDGET must be below 2^63 bytes (9.2 EB), got {value!r}",
    )  # fmt: skip


def test_a_long_memory_budget_is_named_short(monkeypatch, capsys, tmp_path):
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", "x" * 100_000)
    err = _exit2(
        capsys, "truth", "--emitter", "sphere", "--radius", "0.1", "--out", tmp_path / "x.npz",
        fragment="(100,000 characters)",
    )  # fmt: skip
    assert len(err) < 300


ASCII = {"LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}


def _ascii_run(args: list[str], cwd: Path, **extra: str) -> subprocess.CompletedProcess:
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONIOENCODING", "LC_CTYPE")}
    env.update(ASCII, PYTHONPATH=str(REPO))
    env.update(extra)
    return subprocess.run(
        [sys.executable, "-m", "attenfit", *args],
        capture_output=True,
        text=True,
        errors="replace",
        timeout=600,  # catches a hang only
        cwd=cwd,
        env=env,
    )


def test_an_ascii_locale_with_non_ascii_names(tmp_path):
    """Under LC_ALL=C (PYTHONUTF8=0, no locale coercion) Python reads `tü.npz` from argv as
    't\\udcc3\\udcbc.npz'; fit writes its name into fits.json as the UTF-8 text it is."""
    ds = af.facing_sweep(af.SphereEmitter([0, 0, 0], 0.1), 0.2, 5.0, n=32)
    ds.save(tmp_path / "tü.npz")
    proc = _ascii_run(["fit", "--family", "yuksel", "--data", "tü.npz", "--out", "fü"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    rows = json.loads((tmp_path / "fü" / "fits.json").read_text(encoding="utf-8"))
    assert rows[0]["configuration"] == "dataset tü.npz"
    scene = tmp_path / "lümen.toml"
    scene.write_text(
        'tolerance = 0.05\n[constraints]\nfamilies = ["inverse_square"]\n[[lights]]\n'
        'kind = "sphere"\nradius = 0.1\nheight = 2\n[[receivers]]\nkind = "plane"\n'
        "extent = 1\nresolution = 4\n"
    )
    # the scene's answer quotes its file's name: printed (escaped), or refused up front
    # when it would go into --out's UTF-8 files
    proc = _ascii_run(["scene", "lümen.toml"], tmp_path)
    assert proc.returncode == 0, proc.stderr
    assert "recommended" in proc.stderr
    proc = _ascii_run(["scene", "lümen.toml", "--out", "dü"], tmp_path)
    assert proc.returncode == 2 and proc.stderr.count("\n") == 1, proc.stderr
    assert "the name 'l\\udcc3\\udcbcmen.toml' is not UTF-8 text here" in proc.stderr
    assert "PYTHONUTF8=1" in proc.stderr and not (tmp_path / "dü").exists()
    proc = _ascii_run(["scene", "lümen.toml", "--out", "dü"], tmp_path, PYTHONUTF8="1")
    assert proc.returncode == 0, proc.stderr  # the way out it names
    assert "lümen.toml" in (tmp_path / "dü" / "recommendation.md").read_text(encoding="utf-8")


def test_a_name_that_cannot_be_written_as_utf8_is_one_line(monkeypatch, capsys, tmp_path):
    """Where a name Python read under an ASCII locale ('k\\udcc3\\udcbcche.toml') would go
    into a UTF-8 file, the command says so in one line (exit 2), whichever verb does it."""
    from attenfit._cli import _cmd_families

    name = b"k\xc3\xbcche.toml".decode("ascii", "surrogateescape")

    def write_name(args):
        (tmp_path / "out.md").write_text(f"answer for `{name}`", encoding="utf-8")
        return 0

    monkeypatch.setattr(_cmd_families, "_run_families", write_name)
    code, _, err = _cli(capsys, "families")
    assert code == 2 and "\n" not in err, err
    assert "is not UTF-8 text here" in err and "PYTHONUTF8=1" in err
    assert "'k\\udcc3\\udcbcche.toml'" in err.encode("ascii", "backslashreplace").decode()


@pytest.mark.parametrize(
    "exc",
    [
        OSError(errno.ENOSPC, "No space left on device", "/full/disk/out.npz"),
        OSError(errno.EROFS, "Read-only file system", "/ro/out.npz"),
        OSError(errno.ENAMETOOLONG, "File name too long", "n" * 300),
    ],
    ids=["ENOSPC", "EROFS", "ENAMETOOLONG"],
)
def test_a_file_system_refusal_is_one_line_not_a_bug(monkeypatch, capsys, exc):
    from attenfit._cli import _cmd_families

    def refuse(args):
        raise exc

    monkeypatch.setattr(_cmd_families, "_run_families", refuse)
    err = _exit2(capsys, "families", fragment=exc.strerror)
    assert repr(exc.filename)[:20] in err


def test_an_oserror_without_a_file_name_is_still_a_bug(monkeypatch, capsys):
    from attenfit._cli import _cmd_families

    def boom(args):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(_cmd_families, "_run_families", boom)
    code, _, err = _cli(capsys, "families")
    assert code == 1 and "internal error" in err


# ----------------------------------------------------------------------------- command line
@pytest.mark.parametrize("receivers", ["random", "facing", "plane"])
def test_truth_with_a_negative_seed(capsys, tmp_path, receivers):
    _exit2(
        capsys,
        "truth", "--emitter", "sphere", "--radius", "0.1", "--receivers", receivers,
        "--seed", "-1", "--out", tmp_path / "x.npz",
        fragment="--seed must be a non-negative integer, got -1",
    )  # fmt: skip
    assert not (tmp_path / "x.npz").exists()


LONG = "a" * 300


@pytest.mark.parametrize(
    "argv, fragment",
    [
        (["truth", "--emitter", "sphere", "--radius", "0.1", "--out", f"{LONG}.npz"], "--out"),
        (
            ["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "1", "--out", LONG],
            "--out",
        ),
        (["report", "--out", LONG], "--out"),
        (["export", "yuksel", "--out", f"{LONG}.glsl"], "--out"),
        (["fit", "--family", "yuksel", "--data", f"{LONG}.npz"], "--data"),
        (["report", "--mitsuba", f"{LONG}.npz"], "--mitsuba"),
        (["scene", f"{LONG}.toml"], "FILE"),
        (["scene", "room.glb", "--write-back", f"{LONG}.gltf"], "--write-back"),
    ],
    ids=["truth", "fit", "report", "export", "fit-data", "report-mitsuba", "scene", "write-back"],
)
def test_names_over_name_max(capsys, tmp_path, monkeypatch, argv, fragment):
    monkeypatch.chdir(tmp_path)
    _exit2(capsys, *argv, fragment=f"{fragment} 'aaaa")
    assert sorted(os.listdir(tmp_path)) == []


def test_an_output_name_just_under_the_limit_is_written(capsys, tmp_path):
    """The limit leaves room for the temporary name (`.NAME.XXXXXXXX.attenfit-tmp.npz`)."""
    name = "a" * (255 - 24 - 4 - 4) + ".npz"  # NAME_MAX, less the room, less ".npz" twice
    code, _, err = _cli(
        capsys, "truth", "--emitter", "sphere", "--radius", "0.1", "--samples", "4", "--out",
        tmp_path / name,
    )  # fmt: skip
    assert code == 0, err
    _exit2(
        capsys, "truth", "--emitter", "sphere", "--radius", "0.1", "--out",
        tmp_path / ("b" + name), fragment="over the 227 a name may have here",
    )  # fmt: skip


def test_a_path_over_path_max(capsys, tmp_path):
    deep = "/".join(["é" * 100] * 25) + "/x.npz"  # 2,500 characters, 5,000 bytes
    _exit2(
        capsys, "truth", "--emitter", "sphere", "--radius", "0.1", "--out", deep,
        fragment="over the 4,095 the file system allows (PATH_MAX)",
    )  # fmt: skip


@pytest.mark.parametrize(
    "argv",
    [
        ["export", "yuksel", "--name", "n" * 100_000],
        ["export", "yuksel", "--param", "r=" + "1" * 100_000],
        ["export", "yuksel", "--param", "r" * 100_000 + "=1"],
        ["export", "x" * 100_000],
        ["families", "--json", "y" * 100_000],
        ["scene", "s" * 100_000 + ".toml"],
        ["fit", "--family", ",".join(["yuksel"] * 20_000), "--emitter", "disk"],
    ],
    ids=["export-name", "param-value", "param-name", "export-source", "families", "scene", "fit"],
)
def test_a_100_kb_argument_to_any_verb(capsys, argv):
    long = max(argv, key=len)
    err = _exit2(capsys, *argv, fragment=f"characters long (starting '{long[:8]}")
    assert f"attenfit takes at most {MAX_ARGUMENT:,}" in err and len(err) < 300


def test_an_argument_at_the_limit_is_parsed(capsys):
    code, out, err = _cli(capsys, "export", "yuksel", "--name", "n" * MAX_ARGUMENT)
    assert code == 0, err
    assert "n" * MAX_ARGUMENT in out


def test_fit_with_names_that_are_not_utf8(capsys, tmp_path):
    """Surrogate-escaped bytes in argv (b"\\xff"): a missing --data is named; an existing one
    is read and named in fits.json as text (`\\xff`), the --out folder made with its bytes."""
    raw = os.fsencode(tmp_path)
    data = os.fsdecode(raw + b"/d\xffta.npz")
    out = os.fsdecode(raw + b"/\xfeout")
    err = _exit2(
        capsys, "fit", "--family", "yuksel", "--data", data, "--out", out,
        fragment="does not exist",
    )  # fmt: skip
    assert "d\\udcffta.npz" in err.encode("ascii", "backslashreplace").decode()
    af.facing_sweep(af.SphereEmitter([0, 0, 0], 0.1), 0.2, 5.0, n=32).save(data)
    code, _, err = _cli(capsys, "fit", "--family", "yuksel", "--data", data, "--out", out)
    assert code == 0, err
    fits = json.loads(Path(out, "fits.json").read_text(encoding="utf-8"))
    assert fits[0]["configuration"] == f"dataset {tmp_path}/d\\xffta.npz"
    assert os.path.isdir(raw + b"/\xfeout")


# ----------------------------------------------------------------------------- report --mitsuba
def _grid_dataset(path: Path, **changes) -> Path:
    ds = af.plane_receivers(af.SphereEmitter([0, 0, 0], 0.1), 0.2, 1.0, n=8)
    prov = {**ds.provenance, **changes}
    af.Dataset(ds.emitter, ds.points, ds.normals, ds.E, ds.stderr, provenance=prov).save(path)
    return path


N = 64  # receivers of the 8 x 8 grid (the sphere is above the plane: none dropped)


@pytest.mark.parametrize(
    "changes, fragment",
    [
        ({"shape": 5}, "'shape' must be a list of positive integers, got 5"),
        ({"shape": ["a", "b"]}, "'shape' must be a list of positive integers"),
        ({"shape": [-8, -8]}, "'shape' must be a list of positive integers, got [-8, -8]"),
        ({"shape": [8.5, 8]}, "'shape' must be a list of positive integers, got [8.5, 8]"),
        ({"shape": [[8], [8]]}, "'shape' must be a list of positive integers"),
        ({"shape": [10**9, 10**9]}, "over the budget"),
        ({"grid_index": [10**6] * N}, "'grid_index' must lie in [0, 64) for a [8, 8] grid, got 1000000"),
        ({"grid_index": [-5] * N}, "'grid_index' must lie in [0, 64)"),
        ({"grid_index": ["x"] * N}, "'grid_index' must hold integers, got 'x'"),
        ({"grid_index": [0.5] * N}, "'grid_index' must hold integers, got 0.5"),
        ({"grid_index": [0] * N}, "'grid_index' must name each grid cell once, got 0"),
        ({"grid_index": [0]}, "'grid_index' must list the grid cell of each of its 64 receivers"),
        ({"grid_index": 3}, "'grid_index' must list the grid cell"),
        ({"up": "x"}, "'up' must be 3 finite numbers, not all 0, got 'x'"),
        ({"up": [0, 1]}, "'up' must be 3 finite numbers"),
        ({"x_axis": [1, "a", 0]}, "'x_axis' must be 3 finite numbers"),
        ({"y_axis": [0, 0, 0]}, "'y_axis' must be 3 finite numbers, not all 0"),
        ({"extent": "wide"}, "'extent' must be a finite number > 0, got 'wide'"),
        ({"extent": float("inf")}, "'extent' must be a finite number > 0, got inf"),
        ({"spp": 4}, "gives 'spp' without 'variant'"),
    ],
)  # fmt: skip
def test_report_mitsuba_with_a_malformed_grid(capsys, tmp_path, changes, fragment):
    path = _grid_dataset(tmp_path / "bad.npz", **changes)
    _exit2(
        capsys, "report", "--mitsuba", path, "--no-mitsuba", "--no-fit", "--out", tmp_path / "r",
        fragment=fragment,
    )  # fmt: skip
    assert not (tmp_path / "r").exists()
    _exit2(
        capsys, "report", "--mitsuba", path, "--no-mitsuba", "--no-fit", "--out", tmp_path / "r",
        fragment=f"--mitsuba {str(path)!r}" if "budget" not in fragment else "grid of --mitsuba",
    )  # fmt: skip


def test_report_mitsuba_with_a_good_grid_passes_the_check(tmp_path):
    from attenfit._cli._cmd_report import _check_grid

    path = _grid_dataset(tmp_path / "good.npz")
    ds = af.Dataset.load(path)
    _check_grid(str(path), ds)  # no error
    assert ds.provenance["shape"] == [8, 8] and len(ds.provenance["grid_index"]) == N
    no_index = {k: v for k, v in ds.provenance.items() if k != "grid_index"}
    ds2 = af.Dataset(ds.emitter, ds.points, ds.normals, ds.E, ds.stderr, provenance=no_index)
    _check_grid(str(path), ds2)  # every cell a receiver: the index may be left out
    assert np.asarray(ds2.E).size == N


# ----------------------------------------------------------------------------- --force
@pytest.mark.parametrize(
    "argv, folder",
    [
        (["truth", "--emitter", "sphere", "--radius", "0.1", "--samples", "8"], False),
        (["export", "yuksel", "--lang", "glsl"], False),
        (["fit", "--family", "yuksel", "--emitter", "sphere", "--radius", "0.1"], True),
        (["report", "--no-mitsuba"], True),
    ],
    ids=["truth", "export", "fit", "report"],
)
def test_force_replaces_only_attenfits_own_outputs(tmp_path, capsys, argv, folder):
    """A user's file or folder at --out is refused even with --force, before any work, and
    left as it was."""
    target = tmp_path / ("mine" if folder else "mine.npz" if argv[0] == "truth" else "mine.glsl")
    if folder:
        target.mkdir()
        (target / "notes.txt").write_text("my notes")
    else:
        target.write_text("my own file")
    err = _exit2(capsys, *argv, "--out", str(target), "--force", fragment="not written by attenfit")
    assert "--force replaces only attenfit's own outputs" in err
    kept = target / "notes.txt" if folder else target
    assert kept.read_text() == ("my notes" if folder else "my own file")


def test_force_replaces_attenfits_own_outputs(tmp_path, capsys):
    for argv, name in (
        (["truth", "--emitter", "sphere", "--radius", "0.1", "--samples", "8"], "d.npz"),
        (["export", "yuksel", "--lang", "glsl"], "f.glsl"),
    ):
        out = tmp_path / name
        assert main([*argv, "--out", str(out)]) == 0
        first = out.read_bytes()
        assert main([*argv, "--out", str(out), "--force"]) == 0, capsys.readouterr().err
        assert out.read_bytes() == first  # replaced by the same answer
