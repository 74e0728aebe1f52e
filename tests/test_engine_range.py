"""One range per answer (issue 29): where the engine's joint search moves a light's range
(`attenfit._scenes._engine_search`), the headline, the table and the written glTF state the
range the engine renders; and a fitted range that ran away (the issue's DiskLight scene under
`--engine gltf`, once refused with "range=1.43e+83 ... is not a finite float32") is answered,
its exported shader holding a finite float32 range."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest
from test_engine_witness import _DISK  # the issue's DiskLight scene

from attenfit._judge import get_witness
from attenfit._scenes import Scene
from attenfit._scenes._answer import answer_scene

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "scenes"


def _engine_range_m(engine: str, props) -> float:
    """The range `props` hold, in metres (the witness's range property and its unit)."""
    held = [(n, u) for n, role, u, *_ in get_witness(engine).search_props if role == "range"]
    ((name, unit),) = [(n, u) for n, u in held if n in props]
    return float(props[name]) / unit


def test_the_issues_disk_scene_is_answered_with_a_finite_range(tmp_path):
    path = tmp_path / "disk.toml"
    path.write_text(_DISK)
    ans = answer_scene(Scene.load(path), "gltf")
    (c,) = ans.choices
    R = _engine_range_m("gltf", c.properties)
    assert math.isfinite(R) and R == pytest.approx(c.range["range"], rel=1e-12)
    for lang, text in ans.recommendation.shaders.items():
        for v in re.findall(r"range\s*=\s*([0-9.eE+-]+)", text):
            assert np.isfinite(np.float32(float(v))), (lang, v)


def test_the_headline_and_table_state_the_range_the_engine_renders():
    """spotlight.toml under Godot: the joint search moves `spot_range` off the range trade's;
    the answer states the searched one everywhere."""
    ans = answer_scene(Scene.load(EXAMPLES / "spotlight.toml"), "godot")
    (c,) = ans.choices
    R = _engine_range_m("godot", c.properties)
    assert c.range["range"] == pytest.approx(R, rel=1e-12)
    assert f"range {R:.3g} m" in ans.summary()
    assert f"{R:.4g} m" in ans.to_markdown()


def test_the_written_gltf_range_is_the_one_the_engine_renders(tmp_path):
    """room.glb's spot under glTF: the written `range` is the answer's engine property."""
    from attenfit._scenes._answer import answer_file

    room = EXAMPLES / "blender" / "room.glb"
    ans = answer_file(room, side=room.parent / "room.side.toml", engine="gltf", samples=256)
    out = ans.write_back(tmp_path / "room.gltf")
    doc = json.loads(out.read_text())
    lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
    checked = 0
    for c in ans.choices:
        if "range" in c.properties and c.range is not None:
            R = _engine_range_m("gltf", c.properties)
            assert lights[ans.imported.refs[c.light]]["range"] == pytest.approx(R, rel=1e-12)
            checked += 1
    assert checked
