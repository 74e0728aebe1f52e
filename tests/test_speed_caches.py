"""The caches that make a warm call cheap (issue 30): `attenfit export`'s text, and the
report's figures and Mitsuba witness. A cached answer must equal the computed one byte for
byte, a corrupted entry must be ignored (recomputed, never trusted), and a changed input
must recompute."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from attenfit import _cache

REPO = Path(__file__).resolve().parents[1]


@pytest.fixture
def cache_dir(tmp_path, monkeypatch):
    folder = tmp_path / "cache"
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(folder))
    return folder


# ----------------------------------------------------------------------------- export
_EXPORT = r"""
import contextlib, io, json, sys
from attenfit.cli import main

out = io.StringIO()
with contextlib.redirect_stdout(out):
    code = main(sys.argv[1:])
print(json.dumps([code, out.getvalue(), "jax" in sys.modules]))
"""


def _export(cache_dir: Path, *argv: str, cwd: Path | None = None) -> tuple[int, str, bool, str]:
    """(exit code, stdout, whether JAX was imported, stderr) of `attenfit export ARGV` in a
    fresh process."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "ATTENFIT_CACHE_DIR": str(cache_dir)}
    proc = subprocess.run(
        [sys.executable, "-c", _EXPORT, "export", *argv],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
        cwd=cwd,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    code, text, jax = json.loads(proc.stdout.strip().splitlines()[-1])
    return code, text, jax, proc.stderr


def _entries(cache_dir: Path, kind: str) -> list[Path]:
    return sorted((cache_dir / "entries").rglob(f"{kind}/*.bin"))


def test_a_warm_export_prints_the_same_bytes_without_jax_and_ignores_a_corrupt_entry(cache_dir):
    argv = ("yuksel", "--lang", "hlsl", "--param", "r=0.25", "--uniforms")
    code, cold, cold_jax, _ = _export(cache_dir, *argv)
    assert code == 0 and cold_jax and "attenfit_yuksel" in cold
    (entry,) = _entries(cache_dir, "export")
    code, warm, warm_jax, _ = _export(cache_dir, *argv)
    assert (code, warm, warm_jax) == (0, cold, False)
    # another argument is another entry, computed
    code, glsl, jax, _ = _export(cache_dir, "yuksel", "--lang", "glsl", "--param", "r=0.25")
    assert code == 0 and jax and glsl != cold and len(_entries(cache_dir, "export")) == 2
    # a corrupted entry is ignored with a notice and recomputed, never printed
    data = entry.read_bytes()
    entry.write_bytes(data.replace(b"attenfit_yuksel", b"attenfit_bogus_"))
    code, again, jax, err = _export(cache_dir, *argv)
    assert (code, again, jax) == (0, cold, True) and "ignoring a corrupt cache entry" in err


def test_an_export_entry_of_the_wrong_shape_is_ignored(cache_dir, capsys):
    key = json.dumps(["x"])
    assert _cache.write("export", key, json.dumps({"text": 3}).encode())
    assert _cache.read("export", key) is None
    assert "no exported text" in capsys.readouterr().err
    assert _cache.write("export", key, json.dumps({"text": "f"}).encode())
    assert _cache.read("export", key) == b'{"text": "f"}'


def test_a_fit_file_export_is_keyed_by_the_file_bytes(cache_dir, tmp_path):
    fit = tmp_path / "fit.json"
    fit.write_text(json.dumps({"family": "yuksel", "params": {"r": 0.5}}))
    _, first, _, _ = _export(cache_dir, str(fit), "--lang", "c")
    _, warm, jax, _ = _export(cache_dir, str(fit), "--lang", "c")
    assert warm == first and not jax
    fit.write_text(json.dumps({"family": "yuksel", "params": {"r": 0.75}}))
    _, changed, jax, _ = _export(cache_dir, str(fit), "--lang", "c")
    assert jax and changed != first and "0.75" in changed


# ----------------------------------------------------------------------------- report figures
def _small_report(**kw):
    from attenfit import build_report

    args = dict(families=["inverse_square", "yuksel"], sweep_n=16, plane_px=8, cost=False)
    return build_report(**{**args, **kw})


def test_a_second_report_draws_no_figure_and_a_changed_input_redraws(
    cache_dir, tmp_path, monkeypatch
):
    from attenfit._report import _figures

    drawn = []
    to_bytes = _figures._to_bytes

    def counted(fig, *args):
        drawn.append(fig)
        return to_bytes(fig, *args)

    monkeypatch.setattr(_figures, "_to_bytes", counted)
    report = _small_report()
    first = report.write(tmp_path / "one")
    pngs = sorted((first / "figures").glob("*.png"))
    assert len(pngs) >= 8 and len(drawn) == len(pngs)
    drawn.clear()
    again = _small_report(figures_early=True)  # built again; the thread's path too
    second = again.write(tmp_path / "two")
    assert drawn == []
    for png in pngs:
        assert (second / "figures" / png.name).read_bytes() == png.read_bytes()
    # corrupted figure entries are redrawn, never written
    drawn.clear()
    for entry in _entries(cache_dir, "figure"):
        entry.write_bytes(entry.read_bytes()[:-10])
    third = report.write(tmp_path / "three")
    assert len(drawn) == len(pngs)
    for png in pngs:
        assert (third / "figures" / png.name).read_bytes() == png.read_bytes()
    # one pixel of one light's truth changed: that light's plane figures only are redrawn
    sphere = next(c for c in report.configs if c.name == "sphere")
    truth = sphere.plane.E.copy()
    truth[0, 0] *= 1.5
    object.__setattr__(sphere, "plane", dataclasses.replace(sphere.plane, E=truth))
    keys = []
    monkeypatch.setattr(_figures, "DRAWN", keys)  # the keys of the figures drawn
    report.write(tmp_path / "four")
    assert sorted(keys) == ["sphere_plane_errors", "sphere_plane_side_by_side"]


# ----------------------------------------------------------------------------- the witness
def test_the_witness_is_rendered_once_for_the_same_lights(cache_dir, monkeypatch):
    pytest.importorskip("data_gen.witness")
    import data_gen.variants
    import data_gen.witness
    from attenfit._cli import _cmd_report
    from attenfit._report import resolve_emitters

    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from test_witness import _pair

    renders = []

    def render(emitters, **kw):
        renders.append(sorted(emitters))
        return [("sphere floor", *_pair(np.linspace(-1.0, 1.0, 50)))]

    monkeypatch.setattr(data_gen.variants, "require_mitsuba", lambda: None)
    monkeypatch.setattr(data_gen.witness, "render_witness", render)
    emitters = resolve_emitters(None)
    first = _cmd_report._Witness(emitters).result()
    again = _cmd_report._Witness(emitters).result()
    assert renders == [sorted(emitters)]
    assert again.data == first.data and again.png == first.png
    other = _cmd_report._Witness(resolve_emitters(["sphere"])).result()
    assert len(renders) == 2 and other.data["n"] == first.data["n"]
    # a corrupted entry is rendered again
    for entry in _entries(cache_dir, "witness"):
        entry.write_bytes(entry.read_bytes().replace(b'"spp": 64', b'"spp": 65'))
    _cmd_report._Witness(emitters).result()
    assert len(renders) == 3


def test_a_witness_entry_of_the_wrong_shape_is_ignored(cache_dir, capsys):
    from attenfit._report import cached_witness

    key = "k"
    assert _cache.write("witness", key, json.dumps({"data": {"n": 3}, "png": "AA=="}).encode())
    assert cached_witness(key) is None
    assert "no witness numbers" in capsys.readouterr().err


# ----------------------------------------------------------------------------- solve outputs
def test_reused_solve_outputs_equal_a_solve_and_a_changed_input_solves(cache_dir, monkeypatch):
    import attenfit as af
    from attenfit._fit import _compiled, reuse_results

    solves = []
    solve = _compiled._OnHost._solve
    monkeypatch.setattr(
        _compiled._OnHost, "_solve", lambda self, *a: solves.append(1) or solve(self, *a)
    )
    d = np.geomspace(0.05, 10.0, 32)[None].repeat(3, 0)
    t = 1 / (d**2 + np.array([[0.01], [0.02], [0.03]]))

    def fits(target):
        return af.fit_many(af.Yuksel(r=np.full(3, 0.1)), d, target).params["r"]

    plain = fits(t)  # outside the context: solved, nothing kept
    assert len(solves) == 1 and not _entries(cache_dir, "result")
    with reuse_results():
        first = fits(t)
        again = fits(t)
        assert len(solves) == 2 and np.array_equal(first, again) and np.array_equal(first, plain)
        changed = fits(t * 1.01)  # another target: solved
        assert len(solves) == 3 and not np.array_equal(changed, first)
        for entry in _entries(cache_dir, "result"):  # corrupted: solved again, not trusted
            entry.write_bytes(entry.read_bytes()[:-8] + b"\0" * 8)
        assert np.array_equal(fits(t), first) and len(solves) == 4


_REUSED = r"""
import json, sys
import numpy as np
import attenfit as af
from attenfit._fit import reuse_results

d = np.geomspace(0.05, 10.0, 32)[None].repeat(2, 0)
t = 1 / (d**2 + np.array([[0.01], [0.02]]))
with reuse_results():
    res = af.fit_many(af.Yuksel(r=np.full(2, 0.1)), d, t)
print(json.dumps([res.params["r"].tolist(), res.converged.tolist(), "optimistix" in sys.modules]))
"""


def test_a_result_read_back_in_a_fresh_process_needs_no_optimistix(cache_dir):
    # a warm answer reads its solves' outputs from the cache: the solve (optimistix, 0.15 s
    # to import) is not even built
    env = {**os.environ, "PYTHONPATH": str(REPO), "ATTENFIT_CACHE_DIR": str(cache_dir)}
    runs = []
    for _ in range(2):
        proc = subprocess.run(
            [sys.executable, "-c", _REUSED], env=env, capture_output=True, text=True, timeout=600
        )
        assert proc.returncode == 0, proc.stderr[-2000:]
        runs.append(json.loads(proc.stdout.strip().splitlines()[-1]))
    (r1, ok1, optx1), (r2, ok2, optx2) = runs
    assert optx1 and not optx2  # solved, then read back
    assert r1 == r2 and ok1 == ok2 == [True, True]


def test_the_solver_names_checked_are_the_solvers():
    from attenfit._fit import SOLVERS
    from attenfit._fit._validate import SOLVER_NAMES

    assert tuple(SOLVERS) == SOLVER_NAMES


def test_a_scene_reference_curve_is_cached_by_model_and_points(cache_dir):
    import jax

    import attenfit as af
    from attenfit._scenes._light_fits import shade

    d = np.geomspace(0.05, 10.0, 40)
    r = 0.3
    s = np.sqrt(d * d + r * r)
    closed = 2 / (s * (s + d))  # Yuksel 2020, eq. 7
    with jax.enable_x64(True):
        first = shade(af.Yuksel(r=r), d, "float64")
        (entry,) = _entries(cache_dir, "values")
        again = shade(af.Yuksel(r=r), d, "float64")
        other = shade(af.Yuksel(r=0.2), d, "float64")  # another model: computed, kept apart
    np.testing.assert_allclose(first, closed, rtol=1e-12)
    assert np.array_equal(again, first) and len(_entries(cache_dir, "values")) == 2
    assert not np.allclose(other, first)
    entry.write_bytes(entry.read_bytes()[:-8] + b"\0" * 8)  # corrupted: computed again
    with jax.enable_x64(True):
        assert np.array_equal(shade(af.Yuksel(r=r), d, "float64"), first)


def test_minor_log_labels_follow_the_view_span():
    from attenfit._report import plain_log_ticks
    from attenfit._report._plots import new_figure

    ax = new_figure((3, 3)).subplots()
    ax.set_yscale("log")
    plain_log_ticks(ax.yaxis)
    minor = ax.yaxis.get_minor_formatter()
    ax.set_ylim(2, 5)  # under 3 times: every minor tick labelled
    assert minor.format_ticks([2, 3, 4, 5]) == ["2", "3", "4", "5"]
    ax.set_ylim(2, 9)  # 3 to 10 times: 2 and 5 times a decade only
    assert minor.format_ticks([2, 3, 5, 8]) == ["2", "", "5", ""]
    assert minor(5.0) == "5"
    ax.set_ylim(0.01, 100)  # a decade or more: the decades' labels only
    assert minor.format_ticks([0.02, 0.5, 3]) == ["", "", ""]


def test_an_area_model_fitted_in_a_scene_is_reused_for_the_same_receivers(cache_dir, monkeypatch):
    """The escalation fits an area model with free parameters to the judged errors; an
    unchanged scene asked again (another process: the cache on disk) runs no solve."""
    from types import SimpleNamespace

    import attenfit as af
    from attenfit._curves import get_area_model
    from attenfit._fit import _compiled
    from attenfit._scenes import _escalate
    from attenfit._truth import model_inputs

    solves = []
    solve = _compiled._OnHost._solve
    monkeypatch.setattr(
        _compiled._OnHost, "_solve", lambda self, *a: solves.append(1) or solve(self, *a)
    )
    model = get_area_model("unreal_wrap")()
    assert model.free_by_default()
    em = af.SphereEmitter(radius=0.2, center=np.array([0.0, 0.0, 1.0]))
    x = np.linspace(-2.0, 2.0, 40)
    pts = np.stack([x, np.zeros_like(x), np.zeros_like(x)], axis=1)
    nrm = np.broadcast_to([0.0, 0.0, 1.0], pts.shape)
    E = np.asarray(af.irradiance(em, pts, nrm), np.float64)
    rows = np.stack([np.asarray(v, np.float64) for v in model_inputs(model, em, pts, nrm)])
    inputs = [(rows, float(em.intensity))]
    datas = [SimpleNamespace(E_true=E, denom=np.maximum(E, E.max() * 1e-3))]

    first = _escalate._variants(model, inputs, datas)
    assert len(solves) == 1 and len(first) == 2 and first[1][1]
    assert _entries(cache_dir, "result")
    again = _escalate._variants(model, inputs, datas)
    assert len(solves) == 1
    assert again[1][0].params().keys() == first[1][0].params().keys()
    for k, v in first[1][0].params().items():
        assert np.array_equal(np.asarray(again[1][0].params()[k]), np.asarray(v))
    datas = [SimpleNamespace(E_true=E * 1.01, denom=datas[0].denom)]  # another scene: solved
    _escalate._variants(model, inputs, datas)
    assert len(solves) == 2


def test_an_engine_search_is_read_back_for_the_same_light_and_a_bad_entry_is_not(
    cache_dir, monkeypatch, tmp_path
):
    """The engine's closest settings (`_engine_search.search`, most of a warm `--engine`
    answer) are cached by the search's exact inputs; a corrupt entry or one of another shape
    is ignored and the search runs again."""
    from test_engine_search import DISK, _runaway_gltf

    from attenfit._scenes import _engine_search
    from attenfit._scenes._engine_fit import engine_verdict

    calls = []
    real = _engine_search._search
    monkeypatch.setattr(_engine_search, "_search", lambda *a: calls.append(1) or real(*a))
    w, light, props, x, *_ = _runaway_gltf(tmp_path, DISK)
    first = engine_verdict(w, light, props, x, 0.0)  # tolerance 0: the search runs
    assert len(calls) == 1 and len(_entries(cache_dir, "engine-search")) == 1
    again = engine_verdict(w, light, props, x, 0.0)
    assert len(calls) == 1
    assert again.properties == first.properties and again.error == first.error
    (entry,) = _entries(cache_dir, "engine-search")
    entry.write_bytes(entry.read_bytes()[:-4] + b"9999")  # the checksum no longer holds
    assert engine_verdict(w, light, props, x, 0.0).properties == first.properties
    assert len(calls) == 2

    for bad in (b'{"props": {"range": [1]}, "error": 0.1}', b'{"props": {}, "error": "x"}', b"[]"):
        assert _cache.write("engine-search", "k", bad)
        assert _cache.read("engine-search", "k") is None
    assert _cache.write(
        "engine-search", "k", b'{"props": {"range": 2.5, "on": true}, "error": 0.1}'
    )
    assert _cache.read("engine-search", "k") is not None


def test_a_cached_array_of_another_shape_is_rebuilt(cache_dir, capsys):
    """`_cache.cached_array` with `shape`: an entry that is a float array of another shape
    (written by anything that can write the cache) is ignored with a notice, and rebuilt."""
    calls = []

    def compute():
        calls.append(1)
        return np.arange(4.0)

    parts = ("test", np.ones(3))
    assert np.array_equal(_cache.cached_array("values", parts, compute, shape=(4,)), np.arange(4.0))
    assert np.array_equal(_cache.cached_array("values", parts, compute, shape=(4,)), np.arange(4.0))
    assert len(calls) == 1
    _cache.write_array("values", _cache.fingerprint(*parts), np.zeros((2, 2)))
    assert np.array_equal(_cache.cached_array("values", parts, compute, shape=(4,)), np.arange(4.0))
    assert len(calls) == 2 and "another shape" in capsys.readouterr().err
