"""The caches that make a warm call cheap (issue 30): `attenfit export`'s text, and the
report's figures and Mitsuba witness. A cached answer must equal the computed one byte for
byte, a corrupted entry must be ignored (recomputed, never trusted), and a changed input
must recompute."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from attenfit import _cache

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(folder))
    return folder


# ----------------------------------------------------------------------------- export
_EXPORT = r"""
import contextlib, io, json, sys
from attenfit.cli import main

out = io.StringIO()
with contextlib.redirect_stdout(out):
    code = main(sys.argv[1:])
print(json.dumps([code, out.getvalue(), "jax" in sys.modules]))
"""


def _export(cache_dir: Path, *argv: str, cwd: Path | None = None) -> tuple[int, str, bool, str]:
    """(exit code, stdout, whether JAX was imported, stderr) of `attenfit export ARGV` in a
    fresh process."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "ATTENFIT_CACHE_DIR": str(cache_dir)}
    proc = subprocess.run(
        [sys.executable, "-c", _EXPORT, "export", *argv],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        cwd=cwd,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    code, text, jax = json.loads(proc.stdout.strip().splitlines()[-1])
    return code, text, jax, proc.stderr


def _entries(cache_dir: Path, kind: str) -> list[Path]:
    return sorted((cache_dir / "entries").rglob(f"{kind}/*.bin"))


def test_a_warm_export_prints_the_same_bytes_without_jax_and_ignores_a_corrupt_entry(cache_dir):
    argv = ("yuksel", "--lang", "hlsl", "--param", "r=0.25", "--uniforms")
    code, cold, cold_jax, _ = _export(cache_dir, *argv)
    assert code == 0 and cold_jax and "attenfit_yuksel" in cold
    (entry,) = _entries(cache_dir, "export")
    code, warm, warm_jax, _ = _export(cache_dir, *argv)
    assert (code, warm, warm_jax) == (0, cold, False)
    # another argument is another entry, computed
    code, glsl, jax, _ = _export(cache_dir, "yuksel", "--lang", "glsl", "--param", "r=0.25")
    assert code == 0 and jax and glsl != cold and len(_entries(cache_dir, "export")) == 2
    # a corrupted entry is ignored with a notice and recomputed, never printed
    data = entry.read_bytes()
    entry.write_bytes(data.replace(b"attenfit_yuksel", b"attenfit_bogus_"))
    code, again, jax, err = _export(cache_dir, *argv)
    assert (code, again, jax) == (0, cold, True) and "ignoring a corrupt cache entry" in err


def test_an_export_entry_of_the_wrong_shape_is_ignored(cache_dir, capsys):
    key = json.dumps(["x"])
    assert _cache.write("export", key, json.dumps({"text": 3}).encode())
    assert _cache.read("export", key) is None
    assert "no exported text" in capsys.readouterr().err
    assert _cache.write("export", key, json.dumps({"text": "f"}).encode())
    assert _cache.read("export", key) == b'{"text": "f"}'


def test_a_fit_file_export_is_keyed_by_the_file_bytes(cache_dir, tmp_path):
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"family": "yuksel", "params": {"r": 0.5}}))
    _, first, _, _ = _export(cache_dir, str(fit), "--lang", "c")
    _, warm, jax, _ = _export(cache_dir, str(fit), "--lang", "c")
    assert warm == first and not jax
    fit.write_text(json.dumps({"family": "yuksel", "params": {"r": 0.75}}))
    _, changed, jax, _ = _export(cache_dir, str(fit), "--lang", "c")
    assert jax and changed != first and "0.75" in changed
