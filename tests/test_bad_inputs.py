"""The catalogue of bad inputs: each gets one clear line, never a traceback or a wrong answer.

Table-driven. `API_CASES` call the Python API and expect a given subclass of
`attenfit.AttenfitError` (which is also a `ValueError`, `TypeError` or `KeyError`) whose
one-line message contains a fragment naming the bad value. `CLI_CASES` run
`attenfit.cli.main` and expect exit 2 with exactly one line on stderr that contains the
fragment. The files they read (datasets, scene TOML, fit JSON) are made once per module:
truncated, corrupt, foreign, zero-byte and text files, a folder where a file should be.
Tests run as root, so "unreadable" is a folder in place of a file, not `chmod 000`.
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from _stderr import without_progress

import attenfit as af
from attenfit import (
    AttenfitError,
    BadTypeError,
    BadValueError,
    DataFileError,
    OutputExistsError,
    UnknownNameError,
)
from attenfit.cli import main
from attenfit.scene import Scene

REPO = Path(__file__).resolve().parents[1]

VALID_SCENE = """\
tolerance = 0.05
[[lights]]
kind = "sphere"
radius = 0.1
height = 2.0
[[receivers]]
kind = "distribution"
distance = [0.5, 5.0]
n = 8
"""


def _npz(path: Path, header: Any = None, **arrays: Any) -> Path:
    """Write an .npz directly (no validation): header JSON (if given) plus arrays."""
    if header is not None:
        arrays["header"] = np.asarray(header if isinstance(header, str) else json.dumps(header))
    with open(path, "wb") as fh:
        np.savez(fh, **arrays)
    return path


def _patch_central(raw: bytes, member: str, offset: int, value: int) -> bytes:
    """`raw` (a zip) with a 2-byte field of `member`'s central-directory entry OR-ed with `value`."""
    b = bytearray(raw)
    i = b.find(b"PK\x01\x02")
    while i >= 0:
        n = int.from_bytes(b[i + 28 : i + 30], "little")
        if bytes(b[i + 46 : i + 46 + n]) == member.encode():
            field = int.from_bytes(b[i + offset : i + offset + 2], "little") | value
            b[i + offset : i + offset + 2] = field.to_bytes(2, "little")
            return bytes(b)
        i = b.find(b"PK\x01\x02", i + 4)
    raise AssertionError(f"{member} not in the zip")


class Files:
    """Every file the catalogue needs, made once in a temporary folder."""

    def __init__(self, root: Path):
        self.root = root
        self.missing = root / "no_such_file.npz"
        self.missing_dir = root / "no_such_dir"
        self.folder = root / "a_folder.npz"  # a folder where a file is expected
        self.folder.mkdir()
        self.regular = root / "regular_file"  # a file where a folder is expected
        self.regular.write_text("x")
        self.existing = root / "existing.npz"
        self.existing.write_bytes(b"previous output")
        self.full_dir = root / "full_dir"  # a non-empty output folder
        self.full_dir.mkdir()
        (self.full_dir / "keep.txt").write_text("previous")
        self.zero = root / "zero.npz"
        self.zero.write_bytes(b"")
        self.text = root / "text.npz"
        self.text.write_text("this is not a dataset\n")

        emitter = af.SphereEmitter([0.0, 0.0, 0.0], 1.0)
        ds = af.facing_sweep(emitter, 2.0, 20.0, n=8, dtype="float64")
        self.valid = ds.save(root / "valid.npz")
        raw = self.valid.read_bytes()
        self.truncated = root / "truncated.npz"
        self.truncated.write_bytes(raw[: len(raw) // 2])
        self.flipped = root / "flipped.npz"  # the zip's central directory scrambled
        self.flipped.write_bytes(raw[:-40] + bytes(b ^ 0xFF for b in raw[-40:]))

        self.encrypted = root / "encrypted.npz"  # the zip says its member is encrypted
        self.encrypted.write_bytes(_patch_central(raw, "header.npy", 8, 0x01))
        self.method = root / "method.npz"  # ... or compressed by an unknown method
        self.method.write_bytes(_patch_central(raw, "header.npy", 10, 99))

        header = {
            "format": "attenfit.dataset",
            "version": 1,
            "emitter": emitter.to_dict(),
            "provenance": {},
            "n": 8,
        }
        arrays = {k: np.asarray(getattr(ds, k)) for k in ("points", "normals", "E", "stderr")}
        self.foreign = _npz(root / "foreign.npz", x=np.arange(3))
        self.bad_json = _npz(root / "bad_json.npz", "{not json", **arrays)
        self.list_header = _npz(root / "list_header.npz", [1, 2, 3], **arrays)
        self.version = _npz(root / "version.npz", {**header, "version": 99}, **arrays)
        self.no_stderr = _npz(
            root / "no_stderr.npz", header, **{k: v for k, v in arrays.items() if k != "stderr"}
        )
        self.nan_E = _npz(root / "nan_E.npz", header, **{**arrays, "E": np.full(8, np.nan)})
        self.complex_E = _npz(
            root / "complex_E.npz", header, **{**arrays, "E": arrays["E"].astype(complex)}
        )
        self.short_E = _npz(root / "short_E.npz", header, **{**arrays, "E": arrays["E"][:5]})
        self.wrong_n = _npz(root / "wrong_n.npz", {**header, "n": 9}, **arrays)
        self.cone = _npz(
            root / "cone.npz", {**header, "emitter": {"kind": "cone", "radius": 1.0}}, **arrays
        )
        self.neg_radius = _npz(
            root / "neg_radius.npz",
            {**header, "emitter": {**emitter.to_dict(), "radius": -1.0}},
            **arrays,
        )
        self.pickled = root / "pickled.npz"
        with open(self.pickled, "wb") as fh:
            np.savez(fh, header=np.array([{"format": "attenfit.dataset"}], dtype=object), **arrays)

        self.scene = self._scene("valid", VALID_SCENE)
        self.scene_syntax = self._scene("syntax", VALID_SCENE.replace("= 0.05", "= = 0.05"))
        self.scene_no_tol = self._scene("no_tol", VALID_SCENE.replace("tolerance = 0.05", ""))
        self.scene_tol_type = self._scene("tol_type", VALID_SCENE.replace("0.05", '"five"'))
        self.scene_tol_nan = self._scene("tol_nan", VALID_SCENE.replace("0.05", "nan"))
        self.scene_kind = self._scene("kind", VALID_SCENE.replace('"sphere"', '"laser"'))
        self.scene_neg_r = self._scene("neg_r", VALID_SCENE.replace("0.1", "-1.0"))
        self.scene_inf_r = self._scene("inf_r", VALID_SCENE.replace("0.1", "inf"))
        self.scene_str_r = self._scene("str_r", VALID_SCENE.replace("0.1", '"big"'))
        self.scene_huge_r = self._scene(
            "huge_r",
            VALID_SCENE.replace("0.1", "1e300")
            .replace("2.0", "1e301")
            .replace("[0.5, 5.0]", "[2e300, 5e300]"),
        )
        self.scene_extra = self._scene(
            "extra", VALID_SCENE.replace("radius = 0.1", "radius = 0.1\ncolour = 1")
        )
        self.scene_backwards = self._scene(
            "backwards", VALID_SCENE.replace("[0.5, 5.0]", "[5.0, 0.5]")
        )
        self.scene_short = self._scene("short", VALID_SCENE.replace("[0.5, 5.0]", "[5.0]"))
        self.scene_no_lights = self._scene(
            "no_lights", VALID_SCENE.split("[[lights]]")[0] + VALID_SCENE.split("height = 2.0")[1]
        )
        self.scene_n_zero = self._scene("n_zero", VALID_SCENE.replace("n = 8", "n = 0"))
        self.scene_n_float = self._scene("n_float", VALID_SCENE.replace("n = 8", "n = 2.5"))
        self.scene_family = self._scene(
            "family", VALID_SCENE + "[constraints]\nfamilies = ['nope']\n"
        )
        self.scene_recv = self._scene("recv", VALID_SCENE.replace('"distribution"', '"cloud"'))
        self.scene_binary = root / "binary.toml"
        self.scene_binary.write_bytes(b"\xff\xfe\x00\x80garbage")
        self.scene_zero = self._scene("zero", "")

        self.fit_text = root / "fit_text.json"
        self.fit_text.write_text("no json here")
        self.fit_nofamily = root / "fit_nofamily.json"
        self.fit_nofamily.write_text(json.dumps({"params": {"r": 1.0}}))
        self.fit_nan = root / "fit_nan.json"
        self.fit_nan.write_text(json.dumps({"family": "yuksel", "params": {"r": "nan"}}))

    def _scene(self, name: str, text: str) -> Path:
        path = self.root / f"scene_{name}.toml"
        path.write_text(text)
        return path


@pytest.fixture(scope="module")
def files(tmp_path_factory) -> Files:
    return Files(tmp_path_factory.mktemp("bad_inputs"))


@dataclasses.dataclass(frozen=True)
class Case:
    id: str
    call: Callable[[Files], Any]
    exc: type[AttenfitError]
    fragment: str


SPHERE = [0.0, 0.0, 0.0]
D = np.geomspace(1.5, 20.0, 16)
T = 1 / D**2


def _sphere():
    return af.SphereEmitter(SPHERE, 1.0)


def _facing_away():
    """Receivers below a sphere whose normals point away from it: every weight is 0."""
    pts = np.array([[0.0, 0.0, -3.0], [0.0, 0.0, -4.0]])
    nrm = np.array([[0.0, 0.0, -1.0], [0.0, 0.0, -1.0]])
    return af.Dataset(_sphere(), pts, nrm, np.zeros(2), np.zeros(2))


class _Dup(af.Family):
    """A user family whose name is taken already."""

    name = "yuksel"
    formula = "1/d^2"
    source = "test"
    default_free = ()
    shader_form = af.no_shader_form

    def __call__(self, d):
        return 1 / d**2


class _BadName(af.Family):
    name = "not an identifier"
    formula = "1/d^2"
    source = "test"
    default_free = ()
    shader_form = af.no_shader_form

    def __call__(self, d):
        return 1 / d**2


API_CASES = [
    # --- emitter constructors: non-numeric, NaN, inf, zero, negative, absurd, dtypes, shapes
    Case(
        "sphere-radius-str",
        lambda f: af.SphereEmitter(SPHERE, "a"),
        BadTypeError,
        "radius must be a real number",
    ),
    Case(
        "sphere-radius-nan",
        lambda f: af.SphereEmitter(SPHERE, float("nan")),
        BadValueError,
        "radius must be finite, got nan",
    ),
    Case(
        "sphere-radius-inf",
        lambda f: af.SphereEmitter(SPHERE, float("inf")),
        BadValueError,
        "radius must be finite, got inf",
    ),
    Case(
        "sphere-radius-zero",
        lambda f: af.SphereEmitter(SPHERE, 0.0),
        BadValueError,
        "radius must be > 0, got 0.0",
    ),
    Case(
        "sphere-radius-negative",
        lambda f: af.SphereEmitter(SPHERE, -1.0),
        BadValueError,
        "radius must be > 0, got -1.0",
    ),
    Case(
        "sphere-radius-absurd",
        lambda f: af.SphereEmitter(SPHERE, 1e300),
        BadValueError,
        "got 1e+300",
    ),
    Case(
        "sphere-radius-tiny",
        lambda f: af.SphereEmitter(SPHERE, 1e-300),
        BadValueError,
        "got 1e-300",
    ),
    Case(
        "sphere-radius-complex",
        lambda f: af.SphereEmitter(SPHERE, 1 + 2j),
        BadTypeError,
        "dtype complex128",
    ),
    Case(
        "sphere-radius-bool", lambda f: af.SphereEmitter(SPHERE, True), BadTypeError, "dtype bool"
    ),
    Case(
        "sphere-center-object",
        lambda f: af.SphereEmitter(np.array([0, 0, 0], dtype=object), 1.0),
        BadTypeError,
        "center must be real (float or int), got dtype object",
    ),
    Case(
        "sphere-center-shape",
        lambda f: af.SphereEmitter([0.0, 0.0], 1.0),
        BadValueError,
        "center must be shape (3,), got shape (2,)",
    ),
    Case(
        "sphere-center-nan",
        lambda f: af.SphereEmitter([0.0, 0.0, float("nan")], 1.0),
        BadValueError,
        "center must be finite, got [0.0, 0.0, nan]",
    ),
    Case(
        "sphere-center-none",
        lambda f: af.SphereEmitter(None, 1.0),
        BadTypeError,
        "center must be a real number or array, got NoneType",
    ),
    Case(
        "sphere-intensity-negative",
        lambda f: af.SphereEmitter(SPHERE, 1.0, -1.0),
        BadValueError,
        "intensity must be > 0, got -1.0",
    ),
    Case(
        "disk-normal-zero",
        lambda f: af.DiskEmitter(SPHERE, [0, 0, 0], 1.0),
        BadValueError,
        "normal must be a non-zero 3-vector",
    ),
    Case(
        "disk-two-sided-str",
        lambda f: af.DiskEmitter(SPHERE, [0, 0, 1], 1.0, 1.0, "yes"),
        BadTypeError,
        "two_sided must be True or False, got 'yes'",
    ),
    Case(
        "capsule-a-nan",
        lambda f: af.CapsuleEmitter([0, 0, float("nan")], [1, 0, 0], 1.0),
        BadValueError,
        "a must be finite",
    ),
    Case(
        "capsule-radius-inf",
        lambda f: af.CapsuleEmitter(SPHERE, [1, 0, 0], float("inf")),
        BadValueError,
        "radius must be finite, got inf",
    ),
    Case(
        "emitter-unknown-kind",
        lambda f: af.emitter_from_dict({"kind": "cone"}),
        UnknownNameError,
        "unknown emitter kind 'cone'",
    ),
    Case(
        "emitter-dict-not-dict",
        lambda f: af.emitter_from_dict([1]),
        BadTypeError,
        "must be a dict, got list",
    ),
    Case(
        "emitter-dict-missing",
        lambda f: af.emitter_from_dict({"kind": "sphere", "radius": 1.0}),
        BadValueError,
        "lacks ['center']",
    ),
    # --- families
    Case(
        "family-param-negative",
        lambda f: af.Yuksel(r=-1.0),
        BadValueError,
        "parameter 'r' must be > 0, got -1.0",
    ),
    Case(
        "family-param-nan",
        lambda f: af.Yuksel(r=float("nan")),
        BadValueError,
        "parameter 'r' must be a number, got NaN",
    ),
    Case(
        "family-param-str",
        lambda f: af.Yuksel(r="a"),
        BadTypeError,
        "parameter 'r' must be a real number or array, got 'a'",
    ),
    Case("family-param-complex", lambda f: af.Yuksel(r=1j), BadTypeError, "got 1j"),
    Case(
        "family-unknown", lambda f: af.get_family("nope"), UnknownNameError, "unknown family 'nope'"
    ),
    Case(
        "family-name-not-str",
        lambda f: af.get_family(3),
        BadTypeError,
        "family name must be a string, got 3",
    ),
    Case(
        "family-replace-unknown",
        lambda f: af.Yuksel().replace(q=1.0),
        UnknownNameError,
        "has no parameter 'q'",
    ),
    Case("register-not-class", lambda f: af.register_family(3), BadTypeError, "got 3"),
    Case(
        "register-abstract",
        lambda f: af.register_family(af.Family),
        BadTypeError,
        "Family is abstract",
    ),
    Case(
        "register-duplicate",
        lambda f: af.register_family(_Dup),
        BadValueError,
        "a family named 'yuksel' is registered already",
    ),
    Case(
        "register-bad-name",
        lambda f: af.register_family(_BadName),
        BadValueError,
        "got 'not an identifier'",
    ),
    # --- irradiance
    Case(
        "irradiance-emitter-str",
        lambda f: af.irradiance("sphere", [[0, 0, 2.0]], [[0, 0, 1.0]]),
        BadTypeError,
        "got str",
    ),
    Case(
        "irradiance-last-axis",
        lambda f: af.irradiance(_sphere(), np.ones((4, 2)), np.ones((4, 2))),
        BadValueError,
        "got shapes (4, 2) and (4, 2)",
    ),
    Case(
        "irradiance-mismatch",
        lambda f: af.irradiance(_sphere(), np.ones((4, 3)), np.ones((5, 3))),
        BadValueError,
        "points (4, 3) and normals (5, 3)",
    ),
    Case(
        "irradiance-complex",
        lambda f: af.irradiance(_sphere(), np.ones((4, 3)) + 0j, np.ones((4, 3))),
        BadTypeError,
        "points must be real (float or int), got dtype complex128",
    ),
    Case(
        "irradiance-object",
        lambda f: af.irradiance(_sphere(), np.ones((1, 3), dtype=object), np.ones((1, 3))),
        BadTypeError,
        "got dtype object",
    ),
    Case(
        "irradiance-text",
        lambda f: af.irradiance(_sphere(), np.ones((1, 3)), "up"),
        BadTypeError,
        "normals must be real",
    ),
    # --- fit, fit_many, fit_dataset
    Case(
        "fit-empty",
        lambda f: af.fit(af.Yuksel(), np.array([]), np.array([])),
        BadValueError,
        "target is empty",
    ),
    Case(
        "fit-mismatch",
        lambda f: af.fit(af.Yuksel(), D, T[:5]),
        BadValueError,
        "d has shape (16,) but target has shape (5,)",
    ),
    Case(
        "fit-d-nan",
        lambda f: af.fit(af.Yuksel(), np.r_[D[:-1], np.nan], T),
        BadValueError,
        "d must be finite distances >= 0, got nan",
    ),
    Case(
        "fit-d-negative",
        lambda f: af.fit(af.Yuksel(), -D, T),
        BadValueError,
        "got -1.5",
    ),
    Case(
        "fit-target-inf",
        lambda f: af.fit(af.Yuksel(), D, np.r_[T[:-1], np.inf]),
        BadValueError,
        "target must be finite, got inf",
    ),
    Case(
        "fit-target-zero",
        lambda f: af.fit(af.Yuksel(), D, 0 * T),
        BadValueError,
        "target must be > 0 for the 'relative' loss",
    ),
    Case(
        "fit-complex",
        lambda f: af.fit(af.Yuksel(), D, T + 0j),
        BadTypeError,
        "target must be a floating-point array, got dtype complex128",
    ),
    Case(
        "fit-object",
        lambda f: af.fit(af.Yuksel(), D.astype(object), T),
        BadTypeError,
        "got dtype object",
    ),
    Case("fit-text", lambda f: af.fit(af.Yuksel(), "far", T), BadTypeError, "got dtype <U3"),
    Case(
        "fit-2d",
        lambda f: af.fit(af.Yuksel(), D[None], T[None]),
        BadValueError,
        "got shape (1, 16)",
    ),
    Case(
        "fit-loss",
        lambda f: af.fit(af.Yuksel(), D, T, loss="l1"),
        UnknownNameError,
        "unknown loss 'l1'",
    ),
    Case(
        "fit-solver",
        lambda f: af.fit(af.Yuksel(), D, T, solver="adam"),
        UnknownNameError,
        "unknown solver 'adam'",
    ),
    Case(
        "fit-free",
        lambda f: af.fit(af.Yuksel(), D, T, free=("q",)),
        UnknownNameError,
        "free names 'q'",
    ),
    Case(
        "fit-max-steps",
        lambda f: af.fit(af.Yuksel(), D, T, max_steps=0),
        BadValueError,
        "max_steps must be a positive integer, got 0",
    ),
    Case(
        "fit-rtol-nan",
        lambda f: af.fit(af.Yuksel(), D, T, rtol=float("nan")),
        BadValueError,
        "rtol must be a finite number >= 0 (or None), got nan",
    ),
    Case(
        "fit-weights-negative",
        lambda f: af.fit(af.Yuksel(), D, T, weights=-np.ones(16)),
        BadValueError,
        "weights must be finite and >= 0",
    ),
    Case("fit-model-str", lambda f: af.fit("yuksel", D, T), BadTypeError, "got str"),
    Case(
        "fit-pair-unknown-free",
        lambda f: af.fit((lambda d, p: 1 / (d * d + p["e"]), {"e": 1.0}), D, T, free=("r",)),
        UnknownNameError,
        "'r'",
    ),
    Case(
        "fit-many-1d",
        lambda f: af.fit_many(af.Yuksel(), D, T),
        BadValueError,
        "target must have shape (batch, n), got shape (16,)",
    ),
    Case(
        "fit-many-mismatch",
        lambda f: af.fit_many(af.Yuksel(), np.ones((3, 16)), np.ones((2, 16))),
        BadValueError,
        "d has shape (3, 16) but target has shape (2, 16)",
    ),
    Case(
        "fit-dataset-not-dataset",
        lambda f: af.fit_dataset(af.Yuksel(), {"E": 1}),
        BadTypeError,
        "got dict",
    ),
    Case(
        "fit-dataset-nobody-sees-the-light",
        lambda f: af.fit_dataset(af.Yuksel(), _facing_away()),
        BadValueError,
        "no receiver in the dataset sees the light (every weight is 0)",
    ),
    Case(
        "fit-dataset-weights-shape",
        lambda f: af.fit_dataset(af.Yuksel(), af.Dataset.load(f.valid), weights=np.ones(3)),
        BadValueError,
        "weights has shape (3,), the dataset has 8 receivers",
    ),
    # --- builders (ranges backwards, zero, NaN, absurd) and Dataset
    Case(
        "sweep-backwards",
        lambda f: af.facing_sweep(_sphere(), 10.0, 2.0),
        BadValueError,
        "d_max (2.0) must be >= d_min (10.0)",
    ),
    Case(
        "sweep-nan",
        lambda f: af.facing_sweep(_sphere(), float("nan"), 2.0),
        BadValueError,
        "d_min must be finite and > 0, got nan",
    ),
    Case(
        "sweep-zero",
        lambda f: af.facing_sweep(_sphere(), 0.0, 2.0),
        BadValueError,
        "d_min must be finite and > 0, got 0.0",
    ),
    Case(
        "sweep-inside",
        lambda f: af.facing_sweep(_sphere(), 0.5, 2.0),
        BadValueError,
        "d_min (0.5) must exceed the sphere's radius",
    ),
    Case(
        "sweep-inf",
        lambda f: af.facing_sweep(_sphere(), 2.0, 1e400),
        BadValueError,
        "d_max must be finite and > 0, got inf",
    ),
    Case(
        "sweep-absurd-float32",
        lambda f: af.facing_sweep(_sphere(), 2.0, 1e300, dtype="float32"),
        BadValueError,
        "receivers reach 1e+300 m from the light; in float32 they must stay within",
    ),
    Case(
        "random-absurd-float64",
        lambda f: af.random_receivers(_sphere(), 4, 2.0, 1e200, seed=1),
        BadValueError,
        "in float64 they must stay within 8.38e+152 m",
    ),
    Case(
        "sweep-n-zero",
        lambda f: af.facing_sweep(_sphere(), 2.0, 3.0, n=0),
        BadValueError,
        "n must be >= 1, got 0",
    ),
    Case(
        "sweep-n-float",
        lambda f: af.facing_sweep(_sphere(), 2.0, 3.0, n=2.5),
        BadTypeError,
        "n must be an integer, got 2.5",
    ),
    Case(
        "sweep-dtype-complex",
        lambda f: af.facing_sweep(_sphere(), 2.0, 3.0, dtype=np.complex64),
        BadTypeError,
        "got complex64",
    ),
    Case(
        "sweep-dtype-unknown",
        lambda f: af.facing_sweep(_sphere(), 2.0, 3.0, dtype="float17"),
        BadTypeError,
        "got 'float17'",
    ),
    Case(
        "random-seed-str",
        lambda f: af.random_receivers(_sphere(), 4, 2.0, 3.0, seed="a"),
        BadTypeError,
        "seed must be an integer, got 'a'",
    ),
    Case(
        "plane-extent-zero",
        lambda f: af.plane_receivers(_sphere(), 1.0, 0.0),
        BadValueError,
        "extent must be finite and > 0, got 0.0",
    ),
    Case(
        "dataset-complex",
        lambda f: af.Dataset(
            _sphere(), np.ones((2, 3)) * 3, np.ones((2, 3)), np.ones(2) + 0j, np.zeros(2)
        ),
        BadTypeError,
        "E must be a float array, got dtype complex128",
    ),
    Case(
        "dataset-shapes",
        lambda f: af.Dataset(
            _sphere(), np.ones((2, 3)) * 3, np.ones((2, 3)), np.ones(3), np.zeros(2)
        ),
        BadValueError,
        "E must have shape (2,), got (3,)",
    ),
    Case(
        "dataset-stderr-negative",
        lambda f: af.Dataset(
            _sphere(), np.ones((2, 3)) * 3, np.ones((2, 3)), np.ones(2), -np.ones(2)
        ),
        BadValueError,
        "stderr must be >= 0, got -1.0",
    ),
    Case(
        "dataset-zero-normal",
        lambda f: af.Dataset(
            _sphere(), np.ones((2, 3)) * 3, np.eye(3)[[0, 0]] * [[1], [0]], np.ones(2), np.zeros(2)
        ),
        BadValueError,
        "normal 1 is [0.0, 0.0, 0.0]",
    ),
    # --- dataset files: missing, a folder, zero-byte, text, foreign, truncated, corrupt
    Case(
        "load-missing",
        lambda f: af.Dataset.load(f.missing),
        DataFileError,
        "no_such_file.npz' does not exist",
    ),
    Case(
        "load-folder",
        lambda f: af.Dataset.load(f.folder),
        DataFileError,
        "a_folder.npz' is a folder, not a file",
    ),
    Case(
        "load-zero-bytes",
        lambda f: af.Dataset.load(f.zero),
        DataFileError,
        "zero.npz' is not a readable attenfit dataset",
    ),
    Case(
        "load-text",
        lambda f: af.Dataset.load(f.text),
        DataFileError,
        "text.npz' is not a readable attenfit dataset (.npz): not a zip archive",
    ),
    Case(
        "load-foreign",
        lambda f: af.Dataset.load(f.foreign),
        DataFileError,
        "foreign.npz' is not an attenfit dataset (no header)",
    ),
    Case(
        "load-truncated",
        lambda f: af.Dataset.load(f.truncated),
        DataFileError,
        "truncated.npz' is not a readable attenfit dataset",
    ),
    Case("load-bytes-flipped", lambda f: af.Dataset.load(f.flipped), DataFileError, "flipped.npz'"),
    Case(
        "load-encrypted-member",
        lambda f: af.Dataset.load(f.encrypted),
        DataFileError,
        "encrypted.npz' is not a readable attenfit dataset (.npz): RuntimeError",
    ),
    Case(
        "load-unknown-compression",
        lambda f: af.Dataset.load(f.method),
        DataFileError,
        "method.npz' is not a readable attenfit dataset (.npz): NotImplementedError",
    ),
    Case("load-pickle", lambda f: af.Dataset.load(f.pickled), DataFileError, "pickled.npz'"),
    Case(
        "load-bad-json",
        lambda f: af.Dataset.load(f.bad_json),
        DataFileError,
        "bad_json.npz' is not valid JSON",
    ),
    Case(
        "load-list-header",
        lambda f: af.Dataset.load(f.list_header),
        DataFileError,
        "list_header.npz' is not an attenfit dataset",
    ),
    Case("load-version", lambda f: af.Dataset.load(f.version), DataFileError, "format version 99"),
    Case(
        "load-missing-array",
        lambda f: af.Dataset.load(f.no_stderr),
        DataFileError,
        "lacks the arrays ['stderr']",
    ),
    Case(
        "load-nan",
        lambda f: af.Dataset.load(f.nan_E),
        DataFileError,
        "E must be finite; 8 entries are not",
    ),
    Case(
        "load-complex",
        lambda f: af.Dataset.load(f.complex_E),
        DataFileError,
        "member 'E.npy' holds complex128 values; attenfit reads float arrays",
    ),
    Case(
        "load-short",
        lambda f: af.Dataset.load(f.short_E),
        DataFileError,
        "E must have shape (8,), got (5,)",
    ),
    Case(
        "load-wrong-n",
        lambda f: af.Dataset.load(f.wrong_n),
        DataFileError,
        "header says 9 receivers, arrays hold 8",
    ),
    Case(
        "load-unknown-emitter",
        lambda f: af.Dataset.load(f.cone),
        DataFileError,
        "unknown emitter kind 'cone'",
    ),
    Case(
        "load-negative-radius",
        lambda f: af.Dataset.load(f.neg_radius),
        DataFileError,
        "radius must be > 0, got -1.0",
    ),
    # --- outputs: exists, under a file, missing folder, a folder in place of the file
    Case(
        "save-exists",
        lambda f: af.Dataset.load(f.valid).save(f.existing),
        OutputExistsError,
        "existing.npz' exists; pass force=True to overwrite it",
    ),
    Case(
        "save-under-file",
        lambda f: af.Dataset.load(f.valid).save(f.regular / "x.npz"),
        BadValueError,
        "sits under",
    ),
    Case(
        "save-missing-folder",
        lambda f: af.Dataset.load(f.valid).save(f.missing_dir / "x.npz"),
        BadValueError,
        "no_such_dir' does not exist",
    ),
    Case(
        "save-onto-folder",
        lambda f: af.Dataset.load(f.valid).save(f.folder),
        BadValueError,
        "a_folder.npz' is a folder, not a file",
    ),
    # --- scene files
    Case(
        "scene-missing",
        lambda f: Scene.load(f.missing_dir / "s.toml"),
        DataFileError,
        "s.toml' does not exist",
    ),
    Case(
        "scene-folder",
        lambda f: Scene.load(f.folder),
        DataFileError,
        "is a folder, not a file",
    ),
    Case("scene-syntax", lambda f: Scene.load(f.scene_syntax), DataFileError, "TOML syntax error"),
    Case("scene-binary", lambda f: Scene.load(f.scene_binary), DataFileError, "is not UTF-8 text"),
    Case(
        "scene-zero-bytes",
        lambda f: Scene.load(f.scene_zero),
        BadValueError,
        "missing key 'tolerance'",
    ),
    Case(
        "scene-missing-key",
        lambda f: Scene.load(f.scene_no_tol),
        BadValueError,
        "missing key 'tolerance'",
    ),
    Case(
        "scene-wrong-type",
        lambda f: Scene.load(f.scene_tol_type),
        BadTypeError,
        "tolerance: must be a relative error in (0, 1], got 'five'",
    ),
    Case("scene-nan", lambda f: Scene.load(f.scene_tol_nan), BadValueError, "got nan"),
    Case(
        "scene-unknown-light",
        lambda f: Scene.load(f.scene_kind),
        UnknownNameError,
        "unknown kind 'laser'",
    ),
    Case(
        "scene-negative-radius",
        lambda f: Scene.load(f.scene_neg_r),
        BadValueError,
        "radius: must be a positive number, got -1.0",
    ),
    Case("scene-inf-radius", lambda f: Scene.load(f.scene_inf_r), BadValueError, "got inf"),
    Case("scene-str-radius", lambda f: Scene.load(f.scene_str_r), BadTypeError, "got 'big'"),
    Case("scene-absurd-radius", lambda f: Scene.load(f.scene_huge_r), BadValueError, "got 1e+300"),
    Case(
        "scene-unknown-key",
        lambda f: Scene.load(f.scene_extra),
        UnknownNameError,
        "unknown key 'colour'",
    ),
    Case(
        "scene-range-backwards",
        lambda f: Scene.load(f.scene_backwards),
        BadValueError,
        "range is backwards (min > max): [5.0, 0.5]",
    ),
    Case(
        "scene-range-short",
        lambda f: Scene.load(f.scene_short),
        BadTypeError,
        "must be a list [min, max] of 2 numbers, got [5.0]",
    ),
    Case(
        "scene-no-lights",
        lambda f: Scene.load(f.scene_no_lights),
        BadValueError,
        "at least one [[lights]]",
    ),
    Case(
        "scene-n-zero",
        lambda f: Scene.load(f.scene_n_zero),
        BadValueError,
        "n: must be an integer from 1 to 4096, got 0",
    ),
    Case("scene-n-float", lambda f: Scene.load(f.scene_n_float), BadTypeError, "got 2.5"),
    Case(
        "scene-unknown-family",
        lambda f: Scene.load(f.scene_family),
        UnknownNameError,
        "unknown family 'nope'",
    ),
    Case(
        "scene-unknown-receiver",
        lambda f: Scene.load(f.scene_recv),
        UnknownNameError,
        "unknown kind 'cloud'",
    ),
    # --- export
    Case(
        "export-language",
        lambda f: af.export_function("yuksel", "cobol"),
        UnknownNameError,
        "unknown language 'cobol'",
    ),
    Case(
        "export-family",
        lambda f: af.export_function("nope", "glsl"),
        UnknownNameError,
        "unknown family 'nope'",
    ),
    Case(
        "export-fit-text",
        lambda f: af.export_function(str(f.fit_text), "glsl"),
        DataFileError,
        "fit_text.json",
    ),
    Case(
        "export-fit-no-family",
        lambda f: af.export_function(str(f.fit_nofamily), "glsl"),
        DataFileError,
        "names no family",
    ),
    Case(
        "export-fit-nan",
        lambda f: af.export_function(str(f.fit_nan), "glsl"),
        DataFileError,
        "is not a finite number",
    ),
]


def _one_line(text: str) -> str:
    """The one line of `text` that is not a progress stage line (`attenfit fit: [  0.8 s] ...`,
    written wherever stderr goes)."""
    lines = without_progress(text.strip("\n")).splitlines()
    assert len(lines) == 1, f"expected one line, got {len(lines)}:\n{text}"
    return lines[0]


@pytest.mark.parametrize("case", API_CASES, ids=[c.id for c in API_CASES])
def test_api_bad_input(case: Case, files: Files):
    with pytest.raises(AttenfitError) as info:
        case.call(files)
    exc = info.value
    assert isinstance(exc, case.exc), f"{type(exc).__name__}: {exc}"
    assert isinstance(exc, ValueError | TypeError | KeyError)
    message = _one_line(str(exc))
    assert case.fragment in message, message


def test_catalogue_is_large_and_ids_unique():
    for ids in ([c.id for c in API_CASES], [c[0] for c in CLI_CASES]):
        assert len(ids) == len(set(ids))
    assert len(API_CASES) >= 40 and len(CLI_CASES) >= 30


# ----------------------------------------------------------------------------- accepted inputs
def test_sensible_ints_are_accepted():
    """Integers where a number is meant are fine: same answers as the floats."""
    e_int = af.SphereEmitter([0, 0, 0], 1)
    e_flt = af.SphereEmitter([0.0, 0.0, 0.0], 1.0)
    assert np.issubdtype(e_int.radius.dtype, np.floating)
    pts_i, nrm_i = np.array([[0, 0, -3]]), np.array([[0, 0, 1]])
    E_i = np.asarray(af.irradiance(e_int, pts_i, nrm_i))
    E_f = np.asarray(af.irradiance(e_flt, pts_i.astype(float), nrm_i.astype(float)))
    np.testing.assert_allclose(E_i, E_f, rtol=1e-12)
    np.testing.assert_allclose(E_f, [1 / 9], rtol=1e-12)  # outside a sphere: exactly I/d^2
    assert float(af.Yuksel(r=1)(2.0)) == pytest.approx(float(af.Yuksel(r=1.0)(2.0)))
    d = np.arange(2, 18)
    res = af.fit(af.UnrealEpsilon(), d, 1 / (d.astype(float) ** 2 + 0.25))
    assert res.converged and res.params["eps"] == pytest.approx(0.25, rel=1e-6)
    assert len(af.facing_sweep(e_flt, 2, 3, n=np.int64(4))) == 4


# ----------------------------------------------------------------------------- the CLI
def _p(name: str) -> Callable[[Files], str]:
    return lambda f: str(getattr(f, name))


TRUTH = ["truth", "--emitter", "sphere", "--radius", "1"]
FIT = ["fit", "--family", "yuksel", "--emitter", "sphere", "--radius", "1"]

# (id, argv with callables for paths, fragment of the one stderr line)
CLI_CASES: list[tuple[str, list[Any], str]] = [
    ("no-such-verb", ["frobnicate"], "invalid choice: 'frobnicate'"),
    ("families-unknown-option", ["families", "--bogus"], "unrecognized arguments: --bogus"),
    (
        "truth-radius-text",
        ["truth", "--emitter", "sphere", "--radius", "abc", "--out", "x.npz"],
        "invalid float value: 'abc'",
    ),
    (
        "truth-radius-nan",
        ["truth", "--emitter", "sphere", "--radius", "nan", "--out", "x.npz"],
        "--radius must be finite, got nan",
    ),
    (
        "truth-radius-inf",
        ["truth", "--emitter", "sphere", "--radius", "inf", "--out", "x.npz"],
        "--radius must be finite, got inf",
    ),
    (
        "truth-radius-zero",
        ["truth", "--emitter", "sphere", "--radius", "0", "--out", "x.npz"],
        "--radius must be > 0, got 0.0",
    ),
    (
        "truth-radius-negative",
        ["truth", "--emitter", "disk", "--radius", "-1", "--out", "x.npz"],
        "--radius must be > 0, got -1.0",
    ),
    (
        "truth-radius-absurd",
        [*TRUTH[:3], "--radius", "1e300", "--out", lambda f: str(f.root / "absurd.npz")],
        "got 1e+300",
    ),
    (
        "truth-range-backwards",
        [*TRUTH, "--range", "5:2", "--out", "x.npz"],
        "--range A:B needs 0 < A <= B < inf, got '5:2'",
    ),
    ("truth-range-text", [*TRUTH, "--range", "near:far", "--out", "x.npz"], "got 'near:far'"),
    ("truth-range-zero", [*TRUTH, "--range", "0:2", "--out", "x.npz"], "got '0:2'"),
    ("truth-range-huge", [*TRUTH, "--range", "2:1e400", "--out", "x.npz"], "got '2:1e400'"),
    (
        "truth-range-absurd-float32",
        [*TRUTH, "--range", "2:1e300", "--dtype", "float32", "--out", "x.npz"],
        "in float32 they must stay within",
    ),
    (
        "truth-samples-zero",
        [*TRUTH, "--samples", "0", "--out", "x.npz"],
        "--samples must be >= 1, got 0",
    ),
    (
        "truth-unknown-emitter",
        ["truth", "--emitter", "cone", "--radius", "1", "--out", "x.npz"],
        "invalid choice: 'cone'",
    ),
    (
        "truth-unknown-dtype",
        [*TRUTH, "--dtype", "float16", "--out", "x.npz"],
        "invalid choice: 'float16'",
    ),
    ("truth-out-suffix", [*TRUTH, "--out", "x.txt"], "--out must name a .npz file, got 'x.txt'"),
    ("truth-out-missing", TRUTH, "the following arguments are required: --out"),
    (
        "truth-out-exists",
        [*TRUTH, "--out", _p("existing")],
        "existing.npz' exists; use --force to overwrite it",
    ),
    (
        "truth-out-under-file",
        [*TRUTH, "--out", lambda f: str(f.regular / "x.npz")],
        "which is a file",
    ),
    (
        "truth-out-no-folder",
        [*TRUTH, "--out", lambda f: str(f.missing_dir / "x.npz")],
        "no_such_dir' does not exist",
    ),
    (
        "truth-out-is-folder",
        [*TRUTH, "--out", _p("folder")],
        "a_folder.npz' is a folder, not a file",
    ),
    (
        "gen-spp",
        [
            "gen",
            "--emitter",
            "sphere",
            "--radius",
            "1",
            "--spp",
            "1",
            "--out",
            lambda f: str(f.root / "g.npz"),
        ],
        "--spp must be at least 2, got 1",
    ),
    (
        "gen-chunk",
        [
            "gen",
            "--emitter",
            "sphere",
            "--radius",
            "1",
            "--chunk",
            "0",
            "--out",
            lambda f: str(f.root / "g.npz"),
        ],
        "--chunk must be a positive integer, got 0",
    ),
    (
        "gen-out-exists",
        ["gen", "--emitter", "sphere", "--radius", "1", "--out", _p("existing")],
        "existing.npz' exists",
    ),
    (
        "fit-unknown-family",
        ["fit", "--family", "nope", "--emitter", "sphere", "--radius", "1"],
        "unknown family 'nope'",
    ),
    ("fit-unknown-solver", [*FIT, "--solver", "adam"], "unknown solver 'adam'"),
    ("fit-unknown-loss", [*FIT, "--loss", "l1"], "unknown loss 'l1'"),
    ("fit-unknown-free", [*FIT, "--free", "q"], "no parameter 'q'"),
    (
        "fit-no-radius",
        ["fit", "--family", "yuksel", "--emitter", "sphere"],
        "needs --radius R > 0, got None",
    ),
    ("fit-range-backwards", [*FIT, "--range", "5:2"], "--range 5:2 must satisfy 0 <= A < B"),
    ("fit-range-inside", [*FIT, "--range", "0.5:2"], "A > R = 1 (outside the sphere)"),
    ("fit-n-small", [*FIT, "--n", "2"], "--n must be at least 4, got 2"),
    (
        "fit-data-missing",
        ["fit", "--family", "yuksel", "--data", _p("missing")],
        "no_such_file.npz' does not exist",
    ),
    (
        "fit-data-text",
        ["fit", "--family", "yuksel", "--data", _p("text")],
        "text.npz' is not a readable attenfit dataset",
    ),
    (
        "fit-data-truncated",
        ["fit", "--family", "yuksel", "--data", _p("truncated")],
        "truncated.npz'",
    ),
    (
        "fit-data-and-emitter",
        ["fit", "--family", "yuksel", "--data", "x.npz", "--emitter", "disk"],
        "not allowed with argument",
    ),
    ("fit-out-exists", [*FIT, "--out", _p("full_dir")], "full_dir' exists and is not empty"),
    ("fit-out-is-file", [*FIT, "--out", _p("regular")], "regular_file' exists and is a file"),
    (
        "scene-missing-file",
        ["scene", lambda f: str(f.missing_dir / "s.toml")],
        "s.toml' does not exist",
    ),
    ("scene-syntax", ["scene", _p("scene_syntax")], "TOML syntax error"),
    ("scene-unknown-light", ["scene", _p("scene_kind")], "unknown kind 'laser'"),
    (
        "scene-out-exists",
        ["scene", _p("scene"), "--out", _p("full_dir")],
        "full_dir' exists and is not empty",
    ),
    ("export-unknown-family", ["export", "nope"], "unknown family 'nope'"),
    (
        "export-unknown-language",
        ["export", "yuksel", "--lang", "cobol"],
        "--lang must be one of glsl, hlsl, wgsl, c, cuda, got 'cobol'",
    ),
    (
        "export-unknown-form",
        ["export", "yuksel", "--form", "fast"],
        "--form must be one of shader, stable, got 'fast'",
    ),
    (
        "export-param-syntax",
        ["export", "yuksel", "--param", "r"],
        "--param must be NAME=NUMBER, got 'r'",
    ),
    ("export-param-nan", ["export", "yuksel", "--param", "r=nan"], "nan"),
    ("export-param-unknown", ["export", "yuksel", "--param", "q=1"], "'q'"),
    ("export-fit-corrupt", ["export", _p("fit_text")], "fit_text.json"),
    ("export-out-exists", ["export", "yuksel", "--out", _p("existing")], "existing.npz' exists"),
    (
        "report-unknown-family",
        ["report", "--families", "nope", "--out", "r"],
        "unknown family 'nope'",
    ),
    (
        "report-unknown-emitter",
        ["report", "--emitters", "cone", "--out", "r"],
        "unknown emitter 'cone'",
    ),
    (
        "report-mitsuba-missing",
        ["report", "--mitsuba", _p("missing"), "--out", "r"],
        "no_such_file.npz' does not exist",
    ),
    (
        "report-mitsuba-text",
        ["report", "--families", "yuksel", "--mitsuba", _p("text"), "--out", "r"],
        "not a zip archive",
    ),
    (
        "report-out-exists",
        ["report", "--out", _p("full_dir")],
        "full_dir' exists and is not empty; use --force to replace it",
    ),
    (
        "report-out-is-file",
        ["report", "--out", _p("regular")],
        "regular_file' exists and is a file, not a folder",
    ),
    ("report-out-under-file", ["report", "--out", lambda f: str(f.regular / "r")], "sits under"),
    ("report-unknown-option", ["report", "--bogus"], "unrecognized arguments: --bogus"),
    (
        "truth-unknown-option",
        [*TRUTH, "--out", "x.npz", "--bogus"],
        "unrecognized arguments: --bogus",
    ),
    ("scene-unknown-option", ["scene", "s.toml", "--bogus"], "unrecognized arguments: --bogus"),
]


def _argv(items: list[Any], f: Files) -> list[str]:
    return [x(f) if callable(x) else x for x in items]


@pytest.mark.parametrize(
    "argv, fragment", [c[1:] for c in CLI_CASES], ids=[c[0] for c in CLI_CASES]
)
def test_cli_bad_input(argv, fragment, files: Files, capsys, monkeypatch):
    monkeypatch.chdir(files.root)
    before = sorted(p.name for p in files.root.iterdir())
    code = main(_argv(argv, files))
    out, err = capsys.readouterr()
    assert code == 2, (code, out, err)
    line = _one_line(err)
    assert line.startswith("attenfit"), line
    assert "Traceback" not in err
    assert fragment in line, line
    # nothing written, nothing replaced
    assert sorted(p.name for p in files.root.iterdir()) == before
    assert files.existing.read_bytes() == b"previous output"
    assert (files.full_dir / "keep.txt").read_text() == "previous"


def test_cli_no_verb_prints_usage_and_exits_2(capsys):
    assert main([]) == 2
    assert "usage: attenfit" in capsys.readouterr().err


def test_cli_real_process_has_no_traceback(tmp_path):
    """The installed entry point, as a user runs it: exit 2, one line, no traceback."""
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    proc = subprocess.run(
        [sys.executable, "-m", "attenfit", "truth", "--emitter", "sphere", "--radius", "-1",
         "--out", str(tmp_path / "x.npz")],
        capture_output=True, text=True, timeout=120, cwd=REPO, env=env,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert _one_line(proc.stderr) == "attenfit: error: --radius must be > 0, got -1.0"
    assert not any(tmp_path.iterdir())
