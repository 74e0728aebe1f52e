"""Scene files: parsing and validation (word for word), ground truth only where the scene
looks, the example scenes' kinds of answer, and the `attenfit scene` verb."""

from __future__ import annotations

import dataclasses
import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import attenfit
from attenfit import BadTypeError, BadValueError, DataFileError, UnknownNameError
from attenfit.cli import main
from attenfit.scene import Scene, spot_profile

EXAMPLES = Path(__file__).resolve().parent.parent / "examples" / "scenes"

GOOD = """
tolerance = 0.05
[[lights]]
kind = "sphere"
radius = 0.1
height = 2.0
[[lights]]
kind = "sphere"
radius = 0.2
position = [1.0, 0.0, 2.0]
[[receivers]]
kind = "distribution"
distance = [0.5, 2.0]
angle = [10, 40]
n = 40
"""


def _write(tmp_path: Path, text: str, name: str = "scene.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


# ----------------------------------------------------------------------------- parsing
def test_good_scene_parses_and_round_trips(tmp_path):
    scene = Scene.load(_write(tmp_path, GOOD))
    assert scene.tolerance == 0.05
    assert [lt.radius for lt in scene.lights] == [0.1, 0.2]
    assert scene.lights[0].position == (0.0, 0.0, 2.0)  # height -> (0, 0, height)
    assert scene.receivers[0].distance == (0.5, 2.0)
    assert scene.source == "scene.toml"
    again = Scene.from_dict(scene.to_dict(), source="scene.toml")
    assert again == scene
    with pytest.raises(dataclasses.FrozenInstanceError):
        scene.tolerance = 0.1  # type: ignore[misc]


def test_example_scenes_parse():
    names = sorted(p.name for p in EXAMPLES.glob("*.toml"))
    assert names == [
        "batten.toml",
        "downlight.toml",
        "panel.toml",
        "room.toml",
        "short_range.toml",
        "spotlight.toml",
        "vpl_on_surface.toml",
    ]
    for p in EXAMPLES.glob("*.toml"):
        assert Scene.load(p).source == p.name


_LIGHT = '[[lights]]\nkind = "sphere"\nradius = 0.1\nheight = 1.0\n'
_RECV = '[[receivers]]\nkind = "plane"\nextent = 1.0\n'

# (scene text, exception type, exact message)
BAD = [
    (
        "tolerance = 0.05\n"
        + _LIGHT
        + '[[lights]]\nkind = "sphere"\nradius = -1\nheight = 1\n'
        + _RECV,
        BadValueError,
        "bad.toml: [[lights]][1].radius: must be a positive number, got -1",
    ),
    (
        _LIGHT + _RECV,
        BadValueError,
        "bad.toml: top level: missing key 'tolerance' (the largest acceptable relative error, e.g. 0.05)",
    ),
    (
        "tolerance = 0.05\n" + '[[lights]]\nkind = "sphere"\nradious = 0.1\nheight = 1\n' + _RECV,
        UnknownNameError,
        "bad.toml: [[lights]][0]: unknown key 'radious'; allowed: kind, radius, position, height, intensity, range",
    ),
    (
        "tolerance = 0.05\n" + '[[lights]]\nkind = "laser"\nradius = 0.1\nheight = 1\n' + _RECV,
        UnknownNameError,
        "bad.toml: [[lights]][0].kind: unknown kind 'laser'; allowed: sphere, disk, capsule, spot, rect, tube",
    ),
    (
        "tolerance = nan\n" + _LIGHT + _RECV,
        BadValueError,
        "bad.toml: tolerance: must be a relative error in (0, 1] (finite), got nan",
    ),
    (
        "tolerance = 0.05\n" + '[[lights]]\nkind = "sphere"\nradius = inf\nheight = 1\n' + _RECV,
        BadValueError,
        "bad.toml: [[lights]][0].radius: must be a positive number (finite), got inf",
    ),
    (
        "tolerance = 0.05\n" + '[[lights]]\nkind = "sphere"\nradius = "big"\nheight = 1\n' + _RECV,
        BadTypeError,
        "bad.toml: [[lights]][0].radius: must be a positive number, got 'big'",
    ),
    (
        "tolerance = 0.05\n" + '[[lights]]\nkind = "sphere"\nradius = true\nheight = 1\n' + _RECV,
        BadTypeError,
        "bad.toml: [[lights]][0].radius: must be a positive number, got true",
    ),
    (
        "tolerance = 0.05\n"
        + _LIGHT
        + '[[receivers]]\nkind = "distribution"\ndistance = [2.0, 1.0]\n',
        BadValueError,
        "bad.toml: [[receivers]][0].distance: range is backwards (min > max): [2.0, 1.0]",
    ),
    (
        "tolerance = 0.05\n"
        + '[[lights]]\nkind = "spot"\nradius = 0.1\nheight = 1\numbra = 20\npenumbra = 30\n'
        + _RECV,
        BadValueError,
        "bad.toml: [[lights]][0].penumbra: must be an angle in [0, umbra = 20] degrees, got 30",
    ),
    (
        "tolerance = 0.05\n" + '[[lights]]\nkind = "sphere"\nradius = 0.1\n' + _RECV,
        BadValueError,
        "bad.toml: [[lights]][0]: missing key 'position' ([x, y, z] in m) or 'height' (above z = 0, in m)",
    ),
    (
        "tolerance = 0.05\n"
        + '[[lights]]\nkind = "sphere"\nradius = 0.1\nheight = 1\nposition = [0, 0, 1]\n'
        + _RECV,
        BadValueError,
        "bad.toml: [[lights]][0]: give either 'position' or 'height', not both",
    ),
    (
        "tolerance = 0.05\n[constraints]\nreach_zero_at_range = true\n" + _LIGHT + _RECV,
        BadValueError,
        "bad.toml: [constraints].reach_zero_at_range: needs every light to have a range; [[lights]][0] has none",
    ),
    (
        "tolerance = 0.05\n[constraints]\nfloat64 = true\n" + _LIGHT + _RECV,
        UnknownNameError,
        "bad.toml: [constraints]: unknown key 'float64'; allowed: reach_zero_at_range, precision, float32, families",
    ),
    (
        "tolerance = 0.05\n" + _RECV,
        BadValueError,
        "bad.toml: missing [[lights]]: a scene needs at least one [[lights]] table",
    ),
    (
        "tolerance = 0.05\n"
        + _LIGHT
        + '[[receivers]]\nkind = "distribution"\ndistance = [0.05, 1.0]\n',
        BadValueError,
        "bad.toml: [[receivers]][0].distance: min 0.05 is inside [[lights]][0] (radius 0.1); distances start at the centre",
    ),
    (
        "tolerance = 0.05\n"
        + _LIGHT
        + '[[receivers]]\nkind = "points"\npoints = [[3, 0, 0], [0, 0, 1.05]]\n',
        BadValueError,
        "bad.toml: [[receivers]][0].points[1]: lies inside [[lights]][0] (radius 0.1)",
    ),
    (
        "tolerance = 0.05\n"
        + _LIGHT
        + '[[receivers]]\nkind = "plane"\nextent = 1.0\nresolution = 1\n',
        BadValueError,
        "bad.toml: [[receivers]][0].resolution: must be an integer from 2 to 256, got 1",
    ),
    (
        'tolerance = 0.05\n[constraints]\nfamilies = ["inverse_sqare"]\n' + _LIGHT + _RECV,
        UnknownNameError,
        "bad.toml: [constraints].families: unknown family 'inverse_sqare'; allowed: "
        + ", ".join(attenfit.list_families()),
    ),
    (
        "tolerance = 0.05\n"
        + _LIGHT
        + '[[receivers]]\nkind = "distribution"\ndistance = [0.5, 1.0]\nangle = [0, 120]\n',
        BadValueError,
        "bad.toml: [[receivers]][0].angle: must lie within [0, 90], got [0, 120]",
    ),
]


@pytest.mark.parametrize(
    ("text", "kind", "message"), BAD, ids=[m.split(": ", 1)[1][:40] for _, _, m in BAD]
)
def test_bad_scene_messages_word_for_word(tmp_path, text, kind, message):
    path = _write(tmp_path, text, "bad.toml")
    with pytest.raises(kind) as info:
        Scene.load(path)
    assert str(info.value) == message


def test_toml_syntax_error_names_file_and_position(tmp_path):
    text = "tolerance = 0.05\n[[lights]\nkind = 'sphere'\n"
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        expected = f"scene file 'bad.toml': TOML syntax error: {exc}"
    with pytest.raises(DataFileError) as info:
        Scene.load(_write(tmp_path, text, "bad.toml"))
    assert str(info.value) == expected
    assert "line 2" in str(info.value)


def test_missing_file(tmp_path):
    with pytest.raises(DataFileError) as info:
        Scene.load(tmp_path / "nope.toml")
    assert str(info.value) == "scene file 'nope.toml' does not exist"


# ----------------------------------------------------------------------------- ground truth
def test_truth_is_only_the_scenes_configurations(tmp_path):
    """Distances, angles, radii and kinds generated are exactly the scene's, nothing else."""
    scene = Scene.load(_write(tmp_path, GOOD))
    truths = scene.ground_truth()
    assert len(truths) == 2
    for t, light in zip(truths, scene.lights, strict=True):
        ds = t.dataset
        assert ds.emitter.kind == "sphere"
        assert float(ds.emitter.radius) == light.radius
        assert len(ds) == 40
        c = np.asarray(light.position)
        v = c - ds.points
        d = np.linalg.norm(v, axis=1)
        assert d.min() >= 0.5 * (1 - 1e-12) and d.max() <= 2.0 * (1 + 1e-12)
        cos = np.sum(ds.normals * v, axis=1) / d / np.linalg.norm(ds.normals, axis=1)
        ang = np.degrees(np.arccos(np.clip(cos, -1, 1)))
        assert ang.min() >= 10 - 1e-6 and ang.max() <= 40 + 1e-6
        # the truth itself, independently: a Lambertian sphere of intensity I seen by a
        # receiver tilted by t (no horizon clipping for t + asin(r/d) < 90 deg) gives
        # E = I cos(t) / d^2 (Snyder 1996; the sphere is a point source outside itself).
        assert np.allclose(ds.E, np.cos(np.radians(ang)) / d**2, rtol=1e-9)


def test_plane_receivers_are_the_grid(tmp_path):
    text = (
        "tolerance = 0.05\n"
        '[[lights]]\nkind = "disk"\nradius = 0.2\nposition = [0.3, 0.0, 1.0]\n'
        '[[receivers]]\nkind = "plane"\nextent = 1.5\nresolution = 7\ncenter = [0, 0, 0.25]\n'
    )
    (truth,) = Scene.load(_write(tmp_path, text)).ground_truth()
    xs = np.linspace(-1.5, 1.5, 7)
    X, Y = np.meshgrid(xs, xs)
    grid = {(round(x, 9), round(y, 9)) for x, y in zip(X.ravel(), Y.ravel(), strict=True)}
    pts = truth.dataset.points
    assert {(round(x, 9), round(y, 9)) for x, y in pts[:, :2]} == grid
    assert np.all(pts[:, 2] == 0.25)
    # a facing disk on its axis: E = I / (h^2 + r^2) (Howell B-12); the receiver under the
    # centre is not on the grid, so check the closed form of the coaxial point explicitly
    E = attenfit.irradiance(
        truth.dataset.emitter, np.array([[0.3, 0.0, 0.25]]), np.array([[0.0, 0, 1]])
    )
    assert float(E[0]) == pytest.approx(1 / (0.75**2 + 0.2**2), rel=1e-9)


def test_capsule_distribution_distances_are_to_the_segment():
    scene = Scene.from_dict(
        {
            "tolerance": 0.1,
            "lights": [
                {
                    "kind": "capsule",
                    "radius": 0.05,
                    "length": 0.6,
                    "axis": [0.0, 1.0, 0.0],
                    "position": [0.0, 0.0, 1.0],
                }
            ],
            "receivers": [{"kind": "distribution", "distance": [0.2, 0.8], "n": 8}],
        },
        source="capsule.toml",
    )
    (truth,) = scene.ground_truth()
    em = truth.dataset.emitter
    assert em.kind == "capsule" and float(em.radius) == 0.05
    assert np.allclose(np.asarray(em.a), [0, -0.3, 1]) and np.allclose(
        np.asarray(em.b), [0, 0.3, 1]
    )
    p = truth.dataset.points
    # distance to the segment x = 0, z = 1, |y| <= 0.3, computed here
    dy = np.maximum(np.abs(p[:, 1]) - 0.3, 0)
    d = np.sqrt(p[:, 0] ** 2 + (p[:, 2] - 1) ** 2 + dy**2)
    assert d.min() >= 0.2 * (1 - 1e-9) and d.max() <= 0.8 * (1 + 1e-9)
    assert np.all(truth.dataset.E > 0)  # the default angle [0, 0]: every receiver faces it


def test_aperture_profile_against_monte_carlo():
    """The spot's aperture profile is the visible fraction of the source disk (sampled here)."""
    scene = Scene.from_dict(
        {
            "tolerance": 0.1,
            "lights": [
                {"kind": "spot", "radius": 0.05, "height": 2.0, "umbra": 30.0, "penumbra": 10.0}
            ],
            "receivers": [{"kind": "plane", "extent": 1.0}],
        }
    )
    light = scene.lights[0]
    a, b = math.radians(20.0), math.radians(10.0)  # opening and source angular radii
    rng = np.random.default_rng(0)
    m = 400_000
    rad = b * np.sqrt(rng.uniform(size=m))
    phi = rng.uniform(0, 2 * np.pi, size=m)
    for deg in (5.0, 12.0, 20.0, 26.0, 35.0):
        th = math.radians(deg)
        x, y = th + rad * np.cos(phi), rad * np.sin(phi)
        frac = float(np.mean(x * x + y * y <= a * a))
        got = float(spot_profile(light, np.array([th]))[0])
        assert got == pytest.approx(frac, abs=4e-3), deg
    assert float(spot_profile(light, np.array([math.radians(10.0)]))[0]) == 1.0
    assert float(spot_profile(light, np.array([math.radians(30.0)]))[0]) == 0.0


# ----------------------------------------------------------------------------- recommend
# A few families per example (each family's solve compiles once, then every scene reuses
# it): enough to tell the kinds of answer apart. docs/scenes.md shows the full runs.
FAMILIES = ("inverse_square", "clamped", "disk_facing")


def _recommend(name: str, families: tuple[str, ...]):
    scene = Scene.load(EXAMPLES / name)
    return attenfit.recommend(dataclasses.replace(scene, families=families), measure=False)


def test_room_inverse_square_is_enough():
    rec = _recommend("room.toml", FAMILIES)
    w = rec.winner
    assert w is not None and w.family == "inverse_square"
    assert w.status == "pass" and w.error <= rec.tolerance
    assert attenfit.get_family(w.family).window == "none"
    # only the scene's configurations: a sphere of radius 0.1 and a disk of radius 0.15,
    # judged at d/r from 8 (1.2 m from the panel) to 45 (4.5 m from the bulb)
    assert [(t["kind"], t["radius"]) for t in rec.truth] == [("sphere", 0.1), ("disk", 0.15)]
    x, _ = rec.curves["inverse_square"]
    assert x.min() >= 1.2 / 0.15 * (1 - 1e-9)
    assert x.max() <= 4.5 / 0.1 * (1 + 1e-9)
    # the bulb is exactly a point light here (no receiver sees it cut by its horizon): the
    # error is the panel's, whose facing curve 1/(d^2 + r^2) is within 1/(d/r)^2 of 1/d^2
    assert w.error_by_light[0] < 1e-9
    assert 1e-4 < w.error_by_light[1] <= rec.tolerance
    assert "glsl" in rec.shaders and "attenfit_inverse_square" in rec.shaders["glsl"]


def test_vpl_needs_a_non_singular_family():
    rec = _recommend("vpl_on_surface.toml", FAMILIES)
    w = rec.winner
    assert w is not None
    assert not attenfit.get_family(w.family).singular
    by = {c.family: c for c in rec.candidates}
    assert by["inverse_square"].status == "fail"
    assert by["inverse_square"].error > rec.tolerance
    assert "> tolerance" in by["inverse_square"].reason
    # two lights, two radii: only those were generated
    assert [t["radius"] for t in rec.truth] == [0.05, 0.1]
    assert len(w.params) == 2


def test_short_range_needs_a_window_reaching_zero():
    rec = _recommend("short_range.toml", (*FAMILIES, "cryengine_linear"))
    w = rec.winner
    assert w is not None
    cls = attenfit.get_family(w.family)
    assert cls.window != "none"
    by = {c.family: c for c in rec.candidates}
    assert by["inverse_square"].status == "excluded"
    assert by["inverse_square"].reason == "no window: it cannot reach 0 at the range"
    for model, light in zip(w.models, rec.scene.lights, strict=True):
        assert float(model(np.float64(light.range))) == 0.0
        assert float(model(np.float64(0.9 * light.range))) > 0.0
    # receivers are judged within the range only
    assert all(t["judged_d_max"] <= 3.0 for t in rec.truth)


def test_spotlight_fits_the_directional_falloff():
    rec = _recommend("spotlight.toml", FAMILIES)
    w = rec.winner
    assert w is not None and w.directional is not None
    assert w.directional.startswith(("spot_frostbite", "spot_threejs"))
    (dp,) = w.directional_params
    assert 0 <= dp["penumbra"] <= dp["umbra"] < 40
    fitted = [f for f in rec.directional_fits if "fitted" in f["variant"]]
    given = [f for f in rec.directional_fits if "scene" in f["variant"]]
    assert len(fitted) == 2 and len(given) == 2
    # fitting the angles can only help (the scene's angles are the fit's start)
    for f, g in zip(fitted, given, strict=True):
        assert f["error"] <= g["error"] * (1 + 1e-9)
    assert "attenfit_spot_falloff" in rec.shaders["glsl"]


# ----------------------------------------------------------------------------- CLI
SMALL = """
name = "small"
tolerance = 0.05
[constraints]
families = ["inverse_square", "clamped"]
[[lights]]
kind = "sphere"
radius = 0.1
height = 1.0
[[receivers]]
kind = "distribution"
distance = [0.5, 3.0]
n = 200  # the same padded shape (256) as the example scenes: their compiled solves are reused
"""


def test_cli_scene_writes_files(tmp_path, capsys):
    path = _write(tmp_path, SMALL)
    out = tmp_path / "out"
    assert main(["scene", str(path), "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "recommended: inverse_square" in printed
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(
        [
            "recommendation.md",
            "recommendation.json",
            "errors.png",
            *(f"attenfit_inverse_square.{x}" for x in ("glsl", "hlsl", "wgsl", "c", "cuda")),
        ]
    )
    data = json.loads((out / "recommendation.json").read_text())
    assert data["winner"]["family"] == "inverse_square"
    assert data["scene"]["lights"][0]["radius"] == 0.1
    # an existing folder is not replaced without --force
    assert main(["scene", str(path), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "exists and is not empty" in err
    assert main(["scene", str(path), "--out", str(out), "--force", "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["winner"]["family"] == "inverse_square"


def test_cli_bad_scene_exits_2(tmp_path, capsys):
    path = _write(tmp_path, SMALL.replace("radius = 0.1", "radius = -1"), "bad.toml")
    assert main(["scene", str(path)]) == 2
    err = capsys.readouterr().err
    assert (
        err
        == "attenfit: error: bad.toml: [[lights]][0].radius: must be a positive number, got -1\n"
    )


def test_cli_no_family_within_tolerance_exits_0(tmp_path, capsys):
    # a disk near its surface: no distance curve comes within 1e-17, and the exact
    # clipped_disk area model only to its float64 rounding (about 1e-15)
    text = (
        SMALL.replace("tolerance = 0.05", "tolerance = 1e-17")
        .replace('kind = "sphere"', 'kind = "disk"')
        .replace("distance = [0.5, 3.0]", "distance = [0.02, 0.5]")
    )
    path = _write(tmp_path, text)
    assert main(["scene", str(path)]) == 0
    printed = capsys.readouterr().out
    assert "**no family meets the tolerance 1e-15%; closest: " in printed


def test_reach_zero_check_names_the_value_at_the_range():
    from attenfit._scenes._recommend import check_reaches_zero as _check_reaches_zero

    window = attenfit.get_family("frostbite_window")
    assert _check_reaches_zero(window(r_max=3.0), 3.0) is None
    # madams_cutoff reaches 0 at r / sqrt(cutoff) = 3 (to rounding)
    assert (
        _check_reaches_zero(
            attenfit.get_family("madams_cutoff")(r=0.05, cutoff=(0.05 / 3) ** 2), 3.0
        )
        is None
    )
    # a window at 3.5 m is still lit at 3 m: (1 - (3/3.5)^4)^2 / 3^2, computed here
    expected = (1 - (3 / 3.5) ** 4) ** 2 / 9
    assert _check_reaches_zero(window(r_max=3.5), 3.0) == (
        f"does not reach 0 at the range 3 (f = {expected:.3g} there)"
    )


def test_the_scene_stage_sets_the_precision_it_needs(tmp_path):
    """`recommend` gives the command line's answer whatever the caller's `jax_enable_x64`
    (the suite's conftest turns it on; a user's script may not)."""
    import jax

    scene = Scene.load(_write(tmp_path, GOOD))
    scene = dataclasses.replace(scene, families=("inverse_square", "yuksel"))
    with jax.enable_x64(False):
        off = attenfit.recommend(scene).to_dict()
        assert not jax.config.jax_enable_x64  # the caller's setting is left as it was
    on = attenfit.recommend(scene).to_dict()
    assert off == on
