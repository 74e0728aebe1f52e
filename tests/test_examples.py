"""The examples run and reproduce what the seeds show.

Each script in `examples/` is run (its `main(argv)`, in this process under the strict test
settings, or as `python examples/NAME.py` in a subprocess) into a temporary folder; the
tests check that its figures exist and are real images, and assert the reproduced features
on the numbers it wrote (`numbers.json`) against independent textbook forms written here.
"""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def _load(name: str):
    """Import `examples/NAME.py` as a module (its folder on sys.path for `_example`)."""
    if str(EXAMPLES) not in sys.path:
        sys.path.insert(0, str(EXAMPLES))
    spec = importlib.util.spec_from_file_location(f"example_{name}", EXAMPLES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _numbers(folder: Path) -> dict:
    return json.loads((folder / "numbers.json").read_text())


def _assert_png(path: Path, min_bytes: int = 5_000):
    data = path.read_bytes()
    assert data[:8] == PNG_MAGIC, path
    assert len(data) > min_bytes, f"{path} is suspiciously small ({len(data)} bytes)"


# ----------------------------------------------------------------------------- Yuksel Fig. 3
def test_yuksel_fig3_script(tmp_path):
    """Run as a user would; check Yuksel's stated features against the textbook forms."""
    out = tmp_path / "y3"
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / "reproduce_yuksel_fig3.py"), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    assert "Yuksel eq. 7" in proc.stdout
    _assert_png(out / "yuksel_fig3.png")
    nums = _numbers(out)
    r = nums["r"]
    d = np.array(nums["d_over_r"]) * r
    vals = {
        k: np.array([np.nan if v is None else float(v) for v in vs])
        for k, vs in nums["values"].items()
    }
    # Independent forms: eq. 7 as printed (naive, fine in float64 here), eq. 8, the disk's
    # on-axis irradiance 1/(d^2 + r^2) (Howell B-12), the sphere's I/d^2 outside it.
    with np.errstate(divide="ignore"):
        eq7 = 2 / r**2 * (1 - d / np.sqrt(d**2 + r**2))
        eq8 = 1 / (d**2 + r**2 / 2)
    np.testing.assert_allclose(vals["Yuksel eq. 7"], eq7, rtol=1e-9)
    np.testing.assert_allclose(vals["Yuksel eq. 8"], eq8, rtol=1e-12)
    lit = d > 0
    np.testing.assert_allclose(vals["true disk (facing)"][lit], 1 / (d[lit] ** 2 + r**2), rtol=1e-9)
    out_sph = d > r
    np.testing.assert_allclose(
        vals["true sphere (facing)"][out_sph], 1 / d[out_sph] ** 2, rtol=1e-9
    )
    assert np.all(np.isnan(vals["true sphere (facing)"][~out_sph]))
    f = nums["features"]
    assert f["eq7_at_0_times_r2"] == pytest.approx(2.0, rel=1e-12)
    assert f["eq8_at_0_times_r2"] == pytest.approx(2.0, rel=1e-12)
    assert f["disk_at_0_times_r2"] == pytest.approx(1.0, rel=1e-6)  # half of eq. 7's
    assert f["eq8_between_eq7_and_inverse_square"] is True
    assert f["min_gap_eq8_minus_eq7"] > 0 and f["min_gap_inverse_square_minus_eq8"] > 0
    # f d^2 -> 1 with the leading corrections -3/4 (r/d)^2 (eq. 7) and -1/2 (r/d)^2 (eq. 8).
    assert f["eq7_times_d2_at_1000r"] == pytest.approx(1 - 0.75e-6, abs=1e-11)
    assert f["eq8_times_d2_at_1000r"] == pytest.approx(1 - 0.5e-6, abs=1e-11)


def test_example_refuses_to_overwrite(tmp_path):
    """An existing non-empty output folder is kept unless --force (one-line error, exit 2)."""
    out = tmp_path / "taken"
    out.mkdir()
    (out / "keep.txt").write_text("mine")
    proc = subprocess.run(
        [sys.executable, str(EXAMPLES / "reproduce_yuksel_fig3.py"), "--out", str(out)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 2
    assert proc.stderr.startswith("error: output folder") and "--force" in proc.stderr
    assert "Traceback" not in proc.stderr
    assert (out / "keep.txt").read_text() == "mine"
