"""Public USD and glTF files nobody here wrote (tests/data/public, sources and licences in
LICENSES.md), answered end to end (`attenfit scene FILE`), each light checked against a
reading of the file made here: usd-core's own attribute values and `UsdGeom.XformCache`
(at the time the test names), or the glTF JSON, turned into metres and point-equivalent
intensity by the UsdLux formulas (radiance = intensity x 2^exposure, over the area with
normalize; point-equivalent = radiance x pi r^2) and the KHR_lights_punctual README
(intensity in candela, spot angles in radians; a node's -Z rotated by its quaternion). The
radiance is also multiplied by `inputs:diffuse` (UsdLux LightAPI, default 1: "A multiplier
for the effect of this light on the diffuse response of materials").

The end-to-end answers of the larger files are `slow`; every file's lights are read and
checked in the fast suite."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from attenfit.cli import main

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom  # noqa: E402

from attenfit._scenes._files import load_mesh_scene  # noqa: E402
from attenfit._scenes._gltf import read_gltf  # noqa: E402
from attenfit._scenes._usd import read_usd  # noqa: E402

DATA = Path(__file__).parent / "data" / "public"
FAST = ("--samples", "16", "--engine", "gltf", "--json")


def _hand(path: Path, prim: str, time=None, radius=None):
    """(centre m, radius m, point-equivalent intensity, -Z axis) of a USD sphere light, read
    with usd-core: every attribute as authored (the names the file uses), at `time`."""
    time = Usd.TimeCode.Default() if time is None else time
    stage = Usd.Stage.Open(str(path))
    p = stage.GetPrimAtPath(prim)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(p))

    def get(*names, default):
        for n in names:
            a = p.GetAttribute(n)
            if a and a.HasAuthoredValue():
                return a.Get(time)
        return default

    scale = float(np.linalg.norm(m[0, :3])) * mpu
    r = radius if radius is not None else get("inputs:radius", "radius", default=0.5) * scale
    radiance = get("inputs:intensity", "intensity", default=1.0) * 2.0 ** get(
        "inputs:exposure", "exposure", default=0.0
    )
    radiance *= get("inputs:diffuse", "diffuse", default=1.0)
    if get("inputs:normalize", "normalize", default=False):
        radiance /= 4 * math.pi * r**2
    axis = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
    return m[3, :3] * mpu, r, radiance * math.pi * r**2, axis / np.linalg.norm(axis)


def _hand_rect(path: Path, prim: str, time=None):
    """(centre m, (width, height) m, point-equivalent intensity, normal) of a USD RectLight,
    read with usd-core: UsdLux's default 1 x 1 size times the world scale, in metres;
    point-equivalent = radiance x area (radiance = intensity x 2^exposure x diffuse, over
    the area with normalize); it emits along its -Z."""
    time = Usd.TimeCode.Default() if time is None else time
    stage = Usd.Stage.Open(str(path))
    p = stage.GetPrimAtPath(prim)
    mpu = UsdGeom.GetStageMetersPerUnit(stage)
    m = np.array(UsdGeom.XformCache(time).GetLocalToWorldTransform(p))

    def get(name, default):
        a = p.GetAttribute(name)
        return a.Get(time) if a and a.HasAuthoredValue() else default

    w = get("inputs:width", 1.0) * float(np.linalg.norm(m[0, :3])) * mpu
    h = get("inputs:height", 1.0) * float(np.linalg.norm(m[1, :3])) * mpu
    radiance = get("inputs:intensity", 1.0) * 2.0 ** get("inputs:exposure", 0.0)
    radiance *= get("inputs:diffuse", 1.0)
    if get("inputs:normalize", False):
        radiance /= w * h
    normal = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
    return m[3, :3] * mpu, (w, h), radiance * w * h, normal / np.linalg.norm(normal)


def _check_rect(light, hand):
    centre, size, intensity, normal = hand
    assert light.kind == "rect"
    assert light.position == pytest.approx(tuple(centre), rel=1e-9, abs=1e-12)
    assert light.size == pytest.approx(size, rel=1e-6)  # float inputs
    assert light.intensity == pytest.approx(intensity, rel=1e-6)
    assert light.normal == pytest.approx(tuple(normal), abs=1e-9)


def _usd_lights(path: Path, **kw):
    """attenfit's reading of a USD file's lights, meshes or none: {prim path: SceneLight}."""
    lights, _ = read_usd(path, path.name, radius_for=lambda n: kw.get("radius"), strict=False,
                         notice=kw.get("notice", lambda m: None), time=kw.get("time"))  # fmt: skip
    return {x.name: x.light for x in lights}


def _quat_rotate(q, v):
    """`v` rotated by the unit quaternion q = (x, y, z, w) (glTF 2.0 spec, node.rotation)."""
    x, y, z, w = q
    u = np.array([x, y, z])
    v = np.asarray(v, float)
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def _gltf_hand(path: Path) -> dict:
    """{light name: (position, direction, candela, range, inner, outer)} read from the
    glTF JSON here: root nodes only (these files' lights have no parents), a spot's
    direction the node's -Z, cone angles in radians, intensity default 1 (KHR_lights_punctual
    README.md)."""
    doc = json.loads(path.read_text())
    lights = doc["extensions"]["KHR_lights_punctual"]["lights"]
    out = {}
    for node in doc["nodes"]:
        k = node.get("extensions", {}).get("KHR_lights_punctual", {}).get("light")
        if k is None:
            continue
        d = lights[k]
        spot = d.get("spot", {})
        out[d.get("name", f"lights[{k}]")] = (
            np.array(node.get("translation", [0.0, 0.0, 0.0]), float),
            _quat_rotate(node.get("rotation", [0.0, 0.0, 0.0, 1.0]), [0.0, 0.0, -1.0]),
            d.get("intensity", 1.0),
            d.get("range"),
            spot.get("innerConeAngle", 0.0) if d["type"] == "spot" else None,
            spot.get("outerConeAngle", math.pi / 4) if d["type"] == "spot" else None,
        )
    return out


def _answer(capsys, *argv) -> tuple[int, dict | None, str]:
    code = main(["scene", *map(str, argv), *FAST])
    out = capsys.readouterr()
    return code, (json.loads(out.out) if code == 0 else None), out.err


def _check(im, name, hand, rel=1e-9):
    centre, r, intensity, _ = hand
    light = im.scene.lights[im.names.index(name)]
    assert light.position == pytest.approx(tuple(centre), rel=rel, abs=1e-12)
    assert light.radius == pytest.approx(r, rel=rel)
    assert light.intensity == pytest.approx(intensity, rel=1e-6)  # float inputs
    return light


def test_usd_wg_environment_three_sphere_lights_on_a_centimetre_stage(capsys):
    """Pivot xformOps (an inverted one), centimetres, declared-but-unset focus and IES."""
    path = DATA / "usd-wg-environment" / "Environment.usda"
    im = load_mesh_scene(path, samples=16, notice=lambda m: None)
    names = [f"/Environment/Lights/SphereLight{s}" for s in ("", "_01", "_02")]
    assert im.names == tuple(names)
    for n in names:
        light = _check(im, n, _hand(path, n))
        assert light.kind == "sphere"  # cone angle 180: no cone
    code, ans, err = _answer(capsys, path)
    assert code == 0, err
    assert [x["name"] for x in ans["lights"]] == names
    assert all(x["status"] in ("pass", "fail") for x in ans["lights"])


def test_openusd_torch_old_names_and_a_mesh_of_time_samples(capsys):
    """Pre-2021 names (`float radius`, `float exposure`) read with a notice; the mesh is
    authored only as time samples (at 1), read at the start time code."""
    path = DATA / "openusd-torch" / "torch.usda"
    notes: list[str] = []
    im = load_mesh_scene(path, samples=16, notice=notes.append)
    _check(im, "/Mesh/light", _hand(path, "/Mesh/light"))
    assert any("pre-2021" in n and "radius" in n and "exposure" in n for n in notes), notes
    code, ans, err = _answer(capsys, path)
    assert code == 0, err
    assert "pre-2021" in err and ans["lights"][0]["name"] == "/Mesh/light"


def test_openusd_light_visibility_follows_time(capsys):
    """`visibility` time samples: visible at the default time, invisible from time 5."""
    path = DATA / "openusd-light-visibility" / "testVarying.usda"
    im = load_mesh_scene(path, samples=16, notice=lambda m: None)
    _check(im, "/lights/light", _hand(path, "/lights/light"))
    code, _, err = _answer(capsys, path)
    assert code == 0, err
    code, _, err = _answer(capsys, path, "--time", "5")
    assert code == 2 and "/lights/light: invisible; skipped" in err
    assert err.strip().splitlines()[-1].startswith("attenfit: error: ")


def test_maya_usd_lights_read_at_the_start_time_code(capsys):
    """maya-usd's light-import test: the spot's cone, softness and translation are authored
    only as time samples (at 1, the start time code): 25 degrees at (10, 7, -8) cm. The
    published file has no mesh and a spot of diffuse 0 (it lights no diffuse surface:
    skipped with a notice) and focus 8; the answerable layer beside it adds a floor and sets
    focus 0 and diffuse 1 (LICENSES.md)."""
    public = DATA / "maya-usd-lights" / "LightsTest.usda"
    code, _, err = _answer(capsys, public, "--radius", "0.05")
    assert code == 2 and "no mesh to sample receivers on" in err
    assert "/LightsTest/spotLight1: inputs:diffuse 0: the light does not reach diffuse" in err
    path = DATA / "maya-usd-lights" / "LightsTest.answerable.usda"
    for time, argv in ((Usd.TimeCode(1), ()), (Usd.TimeCode(3), ("--time", "3"))):
        im = load_mesh_scene(
            path, samples=16, radius=0.05, time=None if not argv else 3, notice=lambda m: None
        )
        spot = _check(im, "/LightsTest/spotLight1", hand := _hand(path, "/LightsTest/spotLight1", time, 0.05))  # fmt: skip
        assert spot.kind == "spot" and spot.umbra == pytest.approx(25.0)
        cu = math.cos(math.radians(25.0))  # Blender's softness reading (docs/usd-gltf.md)
        assert spot.penumbra == pytest.approx(math.degrees(math.acos(cu + (1 - cu) * 0.4)))
        assert spot.direction == pytest.approx(tuple(hand[3]))
        _check(im, "/LightsTest/pointLight1", _hand(path, "/LightsTest/pointLight1", time, 0.05))  # fmt: skip
        code, ans, err = _answer(capsys, path, "--radius", "0.05", *argv)
        assert code == 0, err
        assert [x["name"] for x in ans["lights"]] == [
            "/LightsTest/pointLight1",
            "/LightsTest/spotLight1",
            "/LightsTest/areaLight1",
            "/LightsTest/NonMaterialsScope/NonRootRectLight",
        ]
        # the RectLights: UsdLux's default 1 x 1 width and height, times the time-sampled
        # scale (4, 3, 2), in centimetres (metersPerUnit 0.01); translate (8, 0, 10) cm
        rect = dict(zip(im.names, im.scene.lights, strict=True))["/LightsTest/areaLight1"]
        assert rect.kind == "rect" and rect.size == pytest.approx((0.04, 0.03))
        assert rect.position == pytest.approx((0.08, 0.0, 0.10))
    assert spot.position == pytest.approx((0.075, 0.05, 0.0), abs=1e-12)  # at time 3


def test_khronos_validator_spot_is_read_and_the_meshless_file_refused(capsys):
    path = DATA / "gltf-validator-lights" / "valid_full.gltf"
    d = json.loads(path.read_text())["extensions"]["KHR_lights_punctual"]["lights"][0]
    lights, meshes = read_gltf(
        path, path.name, radius_for=lambda n: 0.01, strict=False, notice=lambda m: None
    )
    (x,) = lights
    assert meshes == []
    assert x.published_range == d["range"]
    assert x.light.intensity == pytest.approx(d["intensity"])  # candela
    assert x.light.umbra == pytest.approx(math.degrees(d["spot"]["outerConeAngle"]))
    assert x.light.penumbra == pytest.approx(math.degrees(d["spot"]["innerConeAngle"]))
    assert x.light.direction == pytest.approx((0.0, 0.0, -1.0))  # the node's local -Z
    code, _, err = _answer(capsys, path, "--radius", "0.01")
    assert code == 2 and "no mesh to sample receivers on" in err and err.count("\n") == 1


def _answered(capsys, path: Path, names, *argv):
    """`attenfit scene path` answers exactly the lights `names`, each pass or fail with the
    engine-rendered error it reports."""
    code, ans, err = _answer(capsys, path, *argv)
    assert code == 0, err
    assert [x["name"] for x in ans["lights"]] == list(names)
    for x in ans["lights"]:
        assert x["status"] in ("pass", "fail") and x["engine_error"] is not None, x
    return ans, err


def test_maya_usd_rfm_lights_skip_the_textured_rect(capsys):
    """RenderMan-for-Maya lights on a centimetre stage: the textured RectLight is skipped
    with a notice (its emission varies over it), the DistantLight too; the SphereLight has
    the ShapingAPI with no cone authored (UsdLux's default 90 degrees: a hemisphere spot),
    normalize on, exposure 0.7, diffuse 1.7 (a factor on its intensity: 1.7 x 1.7 x 2^0.7 /
    (4 pi r^2) x pi r^2 = 1.7^2 2^0.7 / 4); the empty RectLight keeps every default."""
    path = DATA / "maya-usd-rfm-lights" / "RfMLightsTest.usda"
    notes: list[str] = []
    got = _usd_lights(path, notice=notes.append)
    sphere, rect = "/RfMLightsTest/Lights/SphereLight", "/RfMLightsTest/NonMaterialsScope/NonRootRectLight"  # fmt: skip
    assert list(got) == [sphere, rect]
    assert any("/Lights/RectLight: texture:file './RectLight_texture.tex'" in n for n in notes)
    assert any("DistantLight" in n and "skipped" in n for n in notes)
    centre, r, intensity, axis = _hand(path, sphere)
    s = got[sphere]
    assert s.kind == "spot" and s.umbra == pytest.approx(90.0)
    assert s.position == pytest.approx(tuple(centre)) and s.radius == pytest.approx(r)
    assert s.intensity == pytest.approx(intensity, rel=1e-6)
    assert s.intensity == pytest.approx(1.7**2 * 2**0.7 / 4, rel=1e-6)  # float inputs
    assert s.direction == pytest.approx(tuple(axis))
    _check_rect(got[rect], _hand_rect(path, rect))
    _answered(capsys, path, [sphere, rect])
    code, _, err = _answer(capsys, path, "--strict")
    assert code == 2 and "DistantLight" in err and "--strict refuses it" in err


def test_maya_usd_simple_light_refuses_the_squashed_disk(capsys):
    """Every UsdLux type with maya's defaults: the spot's focus 0.5 is skipped with a
    notice, and the DiskLight scaled (1, 0, 1) is refused by name (no radius to read)."""
    path = DATA / "maya-usd-simple-light" / "SimpleLight.usda"
    code, _, err = _answer(capsys, path, "--radius", "0.05")
    assert code == 2
    assert "/lights/spotLight: shaping:focus 0.5 is not modelled" in err
    last = err.strip().splitlines()[-1]
    assert "DiskLight /lights/diskLight: non-uniform scale (1.0, 0.0, 1.0)" in last


def test_maya_usd_spot_cone_authored_without_the_shaping_api(tmp_path):
    """maya-usd writes the spot's `inputs:shaping:cone:angle` 50 and softness 0.1 without
    applying the ShapingAPI; usdImaging reads authored inputs whatever the applied schemas
    (`UsdImagingPrimAdapter::GetLightParamValue`), so this is a 50 degree spot. Read from
    the public file with its disk unsquashed and its focus 0 (else skipped, as above)."""
    text = (DATA / "maya-usd-simple-light" / "SimpleLight.usda").read_text()
    text = text.replace("float3 xformOp:scale = (1, 0, 1)", "float3 xformOp:scale = (1, 1, 1)")
    text = text.replace("float inputs:shaping:focus = 0.5", "float inputs:shaping:focus = 0")
    path = tmp_path / "SimpleLight.usda"
    path.write_text(text)
    got = _usd_lights(path, radius=0.05)
    spot = got["/lights/spotLight"]
    assert spot.kind == "spot" and spot.umbra == pytest.approx(50.0)
    cu = math.cos(math.radians(50.0))  # Blender's softness reading (docs/usd-gltf.md)
    assert spot.penumbra == pytest.approx(math.degrees(math.acos(cu + (1 - cu) * 0.1)))
    centre, r, intensity, axis = _hand(path, "/lights/spotLight")
    assert spot.position == pytest.approx(tuple(centre)) and spot.radius == pytest.approx(r)
    assert spot.intensity == pytest.approx(intensity) and spot.direction == pytest.approx(
        tuple(axis)
    )
    assert got["/lights/pointLight"].kind == "sphere"  # no shaping input: no cone
    _check_rect(got["/lights/areaLight"], _hand_rect(path, "/lights/areaLight"))


def test_openusd_animated_light_is_read_at_each_time():
    """The lights' parent moves by time samples only (1, 2, 3): read at the start time code
    1, and at 3 with `--time 3`; no metersPerUnit authored (0.01, UsdGeom's fallback). The
    file has no mesh (a Sphere gprim): refused."""
    path = DATA / "openusd-animated-lights" / "lightMoving.usda"
    name = "/lights/light1"
    for time in (None, 3.0):
        light = _usd_lights(path, time=time)[name]
        hand = _hand(path, name, Usd.TimeCode(1 if time is None else time))
        centre, r, intensity, _ = hand
        assert light.position == pytest.approx(tuple(centre), abs=1e-12)
        assert light.radius == pytest.approx(r) and light.intensity == pytest.approx(intensity)
    assert light.position == pytest.approx((0.02, -0.02, 0.0))
    with pytest.raises(ValueError, match="no mesh to sample receivers on"):
        load_mesh_scene(path, samples=16, notice=lambda m: None)


@pytest.mark.parametrize(
    "folder, file, names",
    [
        ("openusd-inherited-primvars", "inherited_primvars.usda", ["/lights/arealight1"]),
        (
            "openusd-preview-surface-normal-map",
            "testPreviewSurfaceNormalMap.usda",
            ["/Scene/Lights/LeftRed", "/Scene/Lights/RightBlue"],
        ),
        ("openusd-physics-box-on-quad", "usdPhysicsBoxOnQuad.usda", ["/World/SphereLight"]),
        ("openusd-premultiply-alpha", "testPremultiplyAlphaUdims.usda", ["/Scene/Lights/Light"]),
        (
            "usd-wg-shader-ball",
            "environment.usda",
            [
                f"/standard_shader_ball_scene/lights/{n}"
                for n in ("emitterLeft/light", *(f"emitterTop/light{k}" for k in (3, 2, 1, 0)))
            ],
        ),
    ],
)
def test_usd_lights_match_a_reading_made_here(folder, file, names):
    """Sphere and rect lights of OpenUSD's test assets and usd-wg's shader ball (a full
    xform matrix, exposure 5, pre-2021 names, centimetres, a render purpose on the parent)
    against usd-core's values turned into metres and point-equivalent intensity here."""
    path = DATA / folder / file
    im = load_mesh_scene(path, samples=16, notice=lambda m: None)
    assert list(im.names) == names
    for name, light in zip(im.names, im.scene.lights, strict=True):
        if light.kind == "rect":
            _check_rect(light, _hand_rect(path, name))
        else:
            _check(im, name, _hand(path, name))


@pytest.mark.slow
@pytest.mark.parametrize(
    "folder, file",
    [
        ("openusd-inherited-primvars", "inherited_primvars.usda"),
        ("openusd-preview-surface-normal-map", "testPreviewSurfaceNormalMap.usda"),
        ("openusd-premultiply-alpha", "testPremultiplyAlphaUdims.usda"),
        ("usd-wg-shader-ball", "environment.usda"),
    ],
)
def test_usd_files_are_answered_end_to_end(capsys, folder, file):
    path = DATA / folder / file
    im = load_mesh_scene(path, samples=16, notice=lambda m: None)
    _answered(capsys, path, im.names)


def test_openusd_physics_file_old_names_answered(capsys):
    """`float radius = 150`, `float intensity = 30000` (pre-2021 names) on a centimetre
    stage: read with a notice and answered."""
    path = DATA / "openusd-physics-box-on-quad" / "usdPhysicsBoxOnQuad.usda"
    _, err = _answered(capsys, path, ["/World/SphereLight"])
    assert "pre-2021 UsdLux names radius, intensity" in err


@pytest.mark.parametrize("kind", ["point", "spot"])
def test_blender_exported_gltf_lights_match_the_json(capsys, kind):
    """atteneder's glTF test models (Blender I/O 3.2 exports): three coloured point or spot
    lights over a 10 m plane, rotated nodes, a published range on some; read against the
    JSON (candela, radians, the node's -Z) and answered end to end."""
    path = DATA / f"atteneder-lights-{kind}" / f"Lights{kind.title()}.gltf"
    hand = _gltf_hand(path)
    lights, meshes = read_gltf(
        path, path.name, radius_for=lambda n: 0.05, strict=False, notice=lambda m: None
    )
    assert [x.name for x in lights] == list(hand) and len(meshes) == 1
    for x in lights:
        pos, direction, cd, rng, inner, outer = hand[x.name]
        assert x.light.position == pytest.approx(tuple(pos), abs=1e-12)
        assert x.light.intensity == pytest.approx(cd) and x.published_range == rng
        if kind == "spot":
            assert x.light.kind == "spot"
            assert x.light.direction == pytest.approx(tuple(direction), abs=1e-6)
            assert x.light.umbra == pytest.approx(math.degrees(outer))
            assert x.light.penumbra == pytest.approx(math.degrees(inner))
        else:
            assert x.light.kind == "sphere" and x.light.radius == 0.05
    code, _, err = _answer(capsys, path)
    assert code == 2 and "glTF lights have no radius" in err
    _answered(capsys, path, list(hand), "--radius", "0.05")


def test_khronos_validator_node_light_keeps_the_defaults(capsys):
    """A point light with only its type: intensity 1 cd, no range, at the origin; no mesh."""
    path = DATA / "gltf-validator-node" / "valid.gltf"
    (name, (pos, _, cd, rng, _, _)), = _gltf_hand(path).items()  # fmt: skip
    (x,), meshes = read_gltf(
        path, path.name, radius_for=lambda n: 0.01, strict=False, notice=lambda m: None
    )
    assert meshes == [] and x.name == name == "lights[0]"
    assert x.light.intensity == cd == 1.0 and x.published_range is rng is None
    assert x.light.position == pytest.approx(tuple(pos))
    code, _, err = _answer(capsys, path, "--radius", "0.01")
    assert code == 2 and "no mesh to sample receivers on" in err
