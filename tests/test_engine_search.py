"""The engine cone search (`attenfit._scenes._engine_fit._cone_search`): the closest error it
reports is the best the engine allows, checked against brute-force grids over the engine's
two cone properties on small spot scenes: one across their bounds
(`EngineWitness.cone_props`), one fine around the search's result. On the "inside" scene the
receivers reach into the spot's penumbra but not its edge (the error varies smoothly, and
the bounds grid finds the best region); on the "edge" scene they reach the edge, where the
best settings sit in a narrow valley that a bounds grid misses (it finds 100%)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _engine_code import SPOT_TOML

from attenfit._judge import engine_receiver_errors, get_witness
from attenfit._scenes import Scene
from attenfit._scenes import _choices as choices_mod
from attenfit._scenes._answer import answer_scene
from attenfit._scenes._engine_fit import _geometry, engine_verdict, renders_as_spot

#: the receivers' extent (m): corners at 28.5 degrees (inside the 30-degree cone) or past it
EXTENT = {"inside": 2.3, "edge": 2.5}

#: brute-force grid points per cone property
N = 121


def _captured(tmp_path, monkeypatch, engine, extent):
    """The arguments `answer_scene` hands `engine_verdict` for the scene's one light."""
    seen = []
    real = choices_mod.engine_verdict

    def spy(*args, **kwargs):
        seen.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(choices_mod, "engine_verdict", spy)
    path = tmp_path / "spot.toml"
    path.write_text(
        SPOT_TOML.format(umbra=30.0, penumbra=25.0, extent=extent, resolution=12, profile="threejs")
    )
    answer_scene(Scene.load(path), engine)
    ((w, light, props, x, *_),) = seen
    return w, light, dict(props), x


def _brute_force(w, light, props, x, around=None) -> float:
    """The smallest largest error over a grid of the two cone properties: across their
    bounds, or (`around`: props) over 2% of each span either side of those values."""
    cos_s, n_dot_l = _geometry(light, x)
    axes = []
    for name, lo, hi in w.cone_props:
        if around is not None:
            v, h = float(around[name]), 0.02 * (hi - lo)
            lo, hi = max(lo, v - h), min(hi, v + h)
        geometric = name in w.cone_log and around is None
        axes.append((name, np.geomspace(lo, hi, N) if geometric else np.linspace(lo, hi, N)))
    (n0, a0), (n1, a1) = axes
    best = math.inf
    for v0 in a0:
        for v1 in a1:
            e = engine_receiver_errors(
                w, {**props, n0: float(v0), n1: float(v1)}, d=x.d, cos_s=cos_s,
                n_dot_l=n_dot_l, spot=renders_as_spot(light), intensity=light.intensity,
                E_true=x.E_true, denom=x.denom,
            )  # fmt: skip
            best = min(best, float(e.max()))
    return best


ENGINES = ["godot", "threejs", "unreal", "filament", "bevy", "unity", "gltf"]


#: run by default (the rest are `slow`): the case that the first search missed (Filament's
#: fast::cos cone at the edge: 100% where 3.9% is reachable), Godot's, and one inside
QUICK = {("edge", "filament"), ("edge", "godot"), ("inside", "bevy")}
CASES = [
    pytest.param(c, e, marks=() if (c, e) in QUICK else pytest.mark.slow)
    for c in sorted(EXTENT)
    for e in ENGINES
]


@pytest.mark.parametrize(("case", "engine"), CASES)
def test_cone_search_beats_brute_force_grids(tmp_path, monkeypatch, engine, case):
    w, light, props, x = _captured(tmp_path, monkeypatch, engine, EXTENT[case])
    assert w is get_witness(engine)
    # tolerance 0: the search always runs; the light's size (Godot) kept as mapped
    verdict = engine_verdict(w, light, props, x, 0.0)
    assert verdict.error <= verdict.mapped_error
    bounds = _brute_force(w, light, verdict.properties, x)
    local = _brute_force(w, light, verdict.properties, x, around=verdict.properties)
    assert verdict.error <= min(bounds, local) * (1 + 1e-9), (verdict.error, bounds, local)
