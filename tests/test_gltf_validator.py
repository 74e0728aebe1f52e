"""Every glTF write-back attenfit produces passes the Khronos glTF validator (the npm
package `gltf-validator`, installed by `.ci/run` into `.tools/gltf-validator`) with 0
errors, and adds no issue the input did not have: the public glTF files (tests/data/public)
and the Blender room (examples/scenes/blender/room.glb), per engine and with no engine.

The validator is run through `tests/_gltf_validate.js` (node). Where node or the validator
is missing the tests skip with the reason, except in CI (`ATTENFIT_CI` set, as `.ci/run`
sets it, or `CI`), where they fail: there the validator must have run."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import pytest

from attenfit.cli import main

ROOT = Path(__file__).resolve().parent.parent
PUBLIC = ROOT / "tests" / "data" / "public"
BLENDER = ROOT / "examples" / "scenes" / "blender"
RUNNER = ROOT / "tests" / "_gltf_validate.js"
ENGINES = ("godot", "threejs", "unreal", "filament", "bevy", "unity", "gltf")
#: (input, options): every glTF attenfit answers (the others are refused before a write-back)
FILES = {
    "room": (BLENDER / "room.glb", ("--side", str(BLENDER / "room.side.toml"))),
    "LightsPoint": (PUBLIC / "atteneder-lights-point" / "LightsPoint.gltf", ("--radius", "0.05")),
    "LightsSpot": (PUBLIC / "atteneder-lights-spot" / "LightsSpot.gltf", ("--radius", "0.05")),
}


def _validator() -> tuple[str, str]:
    """(node, the validator's package folder), or skip (fail in CI) saying which is missing."""
    node = shutil.which("node")
    package = Path(
        os.environ.get("ATTENFIT_GLTF_VALIDATOR")
        or ROOT / ".tools" / "gltf-validator" / "node_modules" / "gltf-validator"
    )
    missing = (
        "node is not installed"
        if node is None
        else None
        if (package / "package.json").is_file()
        else f"the Khronos glTF validator is not installed at {package} (.ci/run installs it: "
        "npm install --prefix .tools/gltf-validator gltf-validator)"
    )
    if missing is not None:
        if os.environ.get("ATTENFIT_CI") or os.environ.get("CI"):
            pytest.fail(f"{missing}: the glTF write-backs were not validated in CI")
        pytest.skip(f"{missing}: this validation did not run")
    return node, str(package)


def validate(*files: Path) -> list[dict]:
    """The validator's report per file: {file, errors, warnings, messages}."""
    node, package = _validator()
    proc = subprocess.run(
        [node, str(RUNNER), package, *map(str, files)], capture_output=True, text=True
    )
    assert proc.returncode == 0, proc.stderr
    return [json.loads(line) for line in proc.stdout.splitlines()]


def _codes(report: dict) -> set[str]:
    return {m.split()[1] for m in report["messages"]}


def _write_back(capsys, tmp_path: Path, name: str, engine: str | None) -> Path:
    path, options = FILES[name]
    out = tmp_path / f"{name}.{engine or 'none'}.gltf"
    argv = ["scene", str(path), *options, "--samples", "16", "--threshold", "0.1", "-q"]
    argv += ["--write-back", str(out)] + (["--engine", engine] if engine else [])
    code = main(argv)
    err = capsys.readouterr().err
    assert code == 0, err
    return out


def _check(outs: list[Path]) -> None:
    reports = validate(*(p for p, _ in FILES.values()))
    inputs = dict(zip(FILES, reports, strict=True))
    for report in validate(*outs):
        name = Path(report["file"]).name.split(".")[0]
        assert report["errors"] == 0, report
        assert report["warnings"] == 0, report
        assert _codes(report) <= _codes(inputs[name]), (report, inputs[name])
        doc = json.loads(Path(report["file"]).read_text())
        lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
        assert any("attenfit" in d.get("extras", {}) for d in lights), report["file"]


def test_the_inputs_pass_the_validator():
    """The public glTF files (the two `.bin` rebuilt from their LFS oid) and the room."""
    files = [p for p, _ in FILES.values()]
    files += [PUBLIC / "gltf-validator-lights" / "valid_full.gltf"]
    files += [PUBLIC / "gltf-validator-node" / "valid.gltf"]
    for report in validate(*files):
        assert report["errors"] == 0 and report["warnings"] == 0, report


def test_write_backs_pass_the_validator(capsys, tmp_path):
    """For glTF itself (the answers every glTF viewer reads)."""
    _check([_write_back(capsys, tmp_path, name, "gltf") for name in FILES])


@pytest.mark.slow
@pytest.mark.parametrize("engine", [None, *(e for e in ENGINES if e != "gltf")])
def test_every_engines_write_back_passes_the_validator(capsys, tmp_path, engine):
    """Every other engine's answers, and none (every family: minutes on 2 cores)."""
    _check([_write_back(capsys, tmp_path, name, engine) for name in FILES])
