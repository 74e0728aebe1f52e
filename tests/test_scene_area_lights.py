"""Rectangle and tube lights in scenes: TOML `kind = "rect"` / `"tube"`, UsdLux `RectLight` and
`CylinderLight` (UsdLux's own definitions: a RectLight in its XY plane emitting along -Z, width
along X; a CylinderLight around its X axis, no end caps), their truth (the rectangle's and the
tube's exact irradiance at the scene's receivers) and what is refused."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from attenfit import BadValueError, RectEmitter, TubeEmitter, UnknownNameError, irradiance
from attenfit._scenes._lighting import light_truth
from attenfit._scenes._scene import Scene

pxr = pytest.importorskip("pxr")
from pxr import Gf, Usd, UsdGeom, UsdLux  # noqa: E402

from attenfit._scenes._files import load_mesh_scene  # noqa: E402

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "scenes"

RECT = """tolerance = 0.05
[[lights]]
kind = "rect"
size = [0.6, 0.3]
normal = [0, 0, -1]
tangent = [0, 1, 0]
height = 1.0
intensity = 2.0
[[receivers]]
kind = "plane"
extent = 1.0
resolution = 5
"""

TUBE = """tolerance = 0.05
[[lights]]
kind = "tube"
radius = 0.02
length = 1.2
axis = [1, 0, 0]
height = 1.5
[[receivers]]
kind = "plane"
extent = 1.0
resolution = 5
[[receivers]]
kind = "points"
points = [[0.9, 0, 1.5], [0, 0.5, 1.5]]
"""


def _scene(tmp_path, text) -> Scene:
    path = tmp_path / "s.toml"
    path.write_text(text)
    return Scene.load(path)


def test_a_rect_and_a_tube_from_toml(tmp_path):
    rect = _scene(tmp_path, RECT).lights[0]
    em = rect.emitter()
    assert isinstance(em, RectEmitter)
    assert (float(em.width), float(em.height)) == (0.6, 0.3)
    assert np.asarray(em.tangent).tolist() == [0.0, 1.0, 0.0]
    assert rect.radius == pytest.approx(math.sqrt(0.18 / math.pi), rel=1e-15)  # equal-area disk
    assert "radius" not in rect.to_dict() and rect.to_dict()["size"] == [0.6, 0.3]
    tube = _scene(tmp_path, TUBE).lights[0].emitter()
    assert isinstance(tube, TubeEmitter) and not tube.caps
    assert np.asarray(tube.a).tolist() == [-0.6, 0.0, 1.5]
    assert np.asarray(tube.b).tolist() == [0.6, 0.0, 1.5]


@pytest.mark.parametrize(
    ("text", "kind", "message"),
    [
        (
            RECT.replace("size = [0.6, 0.3]", "size = [0.6, 0.3]\nradius = 0.2"),
            UnknownNameError,
            "s.toml: [[lights]][0]: unknown key 'radius'",
        ),
        (RECT.replace("size = [0.6, 0.3]\n", ""), BadValueError, "missing key 'size'"),
        (RECT.replace("[0.6, 0.3]", "[0.6, -1]"), BadValueError, "size[1]: must be a positive"),
        (RECT.replace("[0, 1, 0]", "[0, 0, 2]"), BadValueError, "along the normal"),
        (TUBE.replace("length = 1.2\n", ""), BadValueError, "missing key 'length'"),
    ],
)
def test_bad_rects_and_tubes_are_refused_in_one_line(tmp_path, text, kind, message):
    with pytest.raises(kind, match=None) as exc:
        _scene(tmp_path, text)
    assert message in str(exc.value) and "\n" not in str(exc.value)


def test_a_receiver_inside_the_tube_is_refused_and_its_ends_are_outside(tmp_path):
    inside = TUBE.replace("[[0.9, 0, 1.5], [0, 0.5, 1.5]]", "[[0.3, 0, 1.51]]")
    with pytest.raises(BadValueError, match=r"points\[0\]: lies inside \[\[lights\]\]\[0\]"):
        _scene(tmp_path, inside)
    beyond = TUBE.replace("[[0.9, 0, 1.5], [0, 0.5, 1.5]]", "[[0.62, 0, 1.5]]")  # beyond an end
    _scene(tmp_path, beyond)


def test_the_truth_is_the_emitters_exact_irradiance(tmp_path):
    for text in (RECT, TUBE):
        scene = _scene(tmp_path, text)
        truth = light_truth(scene, 0)
        ds = truth.dataset
        want = np.asarray(irradiance(scene.lights[0].emitter(), ds.points, ds.normals))
        np.testing.assert_array_equal(truth.E_true, want)
        assert truth.judged.any() and np.all(truth.profile == 1.0)
    # on the axis beyond an end (no caps): nothing reaches it
    tube = light_truth(_scene(tmp_path, TUBE), 0)
    assert len(tube.dataset) == 25 + 2 and tube.E_true[25] == 0.0


def test_the_example_scenes_hold_a_batten_and_a_panel():
    batten = Scene.load(EXAMPLES / "batten.toml").lights[0]
    assert (batten.kind, batten.radius, batten.length) == ("tube", 0.013, 1.2)
    panel = Scene.load(EXAMPLES / "panel.toml").lights[0]
    assert (panel.kind, panel.size, panel.position) == ("rect", (0.6, 0.6), (0.0, 0.0, 0.3))


# ----------------------------------------------------------------------------- USD
def _stage(tmp_path, build, name="s.usda") -> Path:
    path = tmp_path / name
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, 1.0)
    mesh = UsdGeom.Mesh.Define(stage, "/World/floor")
    mesh.CreatePointsAttr([Gf.Vec3f(x, y, 0) for x, y in ((-5, -5), (5, -5), (5, 5), (-5, 5))])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    build(stage)
    stage.GetRootLayer().Save()
    return path


def test_a_usd_rect_light_its_frame_size_and_intensity(tmp_path):
    def build(stage):
        x = UsdGeom.Xform.Define(stage, "/World/rig")
        x.AddTranslateOp().Set(Gf.Vec3d(1, 2, 3))
        x.AddRotateZOp().Set(90.0)  # the width (X) turns to +Y; -Z stays down
        x.AddScaleOp().Set(Gf.Vec3f(2, 1, 1))  # the width doubles
        light = UsdLux.RectLight.Define(stage, "/World/rig/panel")
        light.CreateWidthAttr(0.5)
        light.CreateHeightAttr(0.25)
        light.CreateIntensityAttr(10.0)
        light.CreateExposureAttr(1.0)
        light.CreateNormalizeAttr(True)

    im = load_mesh_scene(_stage(tmp_path, build), samples=16, notice=lambda m: None)
    (rect,) = im.scene.lights
    assert rect.kind == "rect" and rect.size == pytest.approx((1.0, 0.25))
    assert rect.position == pytest.approx((1.0, 2.0, 3.0))
    assert rect.tangent == pytest.approx((0.0, 1.0, 0.0), abs=1e-12)
    assert rect.normal == pytest.approx((0.0, 0.0, -1.0), abs=1e-12)
    # radiance 10 x 2^1 / (w h); I = radiance x w h (its intensity along the normal)
    assert rect.intensity == pytest.approx(20.0, rel=1e-12)


def test_a_usd_cylinder_light_is_a_tube_along_its_x_axis(tmp_path):
    def build(stage):
        x = UsdGeom.Xform.Define(stage, "/World/rig")
        x.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
        x.AddRotateYOp().Set(90.0)  # X turns to -Z: a vertical tube
        light = UsdLux.CylinderLight.Define(stage, "/World/rig/tube")
        light.CreateLengthAttr(1.2)
        light.CreateRadiusAttr(0.02)
        light.CreateIntensityAttr(3.0)

    im = load_mesh_scene(_stage(tmp_path, build), samples=16, notice=lambda m: None)
    (tube,) = im.scene.lights
    assert (tube.kind, tube.caps) == ("tube", False)
    assert (tube.length, tube.radius) == pytest.approx((1.2, 0.02), rel=1e-7)  # float attributes
    assert tube.axis == pytest.approx((0.0, 0.0, -1.0), abs=1e-12)
    # not normalised: radiance 3; attenfit's I = L pi r^2
    assert tube.intensity == pytest.approx(3.0 * math.pi * tube.radius**2, rel=1e-12)


def test_usd_rect_and_cylinder_lights_attenfit_does_not_model(tmp_path):
    def build(stage):
        cone = UsdLux.RectLight.Define(stage, "/World/cone")
        UsdLux.ShapingAPI.Apply(cone.GetPrim()).CreateShapingConeAngleAttr(40.0)
        cone.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
        oval = UsdLux.CylinderLight.Define(stage, "/World/oval")
        oval.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
        oval.AddScaleOp().Set(Gf.Vec3f(1, 1, 2))
        UsdLux.SphereLight.Define(stage, "/World/bulb").AddTranslateOp().Set(Gf.Vec3d(1, 0, 2))

    notes: list[str] = []
    path = _stage(tmp_path, build)
    im = load_mesh_scene(path, samples=16, notice=notes.append)
    assert im.names == ("/World/bulb",)
    assert notes == [
        "s.usda: RectLight /World/cone: shaping (cone angle 40 deg, focus 0) makes its "
        "emission other than Lambertian; attenfit models a rectangle or tube light as "
        "Lambertian (a cone of 90 deg or more and no focus); skipped",
        "s.usda: CylinderLight /World/oval: its transform scales Y and Z differently (1, 2 m): "
        "an elliptic cylinder, not a tube; skipped",
    ]
    with pytest.raises(BadValueError, match=r"RectLight /World/cone: .*; --strict refuses it"):
        load_mesh_scene(path, samples=16, notice=lambda m: None, strict=True)
