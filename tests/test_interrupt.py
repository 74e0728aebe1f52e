"""Nothing lost: SIGINT and SIGTERM sent to real `attenfit gen` and `attenfit report` processes.

After the signal the process exits 130 (SIGINT) or 143 (SIGTERM) with one line and no
traceback, the previous output is byte for byte what it was, no temporary file is left
behind and every finished chunk of a batch render is a complete file. A rerun of the same
`gen` command resumes: it reuses the finished chunks (proved by marking one) and renders
only the rest.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
import types
from pathlib import Path

import numpy as np
import pytest

import attenfit as af

REPO = Path(__file__).resolve().parents[1]
TMP_MARK = ".attenfit-tmp"


def _start(args: list[str], cwd: Path) -> subprocess.Popen:
    env = {**os.environ, "PYTHONWARNINGS": "ignore", "PYTHONPATH": str(REPO)}
    return subprocess.Popen(
        [sys.executable, "-m", "attenfit", *args],
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _wait_for(cond, proc: subprocess.Popen, timeout: float = 240.0) -> None:
    t0 = time.monotonic()
    while not cond():
        if proc.poll() is not None:
            _, err = proc.communicate()
            pytest.fail(f"process ended (rc {proc.returncode}) before the signal:\n{err[-2000:]}")
        if time.monotonic() - t0 > timeout:
            proc.kill()
            pytest.fail("timed out waiting for the moment to send the signal")
        time.sleep(0.02)


def _finish(proc: subprocess.Popen) -> tuple[int, str, str]:
    out, err = proc.communicate(timeout=240)
    return proc.returncode, out, err


def _leftovers(folder: Path) -> list[str]:
    return [str(p) for p in folder.rglob("*") if TMP_MARK in p.name]


def _chunks(parts: Path) -> list[Path]:
    return sorted(parts.glob("chunk_*.npz")) if parts.is_dir() else []


GEN = [
    "gen", "--emitter", "sphere", "--radius", "0.1", "--samples", "64", "--spp", "8192",
    "--chunk", "8", "--variant", "scalar_rgb", "--seed", "3", "--out", "g.npz", "--force",
]  # fmt: skip


def test_gen_interrupted_keeps_previous_output_and_resumes(tmp_path):
    out = tmp_path / "g.npz"
    parts = tmp_path / "g.npz.parts"
    out.write_bytes(b"previous output")

    # 1. SIGINT once the first chunk is on disk
    proc = _start(GEN, tmp_path)
    _wait_for(lambda: len(_chunks(parts)) >= 1, proc)
    proc.send_signal(signal.SIGINT)
    code, _, err = _finish(proc)
    assert code == 130, err
    assert "Traceback" not in err
    assert "finished chunks are kept" in err and "interrupted" in err
    assert out.read_bytes() == b"previous output"
    assert not _leftovers(tmp_path)
    after_int = _chunks(parts)
    assert 1 <= len(after_int) < 8
    for path in after_int:  # every chunk on disk is complete
        with np.load(path, allow_pickle=False) as npz:
            assert np.all(np.isfinite(npz["E"])) and npz["E"].shape == (8,)

    # 2. SIGTERM on the rerun, once it has added a chunk of its own
    proc = _start(GEN, tmp_path)
    _wait_for(lambda: len(_chunks(parts)) > len(after_int), proc)
    proc.send_signal(signal.SIGTERM)
    code, _, err = _finish(proc)
    assert code == 143, err
    assert "Traceback" not in err and "terminated" in err
    assert out.read_bytes() == b"previous output"
    assert not _leftovers(tmp_path)
    after_term = _chunks(parts)
    assert len(after_int) < len(after_term) < 8
    assert [p.name for p in after_int] == [p.name for p in after_term[: len(after_int)]]

    # 3. mark the first finished chunk: a resumed run must reuse it, not render it again
    first = after_term[0]
    with np.load(first, allow_pickle=False) as npz:
        arrays = {k: npz[k] for k in npz.files}
    arrays["E"] = np.full_like(arrays["E"], 123.0)
    with open(first, "wb") as fh:
        np.savez(fh, **arrays)

    proc = _start(GEN, tmp_path)
    code, _, err = _finish(proc)
    assert code == 0, err
    assert not parts.exists() and not _leftovers(tmp_path)
    ds = af.Dataset.load(out)
    assert np.all(ds.E[:8] == 123.0)  # the marked chunk was reused
    truth = np.asarray(af.irradiance(ds.emitter, ds.points, ds.normals))
    z = (ds.E[8:] - truth[8:]) / ds.stderr[8:]
    assert np.all(np.abs(z) < 6), z  # the rest was rendered, and rendered right


@pytest.mark.parametrize("sig, code, word", [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")])  # fmt: skip
def test_report_interrupted_keeps_previous_report(tmp_path, sig, code, word):
    folder = tmp_path / "rep"
    folder.mkdir()
    (folder / "report.md").write_text("previous report\n")
    args = ["report", "--families", "inverse_square", "--emitters", "sphere", "--no-fit"]
    args += ["--no-mitsuba"]
    proc = _start([*args, "--out", "rep", "--force"], tmp_path)
    # the report is being written into its temporary folder: interrupt it there
    _wait_for(lambda: any(TMP_MARK in p.name for p in tmp_path.iterdir()), proc)
    time.sleep(0.3)
    proc.send_signal(sig)
    got, _, err = _finish(proc)
    assert got == code, err
    assert "Traceback" not in err and word in err
    assert sorted(p.name for p in folder.iterdir()) == ["report.md"]
    assert (folder / "report.md").read_text() == "previous report\n"
    assert not _leftovers(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]


def test_signal_handlers_are_restored_after_main():
    """`main` installs its SIGINT/SIGTERM handlers only for its own run."""
    from attenfit.cli import main

    before = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]
    hook = sys.unraisablehook
    assert main(["families", "--json"]) == 0
    assert [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)] == before
    assert sys.unraisablehook is hook


def test_a_swallowed_interrupt_still_blocks_every_commit(tmp_path):
    """An interrupt raised inside a callback is lost to Python; the commit points see it."""
    from attenfit import _atomic
    from attenfit.cli import _quiet_interrupts

    target = tmp_path / "out"
    target.mkdir()
    (target / "a.txt").write_text("old")
    (tmp_path / "f.txt").write_text("old file")
    _atomic.PENDING.append(signal.SIGTERM)
    try:
        with pytest.raises(_atomic.Interrupted) as info:
            with _atomic.atomic_dir(target, force=True) as tmp:
                (tmp / "b.txt").write_text("new")
        assert info.value.signum == signal.SIGTERM
        with pytest.raises(_atomic.Interrupted):
            _atomic.atomic_write(tmp_path / "f.txt", "new file", force=True)
    finally:
        _atomic.PENDING.clear()
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a.txt", "f.txt", "out"]
    assert (tmp_path / "f.txt").read_text() == "old file"
    # the unraisable hook stays quiet about interrupts only
    seen = []
    quiet = _quiet_interrupts(seen.append)
    quiet(types.SimpleNamespace(exc_value=_atomic.Interrupted(signal.SIGINT)))
    other = types.SimpleNamespace(exc_value=RuntimeError("x"))
    quiet(other)
    assert seen == [other]


class _Boom(Exception):
    pass


def test_folder_swap_holds_signals_back(tmp_path):
    """A signal during the two renames of `atomic_dir` arrives after them, not between."""
    from attenfit._atomic import _signals_deferred, atomic_dir

    def boom(signum, frame):
        raise _Boom()

    previous = signal.signal(signal.SIGINT, boom)
    try:
        done = []
        with pytest.raises(_Boom):
            with _signals_deferred():
                os.kill(os.getpid(), signal.SIGINT)
                time.sleep(0.05)
                done.append("block finished")
        assert done == ["block finished"]
    finally:
        signal.signal(signal.SIGINT, previous)
    # a failure inside the block leaves the previous folder as it was; success replaces it
    target = tmp_path / "out"
    target.mkdir()
    (target / "a.txt").write_text("old")
    with pytest.raises(_Boom):
        with atomic_dir(target, force=True) as tmp:
            (tmp / "b.txt").write_text("new")
            raise _Boom()
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["a.txt", "out"]
    with atomic_dir(target, force=True) as tmp:
        (tmp / "b.txt").write_text("new")
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["b.txt", "out"]
    assert oct(target.stat().st_mode & 0o777) == oct(0o777 & ~_umask())
    assert oct((target / "b.txt").stat().st_mode & 0o777) == oct(0o666 & ~_umask())


def _umask() -> int:
    mask = os.umask(0o022)
    os.umask(mask)
    return mask
