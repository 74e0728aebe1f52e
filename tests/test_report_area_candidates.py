"""Area models in the report's decision table (`attenfit/_report/_area_candidates.py`).

The exact sphere (Snyder) must be exact on every receiver set of a sphere, the models made
for one light must not be judged on another, and a candidate's errors must be those of
`receiver_errors` against the exact irradiance (computed independently here).
"""

from __future__ import annotations

import inspect

import jax
import numpy as np

import attenfit as af
from attenfit._report import _decide
from attenfit._report._area_candidates import area_candidates
from attenfit._report._configs import emitter_config


def _config(kind: str):
    with jax.enable_x64(True):
        em = (
            af.SphereEmitter([0.0, 0.0, 0.0], 0.1)
            if kind == "sphere"
            else af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, -1.0], 0.1)
        )
        return emitter_config(kind, em, 32, 8)


def test_area_models_are_the_decision_tables_other_source():
    assert _decide.SOURCES == (area_candidates,)
    assert inspect.signature(_decide.decide).parameters["sources"].default is _decide.SOURCES


def test_exact_sphere_is_exact_on_every_set_and_band():
    cands = {c.model: c for c in area_candidates(_config("sphere"), None)}
    assert "snyder_sphere" in cands and "vector_disk" not in cands
    snyder = cands["snyder_sphere"]
    assert snyder.kind == "area model"
    judged = [e for e in snyder.errors.values() if e is not None]
    assert judged and max(judged) < 1e-9
    # a wrap is not exact where part of the sphere sinks below a tilted receiver's horizon
    assert cands["godot_wrap"].errors["contact"] > 0.01


def test_disk_candidates_match_an_independent_error():
    cfg = _config("disk")
    cands = {c.model: c for c in area_candidates(cfg, None)}
    assert "vector_disk" in cands and "snyder_sphere" not in cands
    rec = cfg.receivers["floor"]
    with jax.enable_x64(True):
        Em = np.asarray(af.area_irradiance(af.VectorDisk(), cfg.emitter, rec.points, rec.normals))
        Et = np.asarray(af.irradiance(cfg.emitter, rec.points, rec.normals))
    ok = Et > 0
    worst = float(np.max(np.abs(Em[ok] - Et[ok]) / Et[ok]))
    by_band = [e for e in cands["vector_disk"].set_errors["floor"].values() if e is not None]
    np.testing.assert_allclose(max(by_band), worst, rtol=1e-6)
