"""The comparison report: its numbers against independent closed forms, its files, its CLI.

Reference values are computed here from the textbook forms (shared/reference/groundtruth.md §2-4),
never from attenfit: the facing disk's attenuation is 1/(d^2 + r^2) (Howell B-12), a sphere
above the horizon is exactly a point light, Yuksel's eq. 7 is 2/(s (s + d)) with
s = sqrt(d^2 + r^2) and eq. 8 is 1/(d^2 + r^2/2).
"""

import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from attenfit._report import _figures as _report_figures
from attenfit.cli import main
from attenfit.report import PUBLISHED_CUTOFF, Report, build_report, published_params

FAMILIES = [
    "inverse_square",
    "yuksel",
    "yuksel_adhoc",
    "disk_facing",
    "unreal_window",
    "just_cause_2",
    "gltf_range",
]
R = 0.1  # the default emitters' radius (m)


@pytest.fixture(scope="module")
def report() -> Report:
    # 31 log-spaced distances from 1e-3 r to 1e3 r hit d = r exactly (up to rounding)
    return build_report(families=FAMILIES, sweep_n=31, plane_px=16, cost=False)


def test_every_family_and_mode_has_a_result(report):
    keys = {(r["family"], r["config"], r["mode"]) for r in report.results}
    assert keys == {
        (f, c, m) for f in FAMILIES for c in ("sphere", "disk") for m in ("published", "fitted")
    }
    pub = [r for r in report.results if r["mode"] == "published"]
    assert all(r["status"] == "ok" for r in pub)


def test_eq8_and_eq7_are_twice_the_facing_disk_at_zero(report):
    truth0 = 1.0 / R**2  # facing disk, d -> 0
    for fam, f0 in (("yuksel_adhoc", 1.0 / (R**2 / 2)), ("yuksel", 2.0 / R**2)):
        z = report.result(fam, "disk")["sweep"]["at_zero"]
        assert z["value"] == pytest.approx(f0, rel=1e-12)
        assert z["truth"] == pytest.approx(truth0, rel=1e-10)
        assert z["ratio"] == pytest.approx(2.0, rel=1e-10)
    assert report.finding("disk_eq8_at_zero_ratio")["value"] == pytest.approx(2.0, rel=1e-10)
    assert report.finding("disk_eq7_at_zero_ratio")["value"] == pytest.approx(2.0, rel=1e-10)


def test_eq8_with_sqrt2_r_is_the_facing_disk(report):
    assert report.finding("disk_eq8_sqrt2_max_error")["value"] < 1e-12
    # and the fit finds r' = sqrt(2) r by itself
    fitted = report.result("yuksel_adhoc", "disk", "fitted")
    assert fitted["status"] == "ok"
    assert fitted["params"]["r"] / R == pytest.approx(math.sqrt(2.0), rel=1e-6)
    assert report.finding("eq8_between_eq7_and_inverse_square")["value"] == 1.0


def test_yuksel_errors_against_the_facing_disk_by_hand(report):
    sw = report.result("yuksel", "disk")["sweep"]
    # worst at the nearest sample, d = 1e-3 r: 2 s/(s + d) - 1
    d = 1e-3 * R
    s = math.sqrt(d * d + R * R)
    assert sw["overall"]["max_abs"] == pytest.approx(2 * s / (s + d) - 1, rel=1e-9)
    assert sw["overall"]["worst_at"] == pytest.approx(d, rel=1e-9)
    # mid band r..10 r: worst at d = r, 2/(1 + 1/sqrt 2) - 1 = 0.171572875 (shared/reference/groundtruth.md §4 table)
    assert sw["bands"]["mid"]["max_abs"] == pytest.approx(0.171572875253810, rel=1e-9)
    # far band: worst at its nearest sample, d = 10^(0.2 k) r just above 10 r
    d_far = R * 10 ** (1.2)
    s = math.sqrt(d_far**2 + R**2)
    assert sw["bands"]["far"]["max_abs"] == pytest.approx(2 * s / (s + d_far) - 1, rel=1e-8)


def test_inverse_square_is_exact_against_an_unclipped_sphere(report):
    row = report.result("inverse_square", "sphere")
    assert row["sweep"]["overall"]["max_abs"] < 1e-12
    assert row["sweep"]["bands"]["near"]["n"] == 0  # no receiver inside the sphere
    assert row["plane"]["image"]["max_abs"] < 1e-12
    assert row["plane"]["energy"]["ratio"] == pytest.approx(1.0, abs=1e-12)
    # against the disk it is singular: infinite at d = 0
    assert report.result("inverse_square", "disk")["sweep"]["at_zero"]["finite"] is False


def test_window_energy_dropped_matches_the_point_light_closed_form(report):
    # Sphere touching the plane (centre at h = r): a point light of unit intensity puts
    # 2 pi (1 - h/sqrt(h^2 + P^2)) on the disc rho < P and 2 pi h (1/R - 1/dP) beyond distance R.
    row = report.result("unreal_window", "sphere")
    rng = R / math.sqrt(PUBLISHED_CUTOFF)
    assert row["window"]["range"] == pytest.approx(rng, rel=1e-12)
    P = max(1e3 * R, 3 * rng)
    dP = math.hypot(R, P)
    expected = (R / rng - R / dP) / (1 - R / dP)
    assert row["plane"]["energy"]["discarded_fraction"] == pytest.approx(expected, rel=2e-3)
    # the window closes smoothly: value and slope at the range are ~0 relative to 1/d^2
    assert abs(row["window"]["value_rel"]) < 1e-6
    assert abs(row["window"]["slope_rel"]) < 1e-2
    # beyond the range it is black: overall worst error -1, inside the range much smaller
    assert row["sweep"]["overall"]["worst"] == -1.0
    assert row["sweep"]["in_range"]["max_abs"] < 1.0
    # inside the range, against 1/d^2: (1 - (d/R)^4)^2 d^2/(d^2 + 1e-4) - 1, written out here
    d = next(c for c in report.configs if c.name == "sphere").sweep.d
    err = (1 - (d / rng) ** 4) ** 2 * d**2 / (d**2 + 1e-4) - 1
    half = d <= rng / 2
    assert row["sweep"]["inner_half"]["max_abs"] == pytest.approx(
        np.max(np.abs(err[half])), rel=1e-9
    )
    ok = (d < rng) & (np.abs(err) <= 0.01)
    assert row["sweep"]["reach"]["1%"] == pytest.approx(d[ok].max() / rng, rel=1e-12)


def test_published_parameters_follow_the_documented_rules():
    from attenfit import get_family

    p, _ = published_params(get_family("unreal_window"), R)
    assert p["r_max"] == pytest.approx(R / math.sqrt(1e-3)) and p["eps"] == 1e-4
    p, _ = published_params(get_family("madams_tan"), R)
    assert p["d_max"] == pytest.approx(R / math.sqrt(1e-3) - R) and p["r"] == R
    p, _ = published_params(get_family("polynomial"), R)
    assert (p["kc"], p["kl"], p["kq"]) == pytest.approx((R * R, 2 * R, 1.0))
    p, note = published_params(get_family("just_cause_2"), R, truth_at=lambda d: 1 / d**2)
    # scale * (1 - (r/r_max)^2)^2 = truth(r) = 1/r^2
    assert p["scale"] * (1 - (R / p["r_max"]) ** 2) ** 2 == pytest.approx(1 / R**2)
    assert "scale" in note


def test_tables_and_json_are_complete(report):
    rows = report.csv_rows()
    assert len(rows) == len(FAMILIES) * 2 * 2
    d = report.to_dict()
    json.dumps(d, allow_nan=False)  # no NaN or inf sneaks into report.json
    assert {f["key"] for f in d["findings"]} >= {
        "sphere_inverse_square_max_error",
        "disk_eq8_at_zero_ratio",
        "disk_eq7_at_zero_ratio",
        "disk_eq8_sqrt2_max_error",
        "window_unreal_window_energy_dropped",
    }
    summary = report.summary_markdown()
    # a row per family, then one per area model of the report's lights (sphere and disk: the
    # decision's other class), all but the point light, which any light has
    from attenfit import get_area_model, list_area_models

    ours = [m for m in list_area_models() if get_area_model(m).light in ("sphere", "disk")]
    assert summary.count("\n| `") == len(FAMILIES) + len(ours)
    assert "| `vector_disk` (area model) | " in summary


def test_cli_report_writes_every_file_and_refuses_to_overwrite(tmp_path, capsys):
    out = tmp_path / "rep"
    argv = ["report", "--out", str(out), "--families", "yuksel_adhoc", "inverse_square"]
    argv += ["--emitters", "disk", "--no-fit", "--sweep-n", "24", "--plane-px", "12", "--svg"]
    argv += ["--no-mitsuba"]  # the witness has its own test (tests/test_witness.py)
    assert main(argv) == 0
    err = capsys.readouterr().err
    # stderr is not a terminal here: plain stage lines (no carriage return), then the summary
    *stages, summary = err.splitlines()
    assert summary.startswith("attenfit report: wrote ") and " results, " in summary
    assert stages and all(s.startswith("attenfit report: [") for s in stages) and "\r" not in err
    for name in ("report.md", "report.json", "results.csv"):
        assert (out / name).is_file()
    pngs = sorted(p.stem for p in (out / "figures").glob("*.png"))
    assert pngs == sorted(p.stem for p in (out / "figures").glob("*.svg"))
    assert "disk_attenuation_published" in pngs and "disk_plane_errors" in pngs
    md = (out / "report.md").read_text()
    for png in pngs:
        assert f"figures/{png}.png" in md
    data = json.loads((out / "report.json").read_text())
    f = {x["key"]: x["value"] for x in data["findings"]}
    assert f["disk_eq8_at_zero_ratio"] == pytest.approx(2.0, rel=1e-10)
    assert len((out / "results.csv").read_text().strip().splitlines()) == 1 + 2

    # an existing non-empty folder is refused (exit 2), one line, nothing touched
    before = (out / "report.md").read_text()
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err == (
        f"attenfit: error: output folder {str(out)!r} exists and is not empty; "
        "use --force to replace it\n"
    )
    assert (out / "report.md").read_text() == before
    assert main(["report", "--out", str(tmp_path / "new"), "--families", "nope", "--no-fit"]) == 2
    assert "unknown family 'nope'" in capsys.readouterr().err


def test_a_failure_mid_report_leaves_the_previous_folder_intact(report, tmp_path, monkeypatch):
    out = tmp_path / "rep"
    out.mkdir()
    (out / "report.md").write_text("previous report\n")

    def boom(*args, **kwargs):
        (Path(args[1]) / "half-written.png").write_bytes(b"x")
        raise RuntimeError("disk full")

    monkeypatch.setattr(_report_figures, "draw_all", boom)
    with pytest.raises(RuntimeError, match="disk full"):
        report.write(out, force=True)
    assert sorted(p.name for p in out.iterdir()) == ["report.md"]
    assert (out / "report.md").read_text() == "previous report\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["rep"]  # no temporary left


def test_failed_fits_are_marked_not_presented(report):
    # against the sphere the best eq. 8 radius is 0 (inverse-square is exact): no optimum
    row = report.result("yuksel_adhoc", "sphere", "fitted")
    if row["status"] != "ok":
        assert row["status"].startswith("fit did not converge: no finite optimum: r heads to 0")
        assert row["sweep"] is None and row["params"] is None
        assert "fit failed" in report.summary_markdown()
    else:  # a converged fit must then be (nearly) inverse-square, and say r ran to 0
        assert row["params"]["r"] < 1e-3 * R
        assert "r heads to 0" in row["note"] and "no finite optimum" in row["note"]


def test_plots_return_fig_and_ax():
    from attenfit import plots

    d = np.geomspace(1e-3, 10.0, 50)
    fig, ax = plots.plot_attenuation(d, {"a": 1 / d**2}, 1 / (d**2 + 0.01), r=0.1)
    assert ax.get_xscale() == "log" and ax.get_ylabel().startswith("attenuation")
    fig2, ax2 = plots.plot_relative_error(d, {"a": 1 / d**2}, 1 / (d**2 + 0.01), r=0.1, ax=ax)
    assert ax2 is ax and fig2 is fig
    img = np.ones((8, 8))
    _, axes = plots.plot_plane_comparison(img, {"m": 2 * img}, (-1, 1, -1, 1))
    assert axes.shape == (1, 2)


def test_datasets_become_configurations(tmp_path, capsys, monkeypatch):
    # Exact datasets stand in for Mitsuba ones (same format; generator "attenfit.irradiance").
    # A sphere touching a plane and a facing sweep: every receiver sees the whole sphere above
    # its horizon, where the sphere is exactly a point light (shared/reference/groundtruth.md §2.1).
    from attenfit import SphereEmitter, facing_sweep, plane_receivers

    sphere = SphereEmitter(center=(0.0, 0.0, 0.0), radius=R)
    plane = plane_receivers(sphere, R, 4 * R, n=9, dtype="float64")  # the centre point is dropped
    sweep = facing_sweep(sphere, 1.5 * R, 100 * R, n=12, dtype="float64")
    rep = build_report(
        families=["inverse_square", "yuksel"],
        emitters=[],
        datasets={"mc-plane": plane, "mc-sweep": sweep},
        fitted=False,
        cost=False,
    )
    img = rep.result("inverse_square", "mc-plane")["plane"]["image"]
    assert img["n"] == 9 * 9 - 1 and img["max_abs"] < 1e-12
    sw = rep.result("inverse_square", "mc-sweep")["sweep"]
    assert sw["overall"]["n"] == 12 and sw["overall"]["max_abs"] < 1e-12
    # yuksel (r) vs the sphere at d = 1.5 r: 2 d^2/(s (s + d)) - 1, s = sqrt(d^2 + r^2)
    d = 1.5 * R
    s = math.sqrt(d * d + R * R)
    assert rep.result("yuksel", "mc-sweep")["sweep"]["overall"]["max_abs"] == pytest.approx(
        1 - 2 * d * d / (s * (s + d)), rel=1e-9
    )

    # through the CLI, as --mitsuba files
    path = tmp_path / "plane.npz"
    plane.save(path)
    out = tmp_path / "rep"
    argv = ["report", "--out", str(out), "--families", "inverse_square", "--emitters", "disk"]
    argv += ["--no-fit", "--sweep-n", "24", "--plane-px", "12", "--mitsuba", str(path)]
    argv += ["--no-mitsuba"]
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True)  # stage lines, as on a terminal
    assert main(argv) == 0
    assert "] dataset: plane" in capsys.readouterr().err
    assert (out / "figures" / "plane_plane_side_by_side.png").is_file()
    data = json.loads((out / "report.json").read_text())
    assert {c["name"] for c in data["configurations"]} == {"disk", "plane"}


def test_published_figures_drawn_during_the_fits_are_the_ones_written(tmp_path):
    # with figures_early, build_report draws the published figures in a thread while the
    # fits compile (the CLI's report), and writing the report uses them
    report = build_report(
        families=["inverse_square", "yuksel"],
        sweep_n=16,
        plane_px=8,
        cost=False,
        figures_early=True,
    )
    pre = report._prerendered
    assert {"disk_attenuation_published", "sphere_plane_errors"} <= set(pre)
    out = report.write(tmp_path / "rep", svg=False)
    for key, (png, _svg) in pre.items():
        assert (out / "figures" / f"{key}.png").read_bytes() == png
    md = (out / "report.md").read_text()
    written = sorted(p.stem for p in (out / "figures").glob("*.png"))
    assert "sphere_attenuation_fitted" in written and "cost_vs_error" not in written  # no costs
    for key in written:
        assert f"figures/{key}.png" in md


# ----------------------------------------------------------------------------- issue 19
def test_ranges_stay_fixed_and_only_shape_parameters_are_fitted(report):
    for fam, rng in (
        ("unreal_window", "r_max"),
        ("just_cause_2", "r_max"),
        ("gltf_range", "range"),
    ):
        for cfg in ("sphere", "disk"):
            pub = report.result(fam, cfg, "published")
            fit = report.result(fam, cfg, "fitted")
            assert fit["status"] == "ok"
            assert (
                fit["params"][rng]
                == pub["params"][rng]
                == pytest.approx(R / math.sqrt(PUBLISHED_CUTOFF))
            )
    # glTF's only parameter is its range: nothing to fit, fitted = published, and said so
    fit = report.result("gltf_range", "sphere", "fitted")
    assert fit["params"] == report.result("gltf_range", "sphere")["params"]
    assert "fitted = published" in fit["note"]
    assert report.result("just_cause_2", "disk", "fitted")["fit"]["free"] == ["scale"]


def test_three_receiver_sets_judge_every_configuration(report):
    from attenfit._report._configs import FLOOR_HEIGHTS, FLOOR_N, RANDOM_N

    for row in report.results:
        if row["status"] == "ok":
            assert set(row["receivers"]) == {"facing", "floor", "random"}
    # a sphere above every floor receiver's horizon is exactly a point light
    # (shared/reference/groundtruth.md §2.1): inverse-square is exact on the floors
    rx = report.result("inverse_square", "sphere")["receivers"]
    assert rx["floor"]["overall"]["n"] == 2 * FLOOR_HEIGHTS * FLOOR_N
    assert rx["floor"]["overall"]["max_abs"] < 1e-12
    assert rx["facing"]["overall"]["max_abs"] < 1e-12
    # random orientations: part of the sphere sinks below a tilted receiver's horizon near it
    assert rx["random"]["overall"]["n"] == RANDOM_N and rx["random"]["overall"]["max_abs"] > 0.05
    # the facing disk is 1/(d^2 + r^2) on its axis (Howell B-12): disk_facing is exact there
    assert report.result("disk_facing", "disk")["receivers"]["facing"]["overall"]["max_abs"] < 1e-12
    # the summary shows all three sets and the floor energy of both lights
    head = report.summary_markdown().splitlines()[0]
    for c in ("sphere", "disk"):
        for s in ("facing sweep", "floor", "random orientations", "floor energy / truth"):
            assert f"{c}: {s}" in head


def test_a_fit_worse_than_published_is_explained_next_to_it(report):
    summary = report.summary_markdown()
    marks = [int(m) for m in __import__("re").findall(r"\[(\d+)\]", summary)]
    notes = [line for line in summary.splitlines() if line[:1].isdigit() and ". `" in line[:6]]
    assert sorted(set(marks)) == list(range(1, len(notes) + 1))
    # each explained cell really is worse fitted than published
    for line in notes:
        a, b = line.split("(")[1].split(")")[0].split(" → ")
        assert float(b.rstrip("%")) >= float(a.rstrip("%"))


def test_parameters_as_a_function_of_the_light_radius():
    from attenfit._report._decide import params_in_r

    assert params_in_r("yuksel_adhoc", {"r": math.sqrt(2) * R}, R) == "r′ = √2 r"
    assert params_in_r("unreal_epsilon", {"eps": 0.04 * R * R}, R) == "eps = 0.04 r²"
    assert params_in_r("unreal_epsilon", {"eps": 1e-4}, R, absolute=("eps",)) == "eps = 0.0001 m²"
    # not scale-covariant (a fixed 1e-4 m clamp): in metres
    assert params_in_r("godot", {"a": 1.0, "r_max": 3.0}, R) == "a = 1, r_max = 3 m"


def test_the_decision_table_picks_the_cheapest_within_tolerance(report):
    import dataclasses

    from attenfit._report import _decide

    costs = {"inverse_square": 2, "yuksel": 4, "yuksel_adhoc": 2, "disk_facing": 2,
             "unreal_window": 8, "just_cause_2": 6, "gltf_range": 7}  # fmt: skip
    rep = dataclasses.replace(report, costs={k: {"shader_cost": v} for k, v in costs.items()})
    # the ranking on the sampled errors alone first (a lower bound of each worst case)
    entries = _decide.decide(rep, sources=(), verify=False)
    assert len(entries) == 2 * 3 * len(_decide.TOLERANCES)
    far = {e["tolerance"]: e for e in entries if e["config"] == "sphere" and e["band"] == "far"}
    # beyond 10 r a sphere is a point light but for the horizon of tilted receivers, which
    # clips less than 1% of a facing receiver's irradiance there: inverse-square, cost 2
    assert all(e["model"] == "inverse_square" and e["cost"] == 2 for e in far.values())
    assert far[0.01]["error"] < 0.01
    md = _decide.decision_markdown(entries)
    assert md.count("\n| sphere |") == 3 and "| 1% to 20% | `inverse_square` published" in md

    # a source of other candidates (an area model) fills the cells no distance curve meets
    area = _decide.Candidate(
        model="area_stub", mode="fitted", params="r′ = r", cost=50.0,
        errors={"contact": 0.0, "near": 0.0, "far": 0.0},
        worst={"contact": None, "near": None, "far": None}, kind="area model",
    )  # fmt: skip
    none_before = sum(e["model"] is None for e in entries)
    assert none_before > 0  # near a disk no distance curve is within 1% on the floor
    after = _decide.decide(rep, sources=[lambda cfg, rep: [area]], verify=False)
    assert sum(e["model"] is None for e in after) == 0
    assert sum(e["model"] == "area_stub" for e in after) == none_before
    assert "(area model)" in decision_markdown_of(after)


def test_a_verdict_is_held_to_its_worst_case(report):
    """Beyond 10 r the sampled receivers put inverse square 0.4% off a sphere; its worst case
    (a tilted receiver at d = 11 r whose horizon clips the sphere) is 1.9%: it cannot be the
    1% answer, and is the 5% one with its worst case as its error (docs/judging.md)."""
    import dataclasses

    from attenfit._report import _decide

    costs = {"inverse_square": 2, "yuksel": 4, "yuksel_adhoc": 2, "disk_facing": 2,
             "unreal_window": 8, "just_cause_2": 6, "gltf_range": 7}  # fmt: skip
    rep = dataclasses.replace(report, costs={k: {"shader_cost": v} for k, v in costs.items()})
    sphere = [c for c in rep.configs if c.name == "sphere"]
    rep = dataclasses.replace(rep, configs=sphere)
    entries = _decide.decide(rep, sources=())
    far = {e["tolerance"]: e for e in entries if e["band"] == "far"}
    assert far[0.01]["model"] is None  # no distance curve holds 1% at its worst case
    assert far[0.01]["best"] == "inverse_square" and 0.015 < far[0.01]["error"] < 0.025
    five = far[0.05]
    assert five["model"] == "inverse_square" and five["error"] > five["sampled"]
    assert "n.l = " in five["where"] and 0.015 < five["error"] < 0.025


def decision_markdown_of(entries):
    from attenfit._report._decide import decision_markdown

    return decision_markdown(entries)


def test_error_plot_marks_clipped_points():
    from attenfit import plots

    d = np.geomspace(1e-3, 10.0, 50)
    truth = 1 / (d**2 + 0.01)
    _, ax = plots.plot_relative_error(d, {"a": 1 / d**2, "b": truth}, truth, r=0.1)
    assert ax.get_ylim() == pytest.approx((1e-3, 10.0))
    markers = {ln.get_marker() for ln in ax.get_lines()}
    assert {"^", "v"} <= markers  # 1/d^2 runs off the top near the light, b is exact
    assert "d / r" in ax.get_xlabel() and "0.1 m" in ax.get_xlabel()


def test_the_witness_section_shows_z_scores(tmp_path):
    # a stand-in Monte Carlo dataset: the exact values plus known noise of known stderr
    from attenfit import Dataset, SphereEmitter, irradiance, plane_receivers

    sphere = SphereEmitter(center=(0.0, 0.0, 0.0), radius=R)
    exact = plane_receivers(sphere, R, 4 * R, n=9, dtype="float64")
    E = np.asarray(exact.E, np.float64)
    z = np.random.default_rng(0).normal(size=E.shape)
    se = 0.01 * E
    mc = Dataset(sphere, exact.points, exact.normals, E - z * se, se, {"generator": "stub-mc"})
    rep = build_report(families=["inverse_square"], emitters=[], datasets={"mc": mc},
                       fitted=False, cost=False)  # fmt: skip
    (w,) = rep.witnesses()
    assert w["median_abs_z"] == pytest.approx(float(np.median(np.abs(z))), rel=1e-9)
    assert "## Independent witness" in rep.markdown()
    assert irradiance is not None
    out = rep.write(tmp_path / "w")
    assert (out / "figures" / "mc_witness_z.png").is_file()
    assert "figures/mc_witness_z.png" in (out / "report.md").read_text()
