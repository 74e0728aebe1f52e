"""How many programs a scene compiles (issue 30): its families fitted in one solve per shape
of fit (`attenfit._scenes._family_solves`), not one per family; `attenfit warm` leaving a
scene nothing to compile; a spot's falloff fits reused. Counted with JAX's own compile log
and cache events, never timed."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
ROOM = REPO / "examples" / "scenes" / "room.toml"

# `attenfit ARGV` in this process, counting XLA compilations by program name (JAX's compile
# log) and the persistent cache's misses (JAX's monitoring events).
_COUNTED = r"""
import collections, contextlib, io, json, logging, sys
import jax, jax.monitoring
jax.config.update("jax_log_compiles", True)
names = collections.Counter()
events = collections.Counter()

class Log(logging.Handler):
    def emit(self, record):
        msg = record.getMessage()
        if msg.startswith("Finished XLA compilation of "):
            names[msg.split(" of ", 1)[1].split(" in ")[0]] += 1

logging.getLogger("jax").addHandler(Log())
jax.monitoring.register_event_listener(lambda name, **kw: events.update([name]))
from attenfit.cli import main
with contextlib.redirect_stdout(io.StringIO()):
    code = main(sys.argv[1:])
print(json.dumps({"code": code, "names": names, "events": events}))
"""


def _counted(cache: Path, *argv: str) -> dict:
    env = {**os.environ, "PYTHONPATH": str(REPO), "ATTENFIT_CACHE_DIR": str(cache)}
    proc = subprocess.run(
        [sys.executable, "-c", _COUNTED, *argv],
        env=env,
        capture_output=True,
        text=True,
        timeout=1200,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["code"] == 0, proc.stderr[-3000:]
    return out


def test_a_scene_compiles_few_solves_and_after_warm_compiles_nothing(tmp_path):
    """The room scene fits 19 parameterised families to 2 lights: 19 solve programs before,
    one per family; now one per shape of fit, 9 (1 free length; 1 free positive; each of
    the families with a linear start, `unreal_epsilon` and `polynomial`; `godot`'s
    nonnegative; `just_cause_2`'s and `unreal_exponent`'s two; `gltf_range`'s range;
    `spline`'s knots). An exported solve compiles as `jit(call)`."""
    cache = tmp_path / "cache"
    warm = _counted(cache, "warm", "--quiet", str(ROOM))
    assert 1 <= warm["names"].get("jit(call)", 0) <= 9, warm["names"]
    assert warm["events"]["/jax/compilation_cache/cache_misses"] > 0
    # a "cold" scene after `attenfit warm`: every program loaded, none compiled
    scene = _counted(cache, "scene", "--quiet", str(ROOM))
    assert scene["events"].get("/jax/compilation_cache/cache_misses", 0) == 0, scene["events"]
    assert scene["events"]["/jax/compilation_cache/cache_hits"] > 0


def test_warm_without_a_file_outside_a_checkout_says_what_to_name(monkeypatch, capsys):
    from attenfit._cli import _cmd_warm
    from attenfit.cli import main

    monkeypatch.setattr(_cmd_warm, "_EXAMPLES", Path("/nonexistent/examples"))
    assert main(["warm"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "attenfit warm FILE" in err
    assert main(["warm", "--quiet", "/nonexistent/scene.toml"]) == 2
    assert "no such scene file" in capsys.readouterr().err


# ----------------------------------------------------------------------------- group solves
def _light(d, E, radius=0.1, range_=None):
    from attenfit._scenes._light_fits import LightData

    one = np.ones_like(d)
    return LightData(
        d=d, wpt=one, E_true=E, E_irr=E, cos_s=one, theta=0 * d, denom=E,
        peak=float(E.max()), radius=radius, range=range_, spot=None,
    )  # fmt: skip


def test_a_group_solve_fits_each_family_as_its_own_solve_does():
    """The same problems fitted in the group solves (`fit_families`) and each family alone
    (`_fit_alone`, the solve every family had before): the same parameters, to well within
    the solver's tolerance (1e-8 on its coordinates). The targets are curves no family
    represents exactly (a facing disk's irradiance with a far-field bend), so every fit
    ends on a true optimum."""
    import jax

    from attenfit._curves import get_family
    from attenfit._scenes._light_fits import _fit_alone, fit_families, fit_plan

    with jax.enable_x64(True):
        d = np.geomspace(0.05, 3.0, 96)
        lights = [
            _light(d, 1 / (d**2 + 0.3**2) / (1 + 0.05 * d)),
            _light(d, 1 / (d**2 + 0.2**2) * np.exp(-0.1 * d), radius=0.2),
        ]
        knots = tuple(float(k) for k in np.geomspace(d.min(), d.max(), 6))
        requests = []
        for name in ("yuksel", "clamped", "madams_tan", "spline"):
            cls = get_family(name)
            plans = [fit_plan(cls, x, float(d.max()), knots) for x in lights]
            requests.append((cls, lights, plans))
        grouped = fit_families(requests)
        for req, got in zip(requests, grouped, strict=True):
            alone = _fit_alone(*req)
            for (m1, ok1, _), (m2, ok2, _) in zip(got, alone, strict=True):
                assert ok1 and ok2
                for k, v in m2.params().items():
                    np.testing.assert_allclose(
                        np.asarray(m1.params()[k], float), np.asarray(v, float), rtol=1e-6
                    )


# ----------------------------------------------------------------------------- spot falloffs
def test_a_spots_falloff_fits_are_reused_on_the_second_run(tmp_path, monkeypatch):
    """`attenfit scene` of a spot (the USD room's) fits each falloff's angles; a second run
    of the same question reuses the cached outputs: no solve runs."""
    import jax

    from attenfit._curves import spot_threejs
    from attenfit._fit import _compiled
    from attenfit._scenes import _light_fits

    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(tmp_path / "cache"))
    solved = []
    solve = _compiled._OnHost._solve

    def counted(self, *args):
        solved.append(self.key)
        return solve(self, *args)

    monkeypatch.setattr(_compiled._OnHost, "_solve", counted)
    theta = np.linspace(0.0, 0.7, 64)
    with jax.enable_x64(True):
        profile = np.asarray(spot_threejs(np.cos(theta), 0.5, 0.3))
    x = _light(theta + 1.0, profile + 1e-3)
    x = type(x)(**{**x.__dict__, "theta": theta, "spot": (0.55, 0.25), "E_irr": np.ones(64)})
    with jax.enable_x64(True):
        first = [_light_fits._fit_falloff(x, c) for c in ("frostbite", "threejs")]
        assert len(solved) == 2 and all(k and "scenes-falloff" in k for k in solved)
        again = [_light_fits._fit_falloff(x, c) for c in ("frostbite", "threejs")]
    assert len(solved) == 2  # nothing solved the second time
    for a, b in zip(first, again, strict=True):
        assert (float(a.umbra), float(a.penumbra)) == (float(b.umbra), float(b.penumbra))
