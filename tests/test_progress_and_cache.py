"""What a long command says while it works, and the cache that makes the next run quick.

Progress: stage lines wherever stderr goes; bars on a terminal, paced plain count lines (no
carriage returns) elsewhere; nothing with --quiet; every progress point also stops the command
when an interrupt was swallowed; a piped command's first stage line arrives while it works. The
cache (`attenfit._cache`, `attenfit cache`): a second process loads a solve instead of
tracing it; an entry of another code version is never read; a corrupt entry is ignored with
one notice and rebuilt; a read-only cache is only read.
"""

from __future__ import annotations

import io
import json
import os
import re
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
class _Clock:
    """A clock the test moves (the stage lines' times and the plain lines' pace)."""

    def __init__(self):
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_a_terminal_gets_stage_lines_bars_and_the_summary():
    out, clock = _Terminal(), _Clock()
    p = _progress.Progress("attenfit test", stream=out, clock=clock)
    with _progress.active(p):
        _progress.stage("first stage")
        clock.now += 2.25
        with _progress.count(3, "three things") as bar:
            for _ in range(3):
                bar.update()
            _progress.note("compiling, first run only")
        _progress.done("did it")
    text = out.getvalue()
    assert "attenfit test: [  0.0 s] first stage" in text
    assert "attenfit test: [  2.2 s] three things" in text
    assert "3/3" in text and "compiling, first run only" in text  # tqdm's bar and its note
    assert text.rstrip().endswith(")") and "attenfit test: did it (2.2 s)" in text


def test_a_log_gets_plain_stage_and_count_lines_at_a_pace_and_quiet_gets_nothing():
    """Off a terminal: a line per stage, a count's progress at most once every PLAIN_EVERY
    seconds, each note once, no carriage return; quiet: nothing at all."""
    every = _progress.PLAIN_EVERY
    for quiet in (False, True):
        out, clock = io.StringIO(), _Clock()  # not a terminal
        with _progress.active(
            _progress.Progress("attenfit test", quiet=quiet, stream=out, clock=clock)
        ):
            _progress.stage("a stage")
            with _progress.count(10, "ten things") as bar:
                for _ in range(10):
                    clock.now += every / 2  # a line every second update
                    bar.update()
                    _progress.note("compiling")
            _progress.done("summary")
        text = out.getvalue()
        if quiet:
            assert text == ""
            continue
        assert "\r" not in text
        assert text.splitlines() == [
            "attenfit test: [  0.0 s] a stage",
            "attenfit test: [  0.0 s] ten things",
            f"attenfit test: [{every / 2:5.1f} s] compiling",
            *(f"attenfit test: [{k * every / 2:5.1f} s] ten things: {k}/10" for k in (2, 4, 6, 8)),
            f"attenfit test: summary ({10 * every / 2:.1f} s)",
        ]


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
            with pytest.raises(_atomic.Interrupted):  # a count's start is a stage
                with _progress.count(2, "work"):
                    pass
            _atomic.PENDING.clear()
            with _progress.count(2, "work") as bar:
                _atomic.PENDING.append(signal.SIGTERM)
                with pytest.raises(_atomic.Interrupted):
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
    *stages, summary = capsys.readouterr().err.splitlines()
    # the stage lines, their times aside (a loaded machine takes longer)
    assert [re.sub(r"\[ *\d+\.\d s\]", "[t]", s) for s in stages] == [
        "attenfit fit: [t] the data",
        "attenfit fit: [t] fitting 1 families",
    ]
    assert summary.startswith("attenfit fit: 1 fits converged; wrote ")


_HELD = r"""
import sys
from attenfit._cli import _cmd_fit

read_data = _cmd_fit._fit_configuration


def held(*args, **kwargs):  # the work, held until the test has read the first stage line
    sys.stdin.readline()
    return read_data(*args, **kwargs)


_cmd_fit._fit_configuration = held
from attenfit.cli import main

sys.exit(main(sys.argv[1:]))
"""
_FIT_ARGV = ["fit", "--family", "yuksel", "--emitter", "disk", "--radius", "0.5"]


def test_piped_stage_lines_arrive_while_the_command_works_and_quiet_silences_them(tmp_path):
    """stderr a pipe (a log, CI): the first stage line is there while the command is held in
    the middle of its work, before its result on stdout; plain lines, no carriage returns."""
    import select

    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(tmp_path / "cache"), "PYTHONPATH": str(REPO)}
    proc = subprocess.Popen(
        [sys.executable, "-c", _HELD, *_FIT_ARGV],
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        # a guard against a hang, not a measurement: the line comes at once
        assert select.select([proc.stderr], [], [], 120)[0], "no stage line on the pipe"
        first = proc.stderr.readline()
        assert first.startswith("attenfit fit: [") and first.endswith("] the data\n")
        assert proc.poll() is None  # held in the middle of its work
        assert not select.select([proc.stdout], [], [], 0)[0]  # no result yet
        out, rest = proc.communicate("go\n", timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, rest[-2000:]
    assert "[[Fit]] yuksel" in out
    err = first + rest
    assert "\r" not in err
    assert err.splitlines()[-1].startswith("attenfit fit: 1 fits converged (")
    quiet = subprocess.run(
        [sys.executable, "-m", "attenfit", *_FIT_ARGV, "--quiet"],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert quiet.returncode == 0 and "[[Fit]] yuksel" in quiet.stdout
    assert quiet.stderr == ""


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


_COUNT_COMPILES = r"""
import json, sys, numpy as np, jax

events = {"requests": 0, "hits": 0}
names = {
    "/jax/compilation_cache/compile_requests_use_cache": "requests",
    "/jax/compilation_cache/cache_hits": "hits",
}


def listen(name, **kwargs):
    if name in names:
        events[names[name]] += 1


jax.monitoring.register_event_listener(listen)
jax.config.update("jax_enable_x64", True)
import attenfit as af
from attenfit._fit import enable_persistent_cache

enable_persistent_cache()
d = np.geomspace(0.01, 10, 64)[None].repeat(4, 0)
t = 1 / (d**2 + np.array([[0.01], [0.02], [0.03], [0.04]]))
res = af.fit_many(af.Yuksel(r=np.full(4, 0.1)), d, t)
disk = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.1)
E = af.irradiance(disk, np.array([[0.0, 0.0, -1.0]]), np.array([[0.0, 0.0, 1.0]]))
print(json.dumps({**events, "r": res.params["r"].tolist(), "E": float(E[0])}))
"""


def _compiles(cache_dir: Path) -> dict:
    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(cache_dir), "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", _COUNT_COMPILES],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_copied_cache_folder_is_as_warm_as_the_original(tmp_path):
    """JAX's cache keys must not name the cache folder: a cache copied elsewhere (a CI cache,
    another machine's home) loads every program; none is compiled again (JAX's own events:
    each program asks the cache; a hit is loaded, anything else compiled)."""
    import shutil

    a, b = tmp_path / "a", tmp_path / "b"
    cold = _compiles(a)
    assert cold["requests"] > 0 and cold["hits"] == 0  # an empty cache: all compiled
    shutil.copytree(a, b)
    files = sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    warm = _compiles(b)
    assert warm["requests"] == cold["requests"]  # the same programs, each asked for
    assert warm["hits"] == warm["requests"]  # every one loaded: none compiled again
    assert sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file()) == files  # none new
    assert (warm["r"], warm["E"]) == (cold["r"], cold["E"])


# ----------------------------------------------------------------------------- imports
_SMALL_SCENE = """
name = "small"
tolerance = 0.05
[constraints]
families = ["inverse_square", "clamped"]
[[lights]]
kind = "sphere"
radius = 0.1
height = 1.0
[[receivers]]
kind = "distribution"
distance = [0.5, 3.0]
n = 200
"""

_IMPORTS = r"""
import contextlib, io, json, sys
from attenfit.cli import main

seen = {}
for name, argv in (
    ("families", ["families"]),
    ("export", ["export", "yuksel", "--lang", "glsl"]),
    ("scene", ["scene", sys.argv[1]]),
    ("scene --out", ["scene", sys.argv[1], "--out", sys.argv[2]]),
):
    with contextlib.redirect_stdout(io.StringIO()):
        code = main(argv + ["--quiet"])
    seen[name] = (code, "matplotlib" in sys.modules)
print(json.dumps(seen))
"""


def test_matplotlib_is_imported_only_when_a_figure_is_drawn(tmp_path):
    """`families`, `export` and `scene` without --out draw nothing and never import
    matplotlib (0.3 s or more of a fresh process); `scene --out` draws, and imports it."""
    scene = tmp_path / "small.toml"
    scene.write_text(_SMALL_SCENE)
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    proc = subprocess.run(
        [sys.executable, "-c", _IMPORTS, str(scene), str(tmp_path / "out")],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    seen = json.loads(proc.stdout.strip().splitlines()[-1])
    assert seen == {
        "families": [0, False],
        "export": [0, False],
        "scene": [0, False],
        "scene --out": [0, True],
    }
