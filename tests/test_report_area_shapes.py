"""The rectangle's and the tube's rows of the report (issue 31, item 3):
`attenfit report --emitters rect,tube` adds their ceiling and decision rows; the default
report has none.

Every ceiling cell's worst case is judged again here, independently of the report's search:
receivers placed by this test on the plane the docs describe (docs/area.md: a floor under a
square panel of width w = 1 facing down at h = w/4, w, 4 w; a wall beside a tube of length
l = 1, radius l/100, at D = l/4, l, 4 l, normals facing the light; receivers out to
`0.5 + 10 max(size, distance)` along both axes), a dense grid (uniform and log-spaced in each
coordinate) plus a fine grid around the reported point, the exact irradiance
(`attenfit.irradiance`, itself checked against independent quadratures in tests/test_rect.py
and tests/test_tube.py) and the model's own prediction (`attenfit.area_irradiance`). The
reported worst case must be within 5% of the largest error found there (the re-judge's
tolerance, docs/judging.md), or both below 1e-8 (float64 rounding of an exact model).

Kept fast by the report's options: two families, one round light, 24-distance sweeps,
12-pixel planes and a 9 x 9 grid for the shapes' search.
"""

from __future__ import annotations

import json
import re

import jax
import numpy as np
import pytest

import attenfit as af
from attenfit._curves import PointLight, get_area_model, get_family, list_area_models
from attenfit.cli import main

FAMILIES = ["inverse_square", "yuksel"]
#: (key, light, distance over size) of each plane, as docs/area.md lists them.
PLANES = {
    "panel_quarter": ("rect", 0.25),
    "panel_one": ("rect", 1.0),
    "panel_four": ("rect", 4.0),
    "tube_quarter": ("tube", 0.25),
    "tube_one": ("tube", 1.0),
    "tube_four": ("tube", 4.0),
}
#: Receivers per axis of the dense grid (half uniform, half log-spaced) and of the fine one.
DENSE, FINE = 40, 11


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("shapes") / "rep"
    argv = ["report", "--out", str(out), "--families", *FAMILIES, "--emitters", "disk",
            "rect,tube", "--sweep-n", "24", "--plane-px", "12", "--shape-grid", "9",
            "--no-mitsuba"]  # fmt: skip
    assert main(argv) == 0
    return out


@pytest.fixture(scope="module")
def data(written):
    return json.loads((written / "report.json").read_text())


def test_the_rect_and_tube_rows_exist(written, data):
    shapes = data["meta"]["shapes"]
    assert [r["config"] for r in shapes["rows"]] == list(PLANES)
    for row in shapes["rows"]:
        light = PLANES[row["config"]][0]
        ours = {n for n in list_area_models() if get_area_model(n).light == light}
        assert {m["name"] for m in row["models"]} == ours
        named = {"rect": {"clipped_rect", "three_rect", "frostbite_rect"},
                 "tube": {"karis_tube", "frostbite_tube", "lambert_line"}}[light]  # fmt: skip
        assert named <= ours
        assert row["best_fd"]["kind"] == "distance curve" and row["best_fd"]["name"] in FAMILIES
        assert all(m["cost"] > 0 for m in row["models"])
    rows = [d for d in data["decisions"] if d["kind"] in ("rect", "tube")]
    assert len(rows) == 6 * 3  # a row per plane and tolerance
    assert {(d["band"], d["tolerance"]) for d in rows} == {
        (k, t) for k in PLANES for t in (0.01, 0.05, 0.2)
    }
    md = (written / "report.md").read_text()
    assert "## Rectangle and tube lights: the ceiling" in md
    assert "| rect | floor under a panel, h = w/4 |" in md
    assert "| tube | wall beside a tube, D = 4 l |" in md


def test_a_cell_names_the_cheapest_that_holds(data):
    """Where a model is named, its worst case holds the tolerance and no cheaper model of
    the ceiling does; where none is, no model of the ceiling holds it."""
    ceiling = {r["config"]: r for r in data["meta"]["shapes"]["rows"]}
    for d in (d for d in data["decisions"] if d["kind"] in ("rect", "tube")):
        row = ceiling[d["band"]]
        cells = [row["best_fd"], *row["models"]]
        holding = [c for c in cells if c["error"] <= d["tolerance"] and c["cost"] is not None]
        if d["model"] is None:
            assert not holding, d
            continue
        assert d["error"] <= d["tolerance"]
        if d["model_kind"] == "area model":
            assert not any(c["cost"] < d["cost"] for c in holding if c["kind"] == "area model")


def test_the_default_report_has_no_rect_or_tube_rows():
    rep = af.build_report(families=["inverse_square"], emitters=["disk"], fitted=False,
                          sweep_n=16, plane_px=8, cost=False)  # fmt: skip
    assert "shapes" not in rep.meta
    assert {d["kind"] for d in rep.decisions()} == {"disk"}
    assert "Rectangle and tube" not in rep.markdown()
    assert "rect" not in rep.decision_markdown()


def _plane(key: str, u: np.ndarray, v: np.ndarray):
    """This test's own receivers of a plane (docs/area.md), at offsets u, v along it."""
    light, ratio = PLANES[key]
    U, V = (a.ravel() for a in np.meshgrid(u, v, indexing="ij"))
    n = U.size
    if light == "rect":
        em = af.RectEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.0, 0.0], 1.0, 1.0)
        return em, np.stack([U, V, np.full(n, -ratio)], -1), np.tile([0.0, 0.0, 1.0], (n, 1))
    em = af.TubeEmitter([-0.5, 0.0, 0.0], [0.5, 0.0, 0.0], 0.01)
    return em, np.stack([U, np.full(n, ratio), V], -1), np.tile([0.0, -1.0, 0.0], (n, 1))


def _worst(model, key: str, near: tuple[float, float]) -> float:
    """The largest |error| relative to the truth on the dense and the fine grid."""
    _, ratio = PLANES[key]
    reach = 0.5 + 10.0 * max(1.0, ratio)
    axis = np.unique(np.concatenate([np.linspace(0, reach, DENSE // 2),
                                     np.geomspace(1e-3, reach, DENSE // 2)]))  # fmt: skip
    h = 0.02 * reach * np.linspace(-1, 1, FINE)
    grids = [(axis, axis), (np.clip(near[0] + h, 0, reach), np.clip(near[1] + h, 0, reach))]
    worst = 0.0
    with jax.enable_x64(True):
        for u, v in grids:
            em, pts, nrm = _plane(key, u, v)
            truth = np.asarray(af.irradiance(em, pts, nrm))
            pred = np.asarray(af.area_irradiance(model, em, pts, nrm))
            ok = truth > 0
            worst = max(worst, float(np.max(np.abs(pred[ok] / truth[ok] - 1))))
    return worst


def _model(cell):
    if cell["kind"] == "area model":
        return get_area_model(cell["name"])(**cell["values"])
    return PointLight(
        get_family(cell["name"])(**{k: np.asarray(v) for k, v in cell["values"].items()})
    )


@pytest.mark.parametrize("key", list(PLANES))
def test_every_ceiling_cell_is_rejudged_independently(data, key):
    row = next(r for r in data["meta"]["shapes"]["rows"] if r["config"] == key)
    light, _ = PLANES[key]
    for cell in [row["best_fd"], *row["models"]]:
        x, y, z = (float(t) for t in re.findall(r"[-+0-9.e]+", cell["where"])[:3])
        near = (x, z) if light == "tube" else (x, y)
        found = _worst(_model(cell), key, near)
        reported = cell["error"]
        if reported < 1e-8 and found < 1e-8:
            continue
        assert found == pytest.approx(reported, rel=0.05), (cell["name"], found, reported)


@pytest.mark.parametrize(
    ("emitters", "named"),
    [("rect,cube", "'cube'"), ("tubes", "'tubes'"), ("rect,,sphere2", "'sphere2'")],
)
def test_a_bad_emitters_value_exits_2_with_one_line(tmp_path, capsys, emitters, named):
    out = tmp_path / "rep"
    assert main(["report", "--out", str(out), "--emitters", emitters, "--no-mitsuba"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and named in err and "Traceback" not in err
    assert not out.exists()


def test_a_bad_shape_grid_exits_2_with_one_line(tmp_path, capsys):
    argv = ["report", "--out", str(tmp_path / "r"), "--emitters", "rect", "--shape-grid", "2"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "--shape-grid" in err and "2" in err
