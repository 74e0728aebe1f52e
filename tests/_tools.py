"""The external tools the export tests validate with (glslangValidator, spirv-val, naga, cc)."""

import shutil
import subprocess
from pathlib import Path

import pytest


def need(tool: str) -> str:
    """The path of `tool`, or skip the test, saying the validation did not run."""
    path = shutil.which(tool)
    if path is None:
        pytest.skip(f"{tool} is not installed: this validation did not run")
    return path


def run(cmd: list[str], cwd: Path) -> None:
    """Run `cmd` in `cwd`; fail with its output when it fails."""
    proc = subprocess.run(cmd, capture_output=True, text=True, cwd=cwd)
    assert proc.returncode == 0, f"{' '.join(cmd)}:\n{proc.stdout}\n{proc.stderr}"
