"""The command line never says "internal error" on bad input: a fuzz campaign (issue 22).

hypothesis draws command lines (verbs, options, values from a hostile vocabulary: NaN,
inf, 1e-50, 1e308, negative and huge counts, non-UTF-8 and special paths, unknown names)
and files (fit files and scene files with fields retyped, values replaced, bytes flipped
or truncated; datasets mutated), runs `attenfit.cli.main` in-process and asserts exit 0 or
2, never 1, with a one-line message. Only the verbs that answer in well under a second for
bad input are drawn freely; a scene that survives mutation is answered with one family,
and `report` and `gen` are drawn with values that are refused before any work.

`ATTENFIT_FUZZ_SCALE=10` runs ten times the examples (see tests/test_fuzz.py).
"""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path

import numpy as np
from _stderr import without_progress
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import attenfit as af
from attenfit.cli import main

SCALE = int(os.environ.get("ATTENFIT_FUZZ_SCALE", "1"))
WORK = Path(tempfile.mkdtemp(prefix="attenfit-cli-fuzz-"))
FAST = settings(max_examples=60 * SCALE, deadline=None, suppress_health_check=list(HealthCheck))
SLOW = settings(max_examples=12 * SCALE, deadline=None, suppress_health_check=list(HealthCheck))

NUMBERS = ["nan", "inf", "-inf", "1e-50", "1e308", "-1", "0", "1e40", "0.3", "2", "1e-320", "x", ""]
PATHS = ["/dev/zero", "/dev/null", "/", "nope/missing.json", "\udcff.json", "a\nb.json",
         "n" * 300 + ".json", "p/" * 2100, "\0.json"]  # fmt: skip
FAMILIES = ["yuksel", "spline", "gltf_range", "madams_tan", "inverse_square", "laser", ""]


def _run(argv: list[str], capsys) -> None:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code in (0, 2), f"exit {code} for {argv!r}: {err}"
    assert "internal error" not in err, f"{argv!r}: {err}"
    if code == 2:
        assert err and "Traceback" not in err, f"{argv!r}: {err}"


# ----------------------------------------------------------------------------- arguments
@FAST
@given(data=st.data())
def test_export_arguments(capsys, data):
    fam = data.draw(st.sampled_from(FAMILIES))
    argv = ["export", fam]
    for _ in range(data.draw(st.integers(0, 3))):
        opt = data.draw(st.sampled_from(["--param", "--lang", "--form", "--name", "--out"]))
        if opt == "--param":
            name = data.draw(st.sampled_from(["r", "r_max", "knot_values", "eps", "zz"]))
            argv += [opt, f"{name}={data.draw(st.sampled_from(NUMBERS))}"]
        elif opt == "--lang":
            argv += [opt, data.draw(st.sampled_from(["glsl", "hlsl", "wgsl", "c", "cuda", "rust"]))]
        elif opt == "--form":
            argv += [opt, data.draw(st.sampled_from(["shader", "stable", "fast"]))]
        elif opt == "--name":
            names = ["f", "1f", "a b", "main", "x\ny", "d", "n" * 100_000, "\udcff"]
            argv += [opt, data.draw(st.sampled_from(names))]
        else:
            outs = ["o.glsl", "", "o/../", "o" * 300 + ".glsl", "\udcfe.glsl"]
            argv += [opt, str(WORK / data.draw(st.sampled_from(outs)))]
    argv.append("--force")
    _run(argv, capsys)


@FAST
@given(data=st.data())
def test_refused_before_work(capsys, data):
    """`report`, `gen`, `truth` and `fit` with a bad value: refused at once (exit 2)."""
    verb = data.draw(st.sampled_from(["report", "gen", "truth", "fit"]))
    bad = data.draw(st.sampled_from(["nan", "inf", "-1", "0", "1e40", "x", "100000000000"]))
    if verb == "report":  # every value here is refused: a report is never started
        opt = data.draw(st.sampled_from(["--sweep-n", "--plane-px", "--families", "--emitters"]))
        argv = ["report", opt, bad, "--out", str(WORK / "rep")]
    elif verb == "fit":
        argv = ["fit", "--family", "yuksel", "--data", data.draw(st.sampled_from(PATHS))]
    else:
        opt = data.draw(st.sampled_from(["--radius", "--samples", "--seed", "--height"]))
        if opt in ("--radius", "--height") and bad in ("1e40", "100000000000"):
            bad = "-1"  # a huge light is a light: not what this test is about
        argv = [
            verb,
            "--emitter",
            "disk",
            "--radius",
            "0.5",
            opt,
            bad,
            "--out",
            str(WORK / "t.npz"),
        ]
        if verb == "gen":
            argv += ["--spp", "0"]  # refused too: no render ever starts
        argv.append("--force")
    if verb in ("report", "fit") or verb == "gen":
        code = main(argv)
        err = capsys.readouterr().err.strip()
        assert code == 2, f"exit {code} for {argv!r}: {err}"
        # one line, after any progress stage line (`attenfit fit: [  0.0 s] the data`)
        err = without_progress(err)
        assert "internal error" not in err and "\n" not in err
    else:
        _run(argv, capsys)


# ----------------------------------------------------------------------------- files
_FIT = {"family": "yuksel", "params": {"r": 0.25}, "metrics": {"max_rel_error": 0.01},
        "loss": 1e-5, "converged": True, "configuration": "disk"}  # fmt: skip
_HOSTILE = st.sampled_from(
    [None, "text", "x\r\n#define y", -1, 0, 1e308, 1e-50, [], {}, [1, [2]], True, "\u2028", 2**70]
)


@FAST
@given(data=st.data())
def test_export_on_mutated_fit_files(capsys, data):
    fit = json.loads(json.dumps(_FIT))
    for _ in range(data.draw(st.integers(1, 3))):
        key = data.draw(st.sampled_from(["family", "params", "metrics", "loss", "converged",
                                         "configuration", "r", "extra"]))  # fmt: skip
        if key == "r":
            fit["params"] = {"r": data.draw(_HOSTILE)}
        else:
            fit[key] = data.draw(_HOSTILE)
    text = json.dumps(fit, allow_nan=True)
    if data.draw(st.booleans()):
        raw = bytearray(text.encode())
        for i in data.draw(st.lists(st.integers(0, len(raw) - 1), max_size=3)):
            raw[i] ^= data.draw(st.integers(1, 255))
        text = raw.decode("utf-8", "replace")
    path = WORK / "fit.json"
    path.write_text(text, encoding="utf-8")
    lang = data.draw(st.sampled_from(["glsl", "c", "wgsl"]))
    _run(["export", str(path), "--lang", lang, "--out", str(WORK / "f.out"), "--force"], capsys)


_SCENE = {
    "tolerance": 0.05,
    "constraints": {"families": ["inverse_square"]},
    "lights": [{"kind": "sphere", "radius": 0.1, "height": 2.0}],
    "receivers": [{"kind": "plane", "extent": 1.0, "resolution": 4}],
}


def _toml(d: dict) -> str:
    def value(v):
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, float) and not np.isfinite(v):
            return "nan" if v != v else ("inf" if v > 0 else "-inf")
        return repr(v)

    lines = [f"{k} = {value(v)}" for k, v in d.items() if not isinstance(v, dict | list)]
    for k, v in d.items():
        if isinstance(v, dict):
            lines += [f"[{k}]", *(f"{a} = {value(b)}" for a, b in v.items())]
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            for item in v:
                lines += [f"[[{k}]]", *(f"{a} = {value(b)}" for a, b in item.items())]
    return "\n".join(lines) + "\n"


_SCENE_VALUES = st.sampled_from(
    [-1, 0, 1e-200, 1e300, float("nan"), float("inf"), "sphere", "spot", "$x^$", [0, 0, 1e-200],
     [0, 0, 0], [1, 2], 300, 2, True, "plane"]
)  # fmt: skip


@SLOW
@given(data=st.data())
def test_scene_on_mutated_files(capsys, data):
    scene = json.loads(json.dumps(_SCENE))
    table = data.draw(st.sampled_from(["top", "lights", "receivers"]))
    keys = {
        "top": ["tolerance", "name", "seed", "error_floor"],
        "lights": ["kind", "radius", "height", "position", "normal", "range", "umbra"],
        "receivers": ["kind", "extent", "resolution", "normal", "center", "n", "distance"],
    }[table]
    key = data.draw(st.sampled_from(keys))
    value = data.draw(_SCENE_VALUES)
    (scene if table == "top" else scene[table][0])[key] = value
    path = WORK / "scene.toml"
    path.write_text(_toml(scene), encoding="utf-8")
    _run(["scene", str(path), "--quiet", "--out", str(WORK / "scene-out"), "--force"], capsys)


@FAST
@given(data=st.data())
def test_fit_on_mutated_datasets(capsys, data):
    ds = af.random_receivers(af.SphereEmitter([0, 0, 0], 0.5), 8, 1.0, 3.0, seed=1)
    arrays = {"points": ds.points, "normals": ds.normals, "E": ds.E, "stderr": ds.stderr}
    name = data.draw(st.sampled_from(sorted(arrays)))
    arr = np.array(arrays[name], dtype=np.float64)
    how = data.draw(st.sampled_from(["value", "shape", "dtype"]))
    if how == "value":
        arr.flat[data.draw(st.integers(0, arr.size - 1))] = data.draw(
            st.sampled_from([np.nan, np.inf, -1.0, 0.0, 1e308, -1e-320])
        )
    elif how == "shape":
        arr = arr[: data.draw(st.integers(0, len(arr) - 1))]
    else:
        arr = arr.astype(data.draw(st.sampled_from([np.float16, np.int64, np.complex64, ">f8"])))
    arrays[name] = arr
    path = WORK / "data.npz"
    ds.save(path, force=True)
    raw = dict(np.load(path))
    raw.update(arrays)
    np.savez(path, **raw)
    _run(["fit", "--family", "yuksel", "--data", str(path), "--out", str(WORK / "fit.json"),
          "--force"], capsys)  # fmt: skip
