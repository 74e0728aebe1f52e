"""USD read completely, or refused with a reason (issue 29, item 4): time samples and
`--time`, pre-2021 attribute names, `shaping:focus` and `shaping:ies:file`, visibility and
purpose, and write-back values in the stage's units.

Expected values come from the UsdLux schema's formulas worked by hand (radiance =
intensity x 2^exposure; point-equivalent intensity = radiance x pi r^2) and from usd-core's
own value resolution (`Usd.Attribute.Get` at a time, `UsdGeom.XformCache`), never from
attenfit's reader."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from attenfit import BadTypeError, BadValueError
from attenfit.cli import main

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

from attenfit._scenes._choices import LightChoice  # noqa: E402
from attenfit._scenes._files import load_mesh_scene  # noqa: E402
from attenfit._scenes._writeback import write_back  # noqa: E402

FLOOR = """
def Mesh "floor"
{
    uniform bool doubleSided = 1
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-500, -500, -100), (500, -500, -100), (500, 500, -100), (-500, 500, -100)]
}
"""


def _scene(tmp_path: Path, body: str, meta: str = "", name: str = "scene.usda") -> Path:
    path = tmp_path / name
    path.write_text(f"#usda 1.0\n(\n{meta}\n)\n{FLOOR}\n{body}\n")
    return path


def _load(path: Path, **kw):
    notes: list[str] = []
    return load_mesh_scene(path, samples=16, notice=notes.append, **kw), notes


SPOT = """
def SphereLight "spot" (
    prepend apiSchemas = ["ShapingAPI"]
)
{
    float inputs:intensity = 2
    float inputs:radius = 1
    float inputs:shaping:cone:angle.timeSamples = { 1: 25, 5: 35 }
    float inputs:shaping:cone:softness.timeSamples = { 1: 0 }
    double3 xformOp:translate.timeSamples = { 1: (10, 7, -8), 5: (6, 3, 0) }
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""
CM = "metersPerUnit = 0.01\n    startTimeCode = 1\n    endTimeCode = 5"


def test_values_authored_only_as_time_samples_are_read_at_the_start_time_code(tmp_path):
    """The maya-usd spot (LightsTest.usda): 25 degrees at (10, 7, -8) cm, not usd-core's
    fallback (90 degrees at the origin) at the default time."""
    path = _scene(tmp_path, SPOT, CM)
    im, notes = _load(path)
    (light,) = im.scene.lights
    assert light.kind == "spot" and light.umbra == pytest.approx(25.0)
    assert light.position == pytest.approx((0.10, 0.07, -0.08))
    assert any("start time code 1" in n for n in notes)
    # usd-core itself, at the default time, answers the schema's fallback (the old reading)
    stage = Usd.Stage.Open(str(path))
    assert stage.GetPrimAtPath("/spot").GetAttribute("inputs:shaping:cone:angle").Get() == 90


def test_time_reads_every_value_at_that_time_code(tmp_path):
    """At time 3, usd-core interpolates linearly between the samples at 1 and 5: the cone
    (25 + 35) / 2 = 30 degrees, the centre ((10 + 6) / 2, (7 + 3) / 2, (-8 + 0) / 2) cm."""
    im, notes = _load(_scene(tmp_path, SPOT, CM), time=3)
    (light,) = im.scene.lights
    assert light.umbra == pytest.approx(30.0)
    assert light.position == pytest.approx((0.08, 0.05, -0.04))
    assert not any("start time code" in n for n in notes)


def test_a_default_value_wins_over_time_samples_without_time(tmp_path):
    body = SPOT.replace("float inputs:intensity = 2", "float inputs:intensity = 2\n    float inputs:intensity.timeSamples = { 1: 8 }")  # fmt: skip
    a, _ = _load(_scene(tmp_path, body, CM))
    b, _ = _load(_scene(tmp_path, body, CM), time=1)
    # pi r^2 x intensity, r = 1 cm: the default 2 without --time, the sample 8 at time 1
    assert a.scene.lights[0].intensity == pytest.approx(2 * math.pi * 0.01**2)
    assert b.scene.lights[0].intensity == pytest.approx(8 * math.pi * 0.01**2)


def test_transforms_compose_per_op_as_usd_core_does(tmp_path):
    """A pivot and a rotation, with an inverted op (usd-wg Environment.usda writes these):
    the centre matches usd-core's `XformCache` at the default time."""
    body = """
def Xform "rig"
{
    float3 xformOp:rotateXYZ = (10, 20, 30)
    double3 xformOp:translate = (5, 0, 0)
    float3 xformOp:translate:pivot = (1, 2, 3)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:translate:pivot", "xformOp:rotateXYZ", "!invert!xformOp:translate:pivot"]
    def SphereLight "bulb"
    {
        float inputs:radius = 0.25
        double3 xformOp:translate = (0, 0, 40)
        uniform token[] xformOpOrder = ["xformOp:translate"]
    }
}
"""
    path = _scene(tmp_path, body, CM)
    im, _ = _load(path)
    stage = Usd.Stage.Open(str(path))
    m = np.array(UsdGeom.XformCache().GetLocalToWorldTransform(stage.GetPrimAtPath("/rig/bulb")))
    assert im.scene.lights[0].position == pytest.approx(tuple(m[3, :3] * 0.01), abs=1e-12)


def test_mesh_points_authored_only_as_time_samples_are_read(tmp_path):
    """OpenUSD's torch.usda authors its mesh only as time samples."""
    body = (
        FLOOR.replace('"floor"', '"other"')
        .replace("point3f[] points =", "point3f[] points.timeSamples = { 0:")
        .replace("-100)]", "-100)] }")
        + 'def SphereLight "bulb" {\n    float inputs:radius = 1\n}'
    )
    path = _scene(tmp_path, body, "metersPerUnit = 0.01")
    im, _ = _load(path)
    assert len(im.scene.receivers[0].points) > 0


@pytest.mark.parametrize("value", ["nan", "inf", "abc"])
def test_a_bad_time_is_one_line_and_exit_2(tmp_path, capsys, value):
    path = _scene(tmp_path, SPOT, CM)
    code = main(["scene", str(path), "--time", value])
    err = capsys.readouterr().err
    assert code == 2 and err.count("\n") == 1 and err.startswith("attenfit"), err
    assert "time" in err


def test_time_in_the_api_is_checked(tmp_path):
    path = _scene(tmp_path, SPOT, CM)
    with pytest.raises(BadTypeError, match="time"):
        load_mesh_scene(path, time="3")
    with pytest.raises(BadValueError, match="time"):
        load_mesh_scene(path, time=math.nan)


def test_time_is_refused_for_a_toml_scene(capsys):
    code = main(["scene", "examples/scenes/room.toml", "--time", "1"])
    err = capsys.readouterr().err
    assert code == 2 and "--time" in err and err.count("\n") == 1, err


OLD = """
def SphereLight "bulb"
{
    float radius = 20
    float intensity = 3
    float exposure = 1
    bool normalize = 1
}
"""


def test_pre_2021_names_are_read_with_a_notice(tmp_path):
    """usd-core before 21.02 wrote `radius`, `intensity`, `exposure`, `normalize`. With
    normalize the radiance is intensity x 2^exposure / (4 pi r^2), so the point-equivalent
    intensity is 3 x 2 x pi r^2 / (4 pi r^2) = 1.5 (r = 0.2 m)."""
    im, notes = _load(_scene(tmp_path, OLD, "metersPerUnit = 0.01"))
    (light,) = im.scene.lights
    assert light.radius == pytest.approx(0.2)
    assert light.intensity == pytest.approx(1.5)
    (note,) = [n for n in notes if "pre-2021" in n]
    assert "/bulb" in note and all(k in note for k in ("radius", "intensity", "exposure"))


def test_the_inputs_name_wins_over_the_old_one(tmp_path):
    body = OLD.replace("float radius = 20", "float radius = 20\n    float inputs:radius = 10")
    im, notes = _load(_scene(tmp_path, body, "metersPerUnit = 0.01"))
    assert im.scene.lights[0].radius == pytest.approx(0.1)
    (note,) = [n for n in notes if "pre-2021" in n]
    assert "radius" not in note.split("names ")[1].split(" as")[0]


def _shaped(extra: str) -> str:
    return f"""
def SphereLight "shaped" (
    prepend apiSchemas = ["ShapingAPI"]
)
{{
    float inputs:radius = 5
    float inputs:shaping:cone:angle = 40
    {extra}
}}
def SphereLight "plain"
{{
    float inputs:radius = 5
}}
"""


@pytest.mark.parametrize(
    ("extra", "fragment"),
    [
        ("float inputs:shaping:focus = 8", "shaping:focus 8"),
        ("float shaping:focus = 2", "shaping:focus 2"),
        ("asset inputs:shaping:ies:file = @lamp.ies@", "shaping:ies:file 'lamp.ies'"),
    ],
)
def test_focus_and_ies_are_refused_with_a_notice_naming_the_light(tmp_path, extra, fragment):
    path = _scene(tmp_path, _shaped(extra), "metersPerUnit = 0.01")
    im, notes = _load(path)
    assert im.names == ("/plain",)
    (note,) = [n for n in notes if fragment in n]
    assert "/shaped" in note and note.endswith("skipped")
    with pytest.raises(BadValueError, match=f"/shaped: {fragment}"):
        load_mesh_scene(path, samples=16, strict=True, notice=lambda m: None)


def test_declared_but_unauthored_focus_and_ies_are_read(tmp_path):
    """usd-wg's Environment.usda declares `float inputs:shaping:focus` and `asset
    inputs:shaping:ies:file` with no value: nothing to refuse."""
    extra = "float inputs:shaping:focus\n    asset inputs:shaping:ies:file\n    float inputs:shaping:focus.timeSamples = { 1: 0 }"  # fmt: skip
    im, _ = _load(_scene(tmp_path, _shaped(extra), "metersPerUnit = 0.01"))
    assert im.names == ("/shaped", "/plain")


@pytest.mark.parametrize(
    ("body", "fragment"),
    [
        (
            'def Xform "rig" {\n    token visibility = "invisible"\n' + _shaped("") + "}\n",
            "invisible (from /rig)",
        ),
        (
            _shaped("").replace(
                "float inputs:radius = 5\n    float",
                'token visibility = "invisible"\n    float inputs:radius = 5\n    float',
            ),
            "invisible",
        ),
        (
            _shaped("").replace(
                "float inputs:radius = 5\n    float",
                'uniform token purpose = "guide"\n    float inputs:radius = 5\n    float',
            ),
            "purpose guide",
        ),
    ],
)
def test_invisible_lights_and_guides_are_skipped_with_a_notice(tmp_path, body, fragment):
    if "rig" in body:  # both lights under the invisible rig; one more outside it
        body += 'def SphereLight "outside" {\n    float inputs:radius = 5\n}'
    im, notes = _load(_scene(tmp_path, body, "metersPerUnit = 0.01"))
    assert "/shaped" not in im.names and "/rig/shaped" not in im.names
    assert any(fragment in n and "shaped" in n and "skipped" in n for n in notes), notes


def test_visibility_time_samples_follow_time(tmp_path):
    """OpenUSD testVarying.usda: visible at 0, invisible from 5 (held)."""
    samples = 'token visibility.timeSamples = { 0: "inherited", 5: "invisible" }'
    body = _shaped("").replace(
        "float inputs:radius = 5\n    float", f"{samples}\n    float inputs:radius = 5\n    float"
    )
    path = _scene(tmp_path, body, "metersPerUnit = 0.01")
    assert "/shaped" in _load(path)[0].names
    assert "/shaped" not in _load(path, time=5)[0].names


def test_write_back_values_are_in_the_stage_units(tmp_path):
    """A range of 11.91 m on a centimetre stage is written as 1191 (cm), a threshold of
    2 per m^2 as 2e-4 per cm^2, a length parameter likewise; the unit is recorded."""
    path = _scene(tmp_path, 'def SphereLight "bulb" {\n    float inputs:radius = 5\n}', "metersPerUnit = 0.01")  # fmt: skip
    im, _ = _load(path, engine="gltf")
    choice = LightChoice(
        light=0,
        name="/bulb",
        file_kind="SphereLight",
        receivers=16,
        family="gltf_range",
        status="pass",
        params={"range": 11.91},
        error=0.01,
        shader_cost=1.0,
        spot=None,
        range={"range": 11.91, "threshold": 2.0},
        properties={"range": 11.91},
        checked_error=0.02,
    )
    out = write_back(im, [choice], tmp_path / "out.usda")
    stage = Usd.Stage.Open(str(out))
    prim = stage.GetPrimAtPath("/bulb")
    assert prim.GetAttribute("attenfit:range").Get() == pytest.approx(1191.0)
    assert prim.GetAttribute("attenfit:params:range").Get() == pytest.approx(1191.0)
    assert prim.GetAttribute("attenfit:threshold").Get() == pytest.approx(2e-4)
    assert prim.GetAttribute("attenfit:metersPerUnit").Get() == pytest.approx(0.01)
    assert "stage units" in prim.GetAttribute("attenfit:range").GetDocumentation()
    assert "0.01" in prim.GetAttribute("attenfit:range").GetDocumentation()
    # the engine's own property stays in the engine's unit (glTF: metres)
    assert prim.GetAttribute("attenfit:gltf:range").Get() == pytest.approx(11.91)


def _lights(*lights: tuple[str, str, dict]) -> str:
    """usda text of lights (type, name, {attribute: float}; `normalize` a bool)."""
    out = []
    for type_name, name, attrs in lights:
        lines = [
            f"    bool inputs:{k} = 1" if k == "normalize" else f"    float {k} = {v}"
            for k, v in attrs.items()
        ]
        out.append(f'def {type_name} "{name}"\n{{\n' + "\n".join(lines) + "\n}")
    return "\n".join(out) + "\n"


DIFFUSE = _lights(
    ("SphereLight", "sphere", {"inputs:radius": 10, "inputs:intensity": 3, "inputs:diffuse": 0.5}),
    ("DiskLight", "disk", {"inputs:radius": 10, "inputs:intensity": 2, "inputs:diffuse": 2.5, "normalize": 1}),
    ("RectLight", "rect", {"inputs:width": 20, "inputs:height": 10, "inputs:intensity": 4, "inputs:diffuse": 0.25}),
    ("CylinderLight", "tube", {"inputs:length": 30, "inputs:radius": 5, "inputs:intensity": 2, "inputs:diffuse": 3}),
    ("SphereLight", "old", {"inputs:radius": 10, "diffuse": 0.5}),
)  # fmt: skip


def test_diffuse_multiplies_the_intensity(tmp_path):
    """UsdLux LightAPI `inputs:diffuse` ("A multiplier for the effect of this light on the
    diffuse response of materials", default 1) scales the radiance attenfit judges; worked
    by hand on a centimetre stage: sphere 3 x 0.5 x pi (0.1 m)^2; disk normalised, 2 x 2.5 /
    (pi r^2) x pi r^2 = 5; rect 4 x 0.25 x (0.2 x 0.1 m); tube 2 x 3 x pi (0.05 m)^2; the
    pre-2021 name `diffuse` read with a notice: 1 x 0.5 x pi (0.1 m)^2."""
    im, notes = _load(_scene(tmp_path, DIFFUSE, "metersPerUnit = 0.01"))
    got = dict(zip(im.names, (x.intensity for x in im.scene.lights), strict=True))
    assert got == pytest.approx(
        {
            "/sphere": 1.5 * math.pi * 0.01,
            "/disk": 5.0,
            "/rect": 0.02,
            "/tube": 6 * math.pi * 0.0025,
            "/old": 0.5 * math.pi * 0.01,
        },
        rel=1e-6,  # float inputs
    )
    (note,) = [n for n in notes if "pre-2021" in n]
    assert "/old" in note and "diffuse" in note


@pytest.mark.parametrize("light", ["SphereLight", "RectLight"])
def test_diffuse_zero_is_skipped_with_a_notice_and_refused_with_strict(tmp_path, light):
    """`inputs:diffuse` 0 (maya-usd's LightsTest.usda spot): the light lights no diffuse
    surface, so attenfit has nothing to judge; skipped as the unmodelled inputs are."""
    body = f'def {light} "dark"\n{{\n    float inputs:diffuse = 0\n}}\n' + OLD
    path = _scene(tmp_path, body, "metersPerUnit = 0.01")
    im, notes = _load(path)
    assert im.names == ("/bulb",)
    (note,) = [n for n in notes if "/dark" in n]
    assert "inputs:diffuse 0" in note and note.endswith("skipped")
    with pytest.raises(BadValueError, match=r"/dark: inputs:diffuse 0.*--strict refuses it"):
        load_mesh_scene(path, samples=16, strict=True, notice=lambda m: None)


def test_negative_diffuse_is_refused_naming_it(tmp_path):
    body = OLD.replace("float radius = 20", "float radius = 20\n    float inputs:diffuse = -1")
    with pytest.raises(BadValueError, match="/bulb: inputs:diffuse -1 is negative"):
        _load(_scene(tmp_path, body, "metersPerUnit = 0.01"))
