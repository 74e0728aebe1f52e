"""What a long command says while it works, and the cache that makes the next run quick.

Progress: stage lines and bars on a terminal only; one summary line otherwise; nothing with
--quiet; every progress point also stops the command when an interrupt was swallowed. The
cache (`attenfit._cache`, `attenfit cache`): a second process loads a solve instead of
tracing it; an entry of another code version is never read; a corrupt entry is ignored with
one notice and rebuilt; a read-only cache is only read.
"""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from attenfit import _atomic, _cache, _progress
from attenfit.cli import main

REPO = Path(__file__).resolve().parents[1]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


# ----------------------------------------------------------------------------- progress
def test_a_terminal_gets_stage_lines_bars_and_the_summary():
    out = _Terminal()
    p = _progress.Progress("attenfit test", stream=out)
    with _progress.active(p):
        _progress.stage("first stage")
        with _progress.count(3, "three things") as bar:
            for _ in range(3):
                bar.update()
            _progress.note("compiling, first run only")
        _progress.done("did it")
    text = out.getvalue()
    assert "attenfit test: [  0.0 s] first stage" in text
    assert "attenfit test: [  0.0 s] three things" in text
    assert "3/3" in text and "compiling, first run only" in text  # tqdm's bar and its note
    assert text.rstrip().endswith(")") and "attenfit test: did it (" in text


def test_a_log_gets_the_summary_only_and_quiet_gets_nothing():
    for quiet, expected in ((False, 1), (True, 0)):
        out = io.StringIO()  # not a terminal
        with _progress.active(_progress.Progress("attenfit test", quiet=quiet, stream=out)):
            _progress.stage("a stage")
            with _progress.count(2, "two things") as bar:
                bar.update(2)
            _progress.done("summary")
        assert out.getvalue().count("\n") == expected
        assert ("summary" in out.getvalue()) == (not quiet)


def test_without_a_command_the_stages_say_nothing(capsys):
    _progress.stage("nobody listens")
    with _progress.count(1, "x") as bar:
        bar.update()
    assert capsys.readouterr() == ("", "")


def test_a_progress_point_raises_a_swallowed_interrupt():
    """An interrupt that Python swallowed (inside a callback) stops the command at its next
    stage or bar update, not only at its next commit."""
    _atomic.PENDING.append(signal.SIGTERM)
    try:
        with _progress.active(_progress.Progress("attenfit test", stream=io.StringIO())):
            with pytest.raises(_atomic.Interrupted):
                _progress.stage("next stage")
            with _progress.count(2, "work") as bar, pytest.raises(_atomic.Interrupted):
                bar.update()
    finally:
        _atomic.PENDING.clear()


def test_cli_quiet_prints_nothing_on_stderr(tmp_path, capsys):
    out = tmp_path / "fits"
    argv = ["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "0.5", "--out", str(out)]
    assert main([*argv, "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and "[[Fit]] yuksel" in captured.out
    assert main([*argv, "--force"]) == 0
    err = capsys.readouterr().err
    assert err.startswith("attenfit fit: 1 fits converged; wrote ") and err.count("\n") == 1


# ----------------------------------------------------------------------------- the cache
@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(folder))
    return folder


def test_entries_round_trip_and_a_corrupt_one_is_ignored_with_one_notice(cache_dir, capsys):
    assert _cache.read("test", "k") is None
    assert _cache.write("test", "k", b"payload")
    assert _cache.read("test", "k") == b"payload"
    (entry,) = (cache_dir / "entries").rglob("*.bin")
    entry.write_bytes(entry.read_bytes()[:-3])  # truncated
    assert _cache.read("test", "k") is None
    assert _cache.read("test", "k") is None
    err = capsys.readouterr().err
    assert err.count("ignoring a corrupt cache entry") == 1 and err.count("\n") == 1
    entry.write_bytes(b"not a cache entry at all")
    assert _cache.read("test", "k") is None
    assert _cache.write("test", "k", b"rebuilt") and _cache.read("test", "k") == b"rebuilt"


def test_entries_of_another_code_version_are_never_read(cache_dir, monkeypatch):
    assert _cache.write("test", "k", b"from this version")
    monkeypatch.setattr(_cache, "code_version", lambda: "another-attenfit-or-jaxlib")
    assert _cache.read("test", "k") is None
    info = _cache.info()
    assert info["entries"] == {} and len(info["stale_versions"]) == 1


def test_a_read_only_cache_is_only_read(cache_dir, monkeypatch):
    """Writes that fail (EROFS, EACCES; root ignores file modes, so the failure is the OS's
    answer, simulated) are skipped without a word; what is there is still read."""
    assert _cache.write("test", "k", b"kept")

    def refuse(*args, **kwargs):
        raise PermissionError(30, "Read-only file system")

    monkeypatch.setattr(_cache.tempfile, "mkstemp", refuse)
    assert _cache.write("test", "other", b"x") is False
    assert _cache.read("test", "k") == b"kept"


def test_a_cache_that_cannot_be_made_does_not_stop_a_command(tmp_path, monkeypatch, capsys):
    blocker = tmp_path / "a-file"
    blocker.write_text("the cache folder would be under this file")
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(blocker / "cache"))
    assert _cache.write("test", "k", b"x") is False and _cache.read("test", "k") is None
    argv = ["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "0.5", "--quiet"]
    assert main(argv) == 0
    assert capsys.readouterr().err == ""


_FIT = r"""
import sys, time, numpy as np, jax
jax.config.update("jax_enable_x64", True)
import attenfit as af
from attenfit._fit import enable_persistent_cache
enable_persistent_cache()
d = np.geomspace(0.01, 10, 64)[None].repeat(4, 0)
t = 1 / (d**2 + np.array([[0.01], [0.02], [0.03], [0.04]]))
res = af.fit_many(af.Yuksel(r=np.full(4, 0.1)), d, t)
print(repr(res.params["r"].tolist()))
"""


def _fit_in_a_fresh_process(cache_dir: Path) -> tuple[list[float], str]:
    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(cache_dir), "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", _FIT], env=env, capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return eval(proc.stdout.strip().splitlines()[-1]), proc.stderr


def test_a_second_process_loads_the_solve_and_gets_the_same_answer(cache_dir):
    first, _ = _fit_in_a_fresh_process(cache_dir)
    entries = list((cache_dir / "entries").rglob("solve/*.bin"))
    assert len(entries) == 1  # the traced solve, kept
    mtime = entries[0].stat().st_mtime_ns
    second, err = _fit_in_a_fresh_process(cache_dir)
    assert second == first and err == ""
    assert entries[0].stat().st_mtime_ns == mtime  # read, not written again
    # a corrupt entry: one notice, the right answer, and the entry rebuilt
    entries[0].write_bytes(entries[0].read_bytes()[:100])
    third, err = _fit_in_a_fresh_process(cache_dir)
    assert third == first
    assert err.count("ignoring a corrupt cache entry") == 1
    assert entries[0].stat().st_size > 100


def test_cli_cache_info_and_clear(cache_dir, capsys):
    assert _cache.write("test", "k", b"1234")
    assert main(["cache", "--info"]) == 0
    out = capsys.readouterr().out
    assert f"folder: {cache_dir}" in out and "test: 1 entries" in out
    assert main(["cache", "--clear"]) == 0
    assert "removed 1 files" in capsys.readouterr().out
    assert not (cache_dir / "entries").exists()
    assert main(["cache"]) == 0 and "no entries for this version yet" in capsys.readouterr().out
