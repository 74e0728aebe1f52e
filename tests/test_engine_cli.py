"""`attenfit scene FILE.toml --engine E` answers per light through the engine (`answer_scene`),
as a USD or glTF file is: the engine's properties and the error the engine renders with
them, recomputed here through the engine's code transcribed in tests/_engine_code.py."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import pytest
from _engine_code import engine_rendered_errors

from attenfit._scenes import Scene, engine_scene, get_engine
from attenfit.cli import main

SPOT = Path(__file__).resolve().parent.parent / "examples" / "scenes" / "spotlight.toml"


def _run(capsys, *argv):
    code = main(["scene", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_toml_engine_answer_in_markdown(capsys, tmp_path):
    code, text, err = _run(capsys, SPOT, "--engine", "godot", "--out", tmp_path / "ans")
    assert code == 0
    assert "## Per-light choices for godot" in text
    assert "engine-rendered error" in text
    assert "### godot light properties" in text
    assert "spot_angle_attenuation = " in text
    assert "as the engine renders it" in err  # the summary line
    assert {"answer.md", "answer.json", "lights.png"} <= {
        p.name for p in (tmp_path / "ans").iterdir()
    }


@pytest.mark.parametrize("engine", ["godot", "filament"])
def test_toml_engine_answer_is_what_the_engine_renders(capsys, engine):
    code, text, _ = _run(capsys, SPOT, "--engine", engine, "--json")
    assert code == 0
    ans = json.loads(text)
    assert ans["format"] == "attenfit.scene-file-answer"
    assert ans["recommendation"]["scene"]["engine"] == engine
    (light,) = ans["lights"]
    assert light["properties"] and light["engine_error"] is not None
    scene = engine_scene(Scene.load(SPOT), get_engine(engine))
    ((_, rendered),) = engine_rendered_errors(scene, [SimpleNamespace(**light)], engine)
    assert light["engine_error"] == pytest.approx(rendered, rel=0.05)
    assert light["status"] == ("pass" if rendered <= scene.tolerance else "fail")
