"""Fuzzing the public API with hypothesis: arbitrary floats, shapes and mutated files.

Floats include subnormals, +-0, +-inf and NaN. Shapes are fixed per property (so nothing
recompiles per example). The properties:

* families: a valid distance (finite, >= 0) never gives NaN, and the value is >= 0; the
  documented answers elsewhere (families.py): negative d is d = 0, NaN gives NaN, +inf 0;
* irradiance: receivers outside a light give finite, non-negative E;
* fit: arbitrary data either raise a documented `AttenfitError` before any compilation or
  give a `FitResult`; a result that claims convergence has a finite loss and parameters;
* `Dataset.load` and `Scene.load` on random and mutated files (bytes flipped, truncated,
  keys deleted or retyped): a valid object or an `AttenfitError` with a one-line message.

`EXAMPLES` counts the examples each property ran; the last test checks and prints them.
"""

from __future__ import annotations

import collections
import json
import math
import os
import tempfile
import tomllib
from pathlib import Path

import jax.numpy as jnp
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

import attenfit as af
from attenfit.scene import Scene

EXAMPLES: collections.Counter = collections.Counter()
OUTCOMES: collections.Counter = collections.Counter()  # how the examples ended
#: ATTENFIT_FUZZ_SCALE=10 runs ten times the examples (a longer hunt than the test suite's).
SCALE = int(os.environ.get("ATTENFIT_FUZZ_SCALE", "1"))
FAST = settings(max_examples=40 * SCALE, deadline=None, suppress_health_check=list(HealthCheck))
WORK = Path(tempfile.mkdtemp(prefix="attenfit-fuzz-"))

ANY64 = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True, width=64)
ANY32 = st.floats(allow_nan=True, allow_infinity=True, allow_subnormal=True, width=32)


def _one_line(exc: BaseException) -> None:
    assert isinstance(exc, af.AttenfitError), f"{type(exc).__name__}: {exc}"
    assert isinstance(exc, ValueError | TypeError | KeyError)
    assert "\n" not in str(exc).strip(), str(exc)


# ----------------------------------------------------------------------------- families
FAMILIES = sorted(af.list_families())
SINGULAR = {n for n in FAMILIES if af.get_family(n).singular}


@FAST
@given(
    name=st.sampled_from(FAMILIES),
    dtype=st.sampled_from([np.float32, np.float64]),
    data=st.data(),
)
def test_families_on_arbitrary_distances(name, dtype, data):
    EXAMPLES["families"] += 1
    elems = ANY32 if dtype == np.float32 else ANY64
    d = data.draw(hnp.arrays(dtype, (8,), elements=elems))
    fam = af.get_family(name)()
    f = np.asarray(fam(jnp.asarray(d)))
    assert f.dtype == dtype and f.shape == d.shape
    valid = np.isfinite(d) & (d >= 0)
    if name in SINGULAR:  # +inf where 1/d^2 overflows, never NaN
        assert not np.isnan(f[valid]).any() and (f[valid] >= 0).all()
    else:
        assert np.isfinite(f[valid]).all() and (f[valid] >= 0).all(), (d, f)
    assert np.isnan(f[np.isnan(d)]).all()
    assert (f[d == np.inf] == 0).all()
    neg = d < 0
    if neg.any():
        f0 = np.asarray(fam(jnp.zeros(8, dtype)))[0]
        np.testing.assert_array_equal(f[neg], f0)


# ----------------------------------------------------------------------------- irradiance
def _emitter(kind: str, r: float, axis: np.ndarray):
    if kind == "sphere":
        return af.SphereEmitter([0.0, 0.0, 0.0], r)
    if kind == "disk":
        return af.DiskEmitter([0.0, 0.0, 0.0], axis, r, two_sided=True)
    return af.CapsuleEmitter(-r * axis, r * axis, r)


unit3 = hnp.arrays(np.float64, (3,), elements=st.floats(-1, 1)).filter(
    lambda v: np.linalg.norm(v) > 1e-3
)


@FAST
@given(
    kind=st.sampled_from(["sphere", "disk", "capsule"]),
    log_r=st.floats(-6, 6),
    log_k=hnp.arrays(np.float64, (8,), elements=st.floats(-6, 9)),
    dirs=hnp.arrays(np.float64, (8, 3), elements=st.floats(-1, 1)),
    normals=hnp.arrays(np.float64, (8, 3), elements=st.floats(-1, 1)),
    axis=unit3,
    dtype=st.sampled_from([np.float32, np.float64]),
)
def test_irradiance_is_finite_and_nonnegative_outside_the_light(
    kind, log_r, log_k, dirs, normals, axis, dtype
):
    """Receivers at 1 + 1e-6 to 1e9 radii from the light (capsule: from its segment)."""
    EXAMPLES["irradiance"] += 1
    dirs = np.where(np.linalg.norm(dirs, axis=1, keepdims=True) > 1e-3, dirs, [0.0, 0.0, 1.0])
    normals = np.where(
        np.linalg.norm(normals, axis=1, keepdims=True) > 1e-3, normals, [0.0, 1.0, 0.0]
    )
    dirs = dirs / np.linalg.norm(dirs, axis=1, keepdims=True)
    axis = axis / np.linalg.norm(axis)
    r = 10.0**log_r
    em = _emitter(kind, r, axis)
    dist = r * (1.0 + 10.0**log_k)  # 1 + 1e-6 to 1e9 radii
    if kind == "capsule":  # offset from the segment's nearest point, perpendicular to it
        perp = dirs - (dirs @ axis)[:, None] * axis
        ok = np.linalg.norm(perp, axis=1) > 1e-3
        helper = [1.0, 0.0, 0.0] if abs(axis[0]) < 0.9 else [0.0, 1.0, 0.0]
        perp = np.where(ok[:, None], perp, np.cross(axis, helper))
        perp /= np.linalg.norm(perp, axis=1, keepdims=True)
        pts = r * axis * np.linspace(-1.0, 1.0, 8)[:, None] + dist[:, None] * perp
    else:
        pts = dist[:, None] * dirs
    E = np.asarray(af.irradiance(em, pts.astype(dtype), normals.astype(dtype)))
    assert E.dtype == dtype
    assert np.isfinite(E).all() and (E >= 0).all(), (kind, r, pts, normals, E)


# ----------------------------------------------------------------------------- fit
# any floats, or a valid sample (positive and finite, subnormals and huge values included)
POSITIVE = st.floats(0, 1e300, allow_subnormal=True).filter(lambda x: x > 0)
SAMPLES = st.one_of(
    hnp.arrays(np.float64, (16,), elements=ANY64),
    hnp.arrays(np.float64, (16,), elements=POSITIVE),
    hnp.arrays(np.float64, (16,), elements=st.floats(1e-3, 1e3)),
)


@FAST
@given(d=SAMPLES, target=SAMPLES)
def test_fit_on_arbitrary_data_errs_early_or_reports(d, target):
    EXAMPLES["fit"] += 1
    try:
        res = af.fit(af.Yuksel(), d, target, max_steps=32)
    except af.AttenfitError as exc:
        _one_line(exc)
        OUTCOMES["fit: refused"] += 1
        return
    assert isinstance(res, af.FitResult)
    OUTCOMES[f"fit: converged={res.converged}"] += 1
    json.dumps(res.to_dict(), allow_nan=False)
    if res.converged:
        assert math.isfinite(res.loss)
        assert all(math.isfinite(v) for v in res.params.values())


# ----------------------------------------------------------------------------- files
def _valid_dataset_bytes() -> bytes:
    em = af.DiskEmitter([0.0, 0.0, 0.0], [0.0, 0.0, 1.0], 0.5)
    path = WORK / "valid.npz"
    if not path.exists():
        af.facing_sweep(em, 0.1, 5.0, n=4, dtype="float64").save(path)
    return path.read_bytes()


def _mutate(raw: bytes, data) -> bytes:
    how = data.draw(st.sampled_from(["flip", "truncate", "random", "splice"]))
    if how == "flip":
        b = bytearray(raw)
        for i in data.draw(st.lists(st.integers(0, len(b) - 1), min_size=1, max_size=8)):
            b[i] ^= data.draw(st.integers(1, 255))
        return bytes(b)
    if how == "truncate":
        return raw[: data.draw(st.integers(0, len(raw) - 1))]
    if how == "random":
        return data.draw(st.binary(max_size=600))
    i = data.draw(st.integers(0, len(raw)))
    return raw[:i] + data.draw(st.binary(min_size=1, max_size=64)) + raw[i:]


def _retype(value, data):
    return data.draw(
        st.sampled_from(
            [None, "text", -1, 0, 1e308, float("nan"), float("inf"), [], {}, [1, 2], True]
        )
    )


@FAST
@given(data=st.data())
def test_dataset_load_on_mutated_files(data):
    EXAMPLES["dataset files"] += 1
    raw = _valid_dataset_bytes()
    path = WORK / "mutated.npz"
    if data.draw(st.booleans()):
        path.write_bytes(_mutate(raw, data))
    else:  # a well-formed file with a damaged header: a key deleted or retyped
        import io

        with np.load(io.BytesIO(raw), allow_pickle=False) as npz:
            arrays = {k: npz[k] for k in npz.files}
        header = json.loads(str(arrays.pop("header")))
        where = header if data.draw(st.booleans()) else header["emitter"]
        key = data.draw(st.sampled_from(sorted(where)))
        if data.draw(st.booleans()):
            del where[key]
        else:
            where[key] = _retype(where[key], data)
        if data.draw(st.booleans()):  # or an array retyped
            name = data.draw(st.sampled_from(["points", "normals", "E", "stderr"]))
            arrays[name] = data.draw(
                st.sampled_from(
                    [
                        arrays[name].astype(np.complex128),
                        arrays[name].astype(np.int8),
                        arrays[name][:2],
                        np.full_like(arrays[name], np.nan),
                        np.array("text"),
                    ]
                )
            )
        with open(path, "wb") as fh:
            np.savez(fh, header=np.asarray(json.dumps(header)), **arrays)
    try:
        ds = af.Dataset.load(path)
    except af.AttenfitError as exc:
        _one_line(exc)
        assert isinstance(exc, af.BadValueError | af.BadTypeError | af.UnknownNameError)
        OUTCOMES[f"dataset: {type(exc).__name__}"] += 1
        return
    OUTCOMES["dataset: loaded"] += 1
    assert len(ds) == len(ds.E) and np.isfinite(ds.E).all()


SCENE = """\
name = "fuzz"
tolerance = 0.05
error_floor = 0.01
seed = 3
[constraints]
float32 = false
families = ["yuksel", "inverse_square"]
[[lights]]
kind = "spot"
radius = 0.05
position = [0.0, 0.0, 3.0]
intensity = 2.0
range = 20.0
umbra = 40.0
penumbra = 30.0
[[lights]]
kind = "capsule"
radius = 0.1
length = 1.0
height = 2.5
[[receivers]]
kind = "plane"
extent = 4.0
resolution = 8
[[receivers]]
kind = "distribution"
distance = [0.5, 5.0]
angle = [0.0, 60.0]
n = 16
"""


def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    if isinstance(v, float) and math.isinf(v):
        return "inf" if v > 0 else "-inf"
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + "}"
    return repr(v)


def _dump_toml(d: dict) -> str:
    lines = []
    for k, v in d.items():
        if not isinstance(v, dict | list) or (isinstance(v, list) and not all(isinstance(x, dict) for x in v)) or v == []:  # fmt: skip
            if v is not None:
                lines.append(f"{k} = {_toml_value(v)}")
    for k, v in d.items():
        if isinstance(v, dict):
            lines.append(f"[{k}]")
            lines += [f"{kk} = {_toml_value(x)}" for kk, x in v.items() if x is not None]
        elif isinstance(v, list) and v and all(isinstance(x, dict) for x in v):
            for t in v:
                lines.append(f"[[{k}]]")
                lines += [f"{kk} = {_toml_value(x)}" for kk, x in t.items() if x is not None]
    return "\n".join(lines) + "\n"


@FAST
@given(data=st.data())
def test_scene_load_on_mutated_files(data):
    EXAMPLES["scene files"] += 1
    path = WORK / "mutated.toml"
    if data.draw(st.booleans()):
        path.write_bytes(_mutate(SCENE.encode(), data))
    else:  # valid TOML, damaged scene: keys deleted or retyped anywhere
        d = tomllib.loads(SCENE)
        tables = [d, d["constraints"], *d["lights"], *d["receivers"]]
        for _ in range(data.draw(st.integers(1, 3))):
            t = data.draw(st.sampled_from(tables))
            if not t:
                continue
            key = data.draw(st.sampled_from(sorted(t)))
            if data.draw(st.booleans()):
                del t[key]
            else:
                t[key] = _retype(t[key], data)
        path.write_text(_dump_toml(d))
    try:
        scene = Scene.load(path)
    except af.AttenfitError as exc:
        _one_line(exc)
        OUTCOMES[f"scene: {type(exc).__name__}"] += 1
        return
    OUTCOMES["scene: loaded"] += 1
    assert isinstance(scene, Scene) and scene.lights and 0 < scene.tolerance <= 1


GOOD = st.sampled_from(["1", "0.5", "2e-3", "40", "1e3"])
BAD = st.sampled_from(["0", "-1", "nan", "inf", "-inf", "1e-30", "1e300", "1e40", "abc", ""])
NUMBERS = st.one_of(GOOD, GOOD, GOOD, BAD)  # mostly valid, so that some runs get far


@settings(max_examples=30 * SCALE, deadline=None, suppress_health_check=list(HealthCheck))
@given(data=st.data())
def test_cli_truth_on_arbitrary_options(data):
    """`attenfit truth` with arbitrary option values: exit 0 with a valid file, or exit 2."""
    import contextlib
    import io

    from attenfit.cli import main

    EXAMPLES["cli truth"] += 1
    out = WORK / "cli.npz"
    out.unlink(missing_ok=True)
    argv = ["truth", "--emitter", data.draw(st.sampled_from(["sphere", "disk", "capsule"]))]
    argv += ["--radius", data.draw(NUMBERS)]
    for opt in ("--intensity", "--length", "--height", "--extent"):
        if data.draw(st.integers(0, 3)) == 0:
            argv += [opt, data.draw(NUMBERS)]
    if data.draw(st.booleans()):
        lo, hi = data.draw(NUMBERS), data.draw(NUMBERS)
        argv += ["--range", f"{lo}:{hi}"]
    argv += ["--receivers", data.draw(st.sampled_from(["facing", "plane", "random"]))]
    argv += ["--samples", data.draw(st.sampled_from(["4", "4", "4", "0", "-2", "x"]))]
    argv += ["--dtype", data.draw(st.sampled_from(["float32", "float64"])), "--out", str(out)]
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    assert code in (0, 2), (argv, err.getvalue())
    OUTCOMES[f"cli truth: exit {code}"] += 1
    if code == 2:
        assert len(err.getvalue().strip().splitlines()) == 1, err.getvalue()
        assert not out.exists()
    else:
        ds = af.Dataset.load(out)
        assert np.isfinite(ds.E).all() and (ds.E >= 0).all()


def test_zz_examples_ran(capsys):
    """Every property ran examples (pytest -s shows the counts)."""
    with capsys.disabled():
        print(f"\nfuzz examples: {dict(EXAMPLES)}, total {sum(EXAMPLES.values())}")
        print(f"outcomes: {dict(sorted(OUTCOMES.items()))}")
    if len(EXAMPLES) == 6:  # the whole file ran (not a -k selection)
        assert min(EXAMPLES.values()) >= 20 * SCALE


@pytest.fixture(scope="module", autouse=True)
def _cleanup():
    yield
    import shutil

    shutil.rmtree(WORK, ignore_errors=True)
