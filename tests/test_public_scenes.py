"""Public USD and glTF files nobody here wrote (tests/data/public, sources and licences in
LICENSES.md), answered end to end (`attenfit scene FILE`), each light checked against a
reading of the file made here: usd-core's own attribute values and `UsdGeom.XformCache`
(at the time the test names), or the glTF JSON, turned into metres and point-equivalent
intensity by the UsdLux formulas (radiance = intensity x 2^exposure, over the area with
normalize; point-equivalent = radiance x pi r^2) and the KHR_lights_punctual README
(intensity in candela, spot angles in radians)."""

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
    if get("inputs:normalize", "normalize", default=False):
        radiance /= 4 * math.pi * r**2
    axis = np.array([0.0, 0.0, -1.0]) @ m[:3, :3]
    return m[3, :3] * mpu, r, radiance * math.pi * r**2, axis / np.linalg.norm(axis)


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
    published file has no mesh and a spot with focus 8 (refused with a notice); the
    answerable layer beside it adds a floor and sets focus 0 (LICENSES.md)."""
    public = DATA / "maya-usd-lights" / "LightsTest.usda"
    code, _, err = _answer(capsys, public, "--radius", "0.05")
    assert code == 2 and "no mesh to sample receivers on" in err
    assert "/LightsTest/spotLight1: shaping:focus 8 is not modelled" in err
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
