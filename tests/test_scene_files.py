"""USD and glTF scenes: lights under transformed and nested prims, spots, a light without a
radius, flipped normals, sampled receivers, the range trade, engines' properties and the
write-back. Files are built with usd-core and pygltflib; expected values are worked out by
hand (transforms, Blender's cone softness, the glTF range window) or by a dense scan."""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path

import numpy as np
import pytest

from attenfit import BadValueError, DataFileError
from attenfit.cli import main

pxr = pytest.importorskip("pxr")
pygltflib = pytest.importorskip("pygltflib")
from pxr import Gf, Usd, UsdGeom, UsdLux  # noqa: E402

from attenfit._scenes._files import load_mesh_scene  # noqa: E402
from attenfit._scenes._sample import Mesh, sample_receivers  # noqa: E402
from attenfit._scenes._types import SceneLight  # noqa: E402

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "scenes"


# ----------------------------------------------------------------------------- builders
def _floor(stage, path="/World/floor", half=5.0, flip=False, double=False, z=0.0):
    mesh = UsdGeom.Mesh.Define(stage, path)
    pts = [(-half, -half, z), (half, -half, z), (half, half, z), (-half, half, z)]
    mesh.CreatePointsAttr([Gf.Vec3f(*p) for p in pts])
    mesh.CreateFaceVertexCountsAttr([4])
    mesh.CreateFaceVertexIndicesAttr([0, 1, 2, 3])
    mesh.CreateNormalsAttr([Gf.Vec3f(0, 0, -1 if flip else 1)] * 4)
    mesh.SetNormalsInterpolation("vertex")
    mesh.CreateDoubleSidedAttr(double)
    return mesh


def _usd(tmp_path, build, name="scene.usda", mpu=1.0) -> Path:
    path = tmp_path / name
    stage = Usd.Stage.CreateNew(str(path))
    UsdGeom.SetStageMetersPerUnit(stage, mpu)
    build(stage)
    stage.GetRootLayer().Save()
    return path


def _quiet(*_a):
    return None


def _gltf(tmp_path, lights, light_nodes, name="scene.gltf", roots=None, half=5.0):
    """A glTF with a floor quad (2 triangles at z = 0, normals +Z) and lights (nodes 1...)."""
    G = pygltflib
    pos = np.array([[-half, -half, 0], [half, -half, 0], [half, half, 0], [-half, half, 0]], "<f4")
    nrm = np.tile(np.array([0, 0, 1], "<f4"), (4, 1))
    idx = np.array([0, 1, 2, 0, 2, 3], "<u2")
    blob = pos.tobytes() + nrm.tobytes() + idx.tobytes()
    gltf = G.GLTF2(
        asset=G.Asset(version="2.0"),
        scene=0,
        buffers=[
            G.Buffer(
                byteLength=len(blob),
                uri="data:application/octet-stream;base64," + base64.b64encode(blob).decode(),
            )
        ],
        bufferViews=[
            G.BufferView(buffer=0, byteOffset=0, byteLength=48),
            G.BufferView(buffer=0, byteOffset=48, byteLength=48),
            G.BufferView(buffer=0, byteOffset=96, byteLength=12),
        ],
        accessors=[
            G.Accessor(
                bufferView=0,
                componentType=5126,
                count=4,
                type="VEC3",
                min=[-half, -half, 0],
                max=[half, half, 0],
            ),
            G.Accessor(bufferView=1, componentType=5126, count=4, type="VEC3"),
            G.Accessor(bufferView=2, componentType=5123, count=6, type="SCALAR"),
        ],
        materials=[G.Material(doubleSided=False)],
        meshes=[
            G.Mesh(
                name="floor",
                primitives=[
                    G.Primitive(
                        attributes=G.Attributes(POSITION=0, NORMAL=1), indices=2, material=0
                    )
                ],
            )
        ],
        nodes=[G.Node(name="floor", mesh=0), *light_nodes],
        scenes=[G.Scene(nodes=[0, *(roots or range(1, 1 + len(light_nodes)))])],
        extensions={"KHR_lights_punctual": {"lights": lights}},
        extensionsUsed=["KHR_lights_punctual"],
    )
    path = tmp_path / name
    path.write_text(gltf.to_json(), encoding="utf-8")
    return path


def _light_node(name, light, **trs):
    return pygltflib.Node(name=name, extensions={"KHR_lights_punctual": {"light": light}}, **trs)


# ----------------------------------------------------------------------------- USD lights
def test_usd_nested_transforms_units_and_kinds(tmp_path):
    def build(stage):
        _floor(stage, half=500.0, double=True)  # cm; lit from below too
        g = UsdGeom.Xform.Define(stage, "/World/rig")
        g.AddTranslateOp().Set(Gf.Vec3d(100, 0, 0))
        g.AddRotateXOp().Set(90.0)
        g.AddScaleOp().Set(Gf.Vec3f(2, 2, 2))
        s = UsdLux.SphereLight.Define(stage, "/World/rig/bulb")
        s.AddTranslateOp().Set(Gf.Vec3d(0, -100, 0))
        s.CreateRadiusAttr(5.0)
        d = UsdLux.DiskLight.Define(stage, "/World/rig/disk")
        d.AddTranslateOp().Set(Gf.Vec3d(0, 100, 0))
        d.CreateRadiusAttr(10.0)

    path = _usd(tmp_path, build, mpu=0.01)
    im = load_mesh_scene(path, notice=_quiet, samples=64)
    bulb, disk = im.scene.lights
    # local (0, -100, 0) scaled by 2: (0, -200, 0); rotateX(90) maps y -> z: (0, 0, -200);
    # translate by (100, 0, 0): (100, 0, -200) cm = (1, 0, -2) m (below the double-sided
    # floor); the disk at local y = +100 lands at (1, 0, 2) m
    assert disk.position == pytest.approx((1.0, 0.0, 2.0), abs=1e-9)
    assert disk.radius == pytest.approx(10.0 * 2 * 0.01)
    # -Z local, rotated by 90 deg about X: (0, 0, -1) -> (0, 1, 0)
    assert disk.normal == pytest.approx((0.0, 1.0, 0.0), abs=1e-9)
    assert bulb.position == pytest.approx((1.0, 0.0, -2.0), abs=1e-9)
    assert bulb.kind == "sphere" and bulb.radius == pytest.approx(0.1)
    assert im.names == ("/World/rig/bulb", "/World/rig/disk")


def test_usd_spot_from_shaping_as_blender_writes_it(tmp_path):
    def build(stage):
        _floor(stage)
        s = UsdLux.SphereLight.Define(stage, "/World/spot")
        s.AddTranslateOp().Set(Gf.Vec3d(0, 0, 3))
        s.AddRotateXOp().Set(30.0)
        s.CreateRadiusAttr(0.05)
        sh = UsdLux.ShapingAPI.Apply(s.GetPrim())
        sh.CreateShapingConeAngleAttr(40.0)
        sh.CreateShapingConeSoftnessAttr(0.25)

    im = load_mesh_scene(_usd(tmp_path, build), notice=_quiet, samples=256)
    (spot,) = im.scene.lights
    assert spot.kind == "spot" and spot.profile == "threejs" and spot.umbra == 40.0
    # EEVEE spot_attenuation: smoothstep from cos 40 to cos 40 + (1 - cos 40) * 0.25
    c = math.cos(math.radians(40))
    assert math.cos(math.radians(spot.penumbra)) == pytest.approx(c + (1 - c) * 0.25)
    # -Z rotated 30 deg about X: (0, sin 30, -cos 30)
    assert spot.direction == pytest.approx((0.0, 0.5, -math.sqrt(3) / 2))
    # every receiver inside the cone, on the floor, facing up
    pts = im.scene.receivers[0].points
    to = pts - np.array(spot.position)
    cos_t = to @ np.array(spot.direction) / np.linalg.norm(to, axis=1)
    assert len(pts) == 256 and np.all(cos_t > c) and np.allclose(pts[:, 2], 0)


def test_usd_intensity_exposure_normalize(tmp_path):
    def build(stage):
        _floor(stage)
        for name, norm in (("a", False), ("b", True)):
            s = UsdLux.SphereLight.Define(stage, f"/World/{name}")
            s.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
            s.CreateRadiusAttr(0.2)
            s.CreateIntensityAttr(10.0)
            s.CreateExposureAttr(2.0)
            s.CreateNormalizeAttr(norm)

    a, b = load_mesh_scene(_usd(tmp_path, build), notice=_quiet, samples=16).scene.lights
    radiance = 10.0 * 2.0**2
    assert a.intensity == pytest.approx(radiance * math.pi * 0.2**2)
    assert b.intensity == pytest.approx(radiance / 4)  # / (4 pi r^2) * pi r^2


def test_usd_refusals_name_the_prim(tmp_path):
    def nonuniform(stage):
        _floor(stage)
        g = UsdGeom.Xform.Define(stage, "/World/squash")
        g.AddScaleOp().Set(Gf.Vec3f(1, 2, 1))
        UsdLux.SphereLight.Define(stage, "/World/squash/bulb").AddTranslateOp().Set(
            Gf.Vec3d(0, 0, 2)
        )

    with pytest.raises(BadValueError, match=r"SphereLight /World/squash/bulb: non-uniform scale"):
        load_mesh_scene(_usd(tmp_path, nonuniform, "a.usda"), notice=_quiet)

    def dome(stage):
        _floor(stage)
        UsdLux.SphereLight.Define(stage, "/World/bulb").AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
        UsdLux.DomeLight.Define(stage, "/World/sky")

    notes: list[str] = []
    im = load_mesh_scene(_usd(tmp_path, dome, "b.usda"), notice=notes.append, samples=16)
    assert im.names == ("/World/bulb",)
    assert notes == [
        "b.usda: DomeLight /World/sky: not modelled (attenfit takes sphere, disk, spot, rect "
        "and cylinder lights); skipped"
    ]
    with pytest.raises(BadValueError, match=r"DomeLight /World/sky: .*--strict refuses it"):
        load_mesh_scene(tmp_path / "b.usda", notice=_quiet, strict=True)

    def point(stage):
        _floor(stage)
        s = UsdLux.SphereLight.Define(stage, "/World/pt")
        s.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
        s.CreateTreatAsPointAttr(True)

    with pytest.raises(BadValueError) as exc:
        load_mesh_scene(_usd(tmp_path, point, "c.usda"), notice=_quiet)
    assert str(exc.value) == (
        "c.usda: SphereLight /World/pt: treatAsPoint has no radius; give one with --radius R "
        "(m) or a side file with [lights.'/World/pt'] radius = R"
    )
    assert (
        load_mesh_scene(tmp_path / "c.usda", radius=0.03, samples=16).scene.lights[0].radius == 0.03
    )

    def degenerate(stage):
        m = UsdGeom.Mesh.Define(stage, "/World/flat")
        m.CreatePointsAttr([Gf.Vec3f(0, 0, 0), Gf.Vec3f(1, 0, 0), Gf.Vec3f(2, 0, 0)])
        m.CreateFaceVertexCountsAttr([3])
        m.CreateFaceVertexIndicesAttr([0, 1, 2])
        UsdLux.SphereLight.Define(stage, "/World/bulb").AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))

    with pytest.raises(BadValueError, match=r"mesh '/World/flat': degenerate"):
        load_mesh_scene(_usd(tmp_path, degenerate, "d.usda"), notice=_quiet)
    with pytest.raises(DataFileError, match=r"scene file .missing\.usda. does not exist"):
        load_mesh_scene(tmp_path / "missing.usda")


def test_flipped_normals_reach_nothing_unless_double_sided(tmp_path):
    def build(double):
        def f(stage):
            _floor(stage, flip=True, double=double)
            UsdLux.SphereLight.Define(stage, "/World/bulb").AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))

        return f

    with pytest.raises(BadValueError) as exc:
        load_mesh_scene(_usd(tmp_path, build(False), "one.usda"), notice=_quiet)
    assert str(exc.value) == (
        "one.usda: light /World/bulb: reaches no mesh face (none within its range, in front "
        "of it and facing it)"
    )
    im = load_mesh_scene(_usd(tmp_path, build(True), "two.usda"), notice=_quiet, samples=64)
    assert np.allclose(im.scene.receivers[0].normals, [0, 0, 1])  # turned toward the light


# ----------------------------------------------------------------------------- glTF lights
def test_gltf_nested_nodes_spot_and_radius(tmp_path):
    lights = [
        {"type": "point", "name": "bulb", "intensity": 20.0, "range": 6.0},
        {"type": "spot", "name": "cone", "intensity": 50.0,
         "spot": {"innerConeAngle": 0.3, "outerConeAngle": 0.6}},
    ]  # fmt: skip
    q = math.sqrt(0.5)  # a quarter turn about Z
    nodes = [
        pygltflib.Node(name="rig", translation=[1.0, 2.0, 0.0], children=[2, 3], scale=[2, 2, 2]),
        _light_node("bulbNode", 0, translation=[0.0, 0.0, 1.5]),
        _light_node("coneNode", 1, translation=[0.0, 0.0, 2.0], rotation=[0.0, 0.0, q, q]),
    ]
    path = _gltf(tmp_path, lights, nodes, roots=[1])
    with pytest.raises(BadValueError) as exc:
        load_mesh_scene(path)
    assert str(exc.value) == (
        "scene.gltf: light 'bulb' (node 'bulbNode'): glTF lights have no radius; give one "
        "with --radius R (m) or a side file (--side) with [lights.'bulb'] radius = R"
    )
    side = tmp_path / "side.toml"
    side.write_text('radius = 0.05\nsamples = 128\n[lights."cone"]\nradius = 0.02\n')
    im = load_mesh_scene(path, side=side)
    bulb, cone = im.scene.lights
    # rig: scale 2 then translate (1, 2, 0): child (0, 0, 1.5) -> (1, 2, 3)
    assert bulb.position == pytest.approx((1.0, 2.0, 3.0))
    assert (bulb.radius, bulb.range, bulb.intensity) == (0.05, 6.0, 20.0)
    assert cone.radius == 0.02 and cone.profile == "frostbite"
    assert (cone.umbra, cone.penumbra) == pytest.approx((math.degrees(0.6), math.degrees(0.3)))
    # a 90 deg turn about Z keeps -Z: the spot points straight down
    assert cone.direction == pytest.approx((0.0, 0.0, -1.0), abs=1e-12)
    assert im.published_ranges == (6.0, None)
    d = np.linalg.norm(im.scene.receivers[0].points - np.array(bulb.position), axis=1)
    assert d.max() <= 6.0  # within its range


# ----------------------------------------------------------------------------- sampling
def test_sampling_is_by_area_with_interpolated_normals():
    tri = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], float)
    small = Mesh("small", tri[None], np.tile([0, 0, 1.0], (1, 3, 1)))
    big = Mesh("big", (3 * tri + [5, 0, 0])[None], np.array([[[0, 0, 1.0], [1, 0, 1], [0, 1, 1]]]))
    light = SceneLight(kind="sphere", radius=0.1, position=(3.0, 0.0, 50.0))
    pts, nrm, _ = sample_receivers(light, [small, big], 20000, np.random.default_rng(1))
    on_big = pts[:, 0] >= 5
    # areas 0.5 and 4.5: 10% of the points on the small triangle (binomial sd 0.2%)
    assert abs(1 - on_big.mean() - 0.1) < 0.01
    assert np.allclose(np.linalg.norm(nrm, axis=1), 1)
    # barycentric interpolation on the big triangle: n ~ (0,0,1) + u (1,0,0) + v (0,1,0)
    p = (pts[on_big] - [5, 0, 0]) / 3
    expect = np.stack([p[:, 0], p[:, 1], np.ones(len(p))], axis=1)
    expect /= np.linalg.norm(expect, axis=1, keepdims=True)
    assert np.allclose(nrm[on_big], expect)


def test_exact_irradiance_of_a_sphere_at_sampled_receivers(tmp_path):
    """A sphere entirely above a receiver's horizon gives exactly I cos(theta) / d^2."""

    def build(stage):
        _floor(stage, half=2.0)
        s = UsdLux.SphereLight.Define(stage, "/World/bulb")
        s.AddTranslateOp().Set(Gf.Vec3d(0.3, -0.2, 3.0))
        s.CreateRadiusAttr(0.25)

    im = load_mesh_scene(_usd(tmp_path, build), notice=_quiet, samples=300)
    (truth,) = im.scene.ground_truth()
    light = im.scene.lights[0]
    p = np.asarray(truth.dataset.points, float)
    to = np.array(light.position) - p
    d = np.linalg.norm(to, axis=1)
    expect = light.intensity * to[:, 2] / d**3  # floor normals (0, 0, 1)
    assert np.allclose(np.asarray(truth.dataset.E, float), expect, rtol=1e-9)


# ----------------------------------------------------------------------------- answers
def _run(capsys, *argv):
    code = main(["scene", *map(str, argv)])
    out = capsys.readouterr()
    return code, out.out, out.err


def test_gltf_range_trade_against_a_dense_scan_and_write_back(tmp_path, capsys):
    lights = [{"type": "point", "name": "bulb", "intensity": 10.0}]
    path = _gltf(tmp_path, lights, [_light_node("bulbNode", 0, translation=[0.0, 0.0, 1.0])])
    before = path.read_bytes()
    out = tmp_path / "out.gltf"
    argv = (path, "--engine", "gltf", "--radius", 0.05, "--samples", 512, "--threshold", 1.0,
            "--tolerance", 0.05, "--json", "--write-back", out, "--out", tmp_path / "ans")  # fmt: skip
    code, text, _ = _run(capsys, *argv)
    assert code == 0
    assert json.loads((tmp_path / "ans" / "answer.json").read_text()) == json.loads(text)
    assert (tmp_path / "ans" / "all-lights" / "attenfit_gltf_range.glsl").is_file()
    assert (tmp_path / "ans" / "lights.png").stat().st_size > 1000
    (ans,) = json.loads(text)["lights"]
    R = ans["range"]["range"]
    assert ans["family"] == "gltf_range" and ans["properties"] == {"range": R}
    # independent: the true irradiance of the sphere (fully above the floor's horizon) and
    # the KHR_lights_punctual window, scanned densely for the smallest passing range
    im = load_mesh_scene(path, radius=0.05, samples=512, notice=_quiet)
    p = im.scene.receivers[0].points
    to = np.array([0, 0, 1.0]) - p
    d = np.linalg.norm(to, axis=1)
    E = 10.0 * to[:, 2] / d**3
    vis = E > 1.0
    scan = np.geomspace(d[vis].max(), 16 * d[vis].max(), 4000)
    err = [np.max(np.abs(np.clip(1 - (d[vis] / r) ** 4, 0, 1) - 1)) for r in scan]
    r_min = scan[np.argmax(np.array(err) <= 0.05)]
    assert r_min <= R <= r_min * 1.014
    assert ans["checked_error"] <= 0.05
    assert ans["range"]["volume_saved"] == 1.0  # glTF: no range is an infinite one
    # the write-back: the range and the answer in extras; the input untouched
    assert path.read_bytes() == before
    written = json.loads(out.read_text())
    light = written["extensions"]["KHR_lights_punctual"]["lights"][0]
    assert light["range"] == pytest.approx(R)
    assert light["extras"]["attenfit"][0]["family"] == "gltf_range"
    assert load_mesh_scene(out, radius=0.05, samples=16).published_ranges == (pytest.approx(R),)
    code, _, err = _run(capsys, *argv)
    assert code == 2 and "exists" in err and err.count("\n") == 1


def test_usd_engine_properties_and_write_back(tmp_path, capsys):
    def build(stage):
        _floor(stage)
        s = UsdLux.SphereLight.Define(stage, "/World/spot")
        s.AddTranslateOp().Set(Gf.Vec3d(0, 0, 2))
        s.CreateRadiusAttr(0.05)
        sh = UsdLux.ShapingAPI.Apply(s.GetPrim())
        sh.CreateShapingConeAngleAttr(30.0)
        sh.CreateShapingConeSoftnessAttr(0.2)

    path = _usd(tmp_path, build)
    out = tmp_path / "out.usda"
    code, text, _ = _run(capsys, path, "--engine", "threejs", "--samples", 256, "--json",
                         "--write-back", out)  # fmt: skip
    assert code == 0
    (ans,) = json.loads(text)["lights"]
    props, p, spot = ans["properties"], ans["params"], ans["spot"]
    # three.js: decay and distance; SpotLight penumbraCos = cos(angle (1 - penumbra))
    assert props["decay"] == p["decay"] and props["distance"] == p["cutoff"]
    assert props["angle"] == pytest.approx(math.radians(spot["umbra"]))
    assert math.cos(props["angle"] * (1 - props["penumbra"])) == pytest.approx(
        math.cos(math.radians(spot["penumbra"]))
    )
    stage = Usd.Stage.Open(str(out))
    prim = stage.GetPrimAtPath("/World/spot")
    assert prim.GetAttribute("attenfit:family").Get() == "threejs"
    assert prim.GetAttribute("attenfit:threejs:decay").Get() == pytest.approx(props["decay"])
    source = Usd.Stage.Open(str(path))
    assert not source.GetPrimAtPath("/World/spot").GetAttribute("attenfit:family").IsValid()


def test_file_options_refused_for_toml(capsys):
    code, _, err = _run(capsys, EXAMPLE / "room.toml", "--radius", 0.1)
    assert code == 2
    assert "--radius applies to USD and glTF scenes" in err


def test_engine_restricts_a_toml_scene(capsys):
    code, text, _ = _run(capsys, EXAMPLE / "room.toml", "--engine", "unity", "--json")
    assert code == 0
    rec = json.loads(text)["recommendation"]  # a per-light engine answer (`answer_scene`)
    assert [c["family"] for c in rec["candidates"]] == ["frostbite_window"]
    # Unity URP clamps d^2 at HALF_MIN = 2^-14: r_min = 2^-7 m, fixed, not fitted
    assert all(p["r_min"] == 2.0**-7 for p in rec["candidates"][0]["params"])


def test_side_file_names_must_be_lights(tmp_path):
    lights = [{"type": "point", "name": "bulb", "intensity": 10.0}]
    path = _gltf(tmp_path, lights, [_light_node("bulbNode", 0, translation=[0.0, 0.0, 1.0])])
    side = tmp_path / "side.toml"
    side.write_text('radius = 0.1\n[lights."blub"]\nradius = 0.2\n')
    with pytest.raises(Exception) as exc:
        load_mesh_scene(path, side=side)
    assert str(exc.value) == (
        "side.toml: lights.'blub': no light of scene.gltf has that name; its lights: bulb"
    )


def test_engine_properties_in_the_engines_units():
    from attenfit.scene import ENGINES

    spot = SceneLight(kind="spot", radius=0.05, position=(0.0, 0.0, 3.0), umbra=30.0, penumbra=20.0)
    angles = {"umbra": 30.0, "penumbra": 20.0}
    # Unreal lengths are centimetres (UPointLightComponent AttenuationRadius); SourceRadius
    # starts at 0 (it wraps the diffuse term: the engine fit tries 0 and 100 x the radius)
    u = ENGINES["unreal"].properties("unreal_window", {"eps": 1e-4, "r_max": 7.5}, spot, angles)
    assert (u["AttenuationRadius"], u["SourceRadius"]) == (750.0, 0.0)
    assert ENGINES["unreal"].size_unit * spot.radius == 5.0
    assert u["bUseInverseSquaredFalloff"] is True
    # Unity Light.spotAngle / innerSpotAngle are full cone angles in degrees
    un = ENGINES["unity"].properties(
        "frostbite_window", {"r_min": 0.0078125, "r_max": 4.0}, spot, angles
    )
    assert (un["range"], un["spotAngle"], un["innerSpotAngle"]) == (4.0, 60.0, 40.0)
    # Godot: a spot's distance falloff is spot_attenuation / spot_range
    g = ENGINES["godot"].properties("godot", {"a": 2.0, "r_max": 6.0}, spot, angles)
    assert (g["spot_attenuation"], g["spot_range"], g["spot_angle"]) == (2.0, 6.0, 30.0)
    # glTF cone angles are half-angles in radians
    gl = ENGINES["gltf"].properties("gltf_range", {"range": 5.0}, spot, angles)
    assert gl["outerConeAngle"] == pytest.approx(math.pi / 6)


def test_gltf_directional_skipped_and_squashed_light_refused(tmp_path):
    lights = [{"type": "directional", "name": "sun"}, {"type": "point", "name": "bulb"}]
    nodes = [
        _light_node("sunNode", 0),
        _light_node("bulbNode", 1, translation=[0.0, 0.0, 1.0], scale=[1.0, 3.0, 1.0]),
    ]
    path = _gltf(tmp_path, lights, nodes)
    notes: list[str] = []
    with pytest.raises(BadValueError) as exc:
        load_mesh_scene(path, radius=0.1, notice=notes.append)
    assert notes == [
        "scene.gltf: light 'sun' (node 'sunNode'): type 'directional' has no distance falloff "
        "to fit; skipped"
    ]
    assert str(exc.value) == (
        "scene.gltf: light 'bulb' (node 'bulbNode'): non-uniform scale (1.0, 3.0, 1.0) on a "
        "light's node"
    )


def test_the_blender_example_reads_as_blender_wrote_it():
    """examples/scenes/blender: Blender 4.2's own USD and glTF exports of one room."""
    room = EXAMPLE / "blender"
    im = load_mesh_scene(room / "room.usda", samples=32, notice=_quiet)
    assert im.names == (
        "/root/Rig/Bulb/Bulb",
        "/root/Spot/Spot",
        "/root/Panel/Panel",
        "/root/Strip/Strip",
    )
    bulb, spot, panel, strip = im.scene.lights
    # the bulb hangs 0.6 m under a rig at (-1, -0.5, 2) turned 30 deg about Z
    assert bulb.position == pytest.approx((-1.0, -0.5, 2.6), abs=1e-6)
    # Blender: 60 W point light -> 60 / (4 pi) W/sr; 150 W disk -> 150 / pi W/sr on axis
    assert bulb.intensity == pytest.approx(60 / (4 * math.pi), rel=1e-6)
    assert panel.intensity == pytest.approx(150 / math.pi, rel=1e-6)
    # spot_size 60 deg, blend 0.3; tilted -25 deg about X
    assert spot.umbra == pytest.approx(30.0)
    c = math.cos(math.radians(30))
    assert math.cos(math.radians(spot.penumbra)) == pytest.approx(c + 0.3 * (1 - c), rel=1e-6)
    t = math.radians(-25)
    assert spot.direction == pytest.approx((0.0, math.sin(t), -math.cos(t)), abs=1e-6)
    # the 1 m x 0.1 m, 40 W rectangle at (2.5, 3.5, 3), facing down: Blender writes energy / pi
    # with normalize = 1, so the radiance is 40 / (pi w h) and I = L w h = 40 / pi on its axis
    assert (strip.kind, strip.size) == ("rect", pytest.approx((1.0, 0.1)))
    assert strip.position == pytest.approx((2.5, 3.5, 3.0), abs=1e-6)
    assert strip.normal == pytest.approx((0.0, 0.0, -1.0), abs=1e-6)
    assert strip.tangent == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)
    assert strip.intensity == pytest.approx(40 / math.pi, rel=1e-6)
    assert im.notices == ()
    # the glTF export: Y up (Blender's (x, y, z) is glTF's (x, z, -y)), intensity in candela
    gl = load_mesh_scene(room / "room.glb", side=room / "room.side.toml", samples=32)
    gbulb, gspot = gl.scene.lights
    assert gbulb.position == pytest.approx((-1.0, 2.6, 0.5), abs=1e-6)
    assert gbulb.intensity == pytest.approx(60 * 683 / (4 * math.pi), rel=1e-6)
    assert (gbulb.radius, gspot.radius) == (0.08, 0.05)


def test_files_that_are_not_scenes(tmp_path, capsys):
    (tmp_path / "bad.usda").write_text("hello")
    (tmp_path / "bad.glb").write_bytes(b"glTFxxxx")
    code, _, err = _run(capsys, tmp_path / "bad.usda")
    assert code == 2
    assert err == (
        "attenfit: error: bad.usda: not a USD file usd-core can open (<"
        + str(tmp_path / "bad.usda")
        + "> is not a valid usda layer)\n"
    )
    code, _, err = _run(capsys, tmp_path / "bad.glb", "--radius", 0.1)
    assert code == 2 and err.startswith("attenfit: error: bad.glb: not a glTF 2.0 file")
    assert err.count("\n") == 1
