"""Hostile glTF files: files that try to read outside their folder, crash the process, exhaust
memory or time, or reach an internal error (attenfit/_scenes/_refs.py, _gltf_doc.py, _gltf.py).

Each class of attack is one test, parametrised over its cases; each case is a small file made
here from one valid scene (a floor quad and a point light) by a small change. A refusal is
exit 2 with one line naming the value and where it sits, nothing written, and nothing of a
secret file beside the scene's folder in any output. Cases that crashed or hung the process
run in a subprocess with a generous timeout (a hang or a signal fails the test; no timing is
asserted). The last test is a seeded fuzz campaign over the glTF JSON: exit 0 or 2, never 1.
"""

from __future__ import annotations

import base64
import copy
import json
import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from attenfit import BadTypeError, BadValueError, DataFileError, _input
from attenfit._scenes import _refs
from attenfit._scenes._files import load_mesh_scene
from attenfit.cli import main

REPO = Path(__file__).resolve().parent.parent
SECRET = "TOP-SECRET-7f3a9c"
_POS = np.array([[-5, -5, 0], [5, -5, 0], [5, 5, 0], [-5, 5, 0]], "<f4")
_NRM = np.tile(np.array([0, 0, 1], "<f4"), (4, 1))
_IDX = np.array([0, 1, 2, 0, 2, 3], "<u2")
BLOB = _POS.tobytes() + _NRM.tobytes() + _IDX.tobytes()  # 108 bytes


def _data_uri(blob: bytes) -> str:
    return "data:application/octet-stream;base64," + base64.b64encode(blob).decode()


def scene_doc(uri: str | None = None) -> dict:
    """A valid glTF: a 10 m floor quad at z = 0 (normals +Z) and a point light 1 m above."""
    return {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "floor", "mesh": 0},
            {
                "name": "bulbNode",
                "translation": [0, 0, 1],
                "extensions": {"KHR_lights_punctual": {"light": 0}},
            },
        ],
        "meshes": [
            {
                "name": "floor",
                "primitives": [
                    {"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2, "material": 0}
                ],
            }
        ],
        "materials": [{"doubleSided": False}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"},
        ],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 12},
        ],
        "buffers": [{"byteLength": len(BLOB), "uri": uri or _data_uri(BLOB)}],
        "extensions": {
            "KHR_lights_punctual": {
                "lights": [{"type": "point", "name": "bulb", "intensity": 10.0}]
            }
        },
        "extensionsUsed": ["KHR_lights_punctual"],
    }


def glb(doc: dict, binary: bytes | None) -> bytes:
    """A GLB container (glTF 2.0 section 4.4) of `doc` and a BIN chunk."""
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    out = struct.pack("<II", len(text), 0x4E4F534A) + text
    if binary is not None:
        binary += b"\0" * (-len(binary) % 4)
        out += struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<4sII", b"glTF", 2, 12 + len(out)) + out


@pytest.fixture
def room(tmp_path) -> Path:
    """`tmp_path/room/` for the scene, `tmp_path/secret.txt` beside it (never to be read)."""
    (tmp_path / "secret.txt").write_text(SECRET)
    (tmp_path / "room").mkdir()
    return tmp_path / "room"


def _write(folder: Path, doc: dict | str | bytes, name: str = "scene.gltf") -> Path:
    path = folder / name
    if isinstance(doc, bytes):
        path.write_bytes(doc)
    else:
        path.write_text(doc if isinstance(doc, str) else json.dumps(doc), encoding="utf-8")
    return path


ARGS = ("--radius", "0.05", "--samples", "32", "--engine", "gltf", "--quiet")


def refused(capsys, path: Path, *more: str, fragment: str) -> str:
    """Run `attenfit scene path` in-process; expect exit 2, one line holding `fragment`,
    no secret, and no output written (`--out`, `--write-back` beside the scene)."""
    out, back = path.parent / "ans", path.parent / "back.gltf"
    code = main(["scene", str(path), *ARGS, "--out", str(out), "--write-back", str(back), *more])
    cap = capsys.readouterr()
    err = cap.err.strip()
    assert code == 2, err
    assert err.startswith("attenfit: error: ") and "\n" not in err and "Traceback" not in err
    assert fragment in err, err
    assert SECRET not in cap.out + cap.err
    assert not out.exists() and not back.exists()
    return err


def run_process(path: Path, *more: str, env: dict | None = None) -> subprocess.CompletedProcess:
    """`python -m attenfit scene path` in a subprocess: a crash or hang fails, not kills, the
    test (the timeout only catches a hang)."""
    return subprocess.run(
        [sys.executable, "-m", "attenfit", "scene", str(path), *ARGS, *more],
        capture_output=True,
        text=True,
        timeout=300,
        cwd=path.parent,
        env={**os.environ, "PYTHONPATH": str(REPO), **(env or {})},
    )


# ----------------------------------------------------------------------------- references
def _symlink_out(room: Path) -> str:
    (room / "link.bin").symlink_to(room.parent / "secret.txt")
    return "link.bin"


def _link_folder(room: Path) -> str:
    (room / "up").symlink_to(room.parent)
    return "up/secret.txt"


OUTSIDE = {
    "absolute": lambda room: str(room.parent / "secret.txt"),
    "climbing": lambda room: "../secret.txt",
    "climbing-far": lambda room: "../" * 12 + str(room.parent / "secret.txt").lstrip("/"),
    "etc-passwd": lambda room: "../../../../../../../../etc/passwd",
    "proc-environ": lambda room: "/proc/self/environ",
    "file-uri": lambda room: "file://" + str(room.parent / "secret.txt"),
    "file-uri-localhost": lambda room: "file://localhost" + str(room.parent / "secret.txt"),
    "percent-encoded": lambda room: "%2e%2e/secret.txt",
    "percent-slash": lambda room: "..%2fsecret.txt",
    "inner-dots": lambda room: "a/../../secret.txt",
    "symlink-file": _symlink_out,
    "symlink-folder": _link_folder,
    "http": lambda room: "http://example.com/floor.bin",
    "windows": lambda room: "C:/Windows/win.ini",
    "other-host": lambda room: "file://server/share/floor.bin",
    "query": lambda room: "floor.bin?x=1",
    "nul": lambda room: "floor.bin%00.txt",
    "the-folder": lambda room: ".",
    "surrogate": lambda room: "\ud800.bin",
}


@pytest.mark.parametrize("case", OUTSIDE, ids=list(OUTSIDE))
@pytest.mark.parametrize("what", ["buffer", "image"])
def test_references_outside_the_folder_are_refused(room, capsys, monkeypatch, case, what):
    opened = []
    real_open = _input._open_regular

    def spy(path, what):  # every input attenfit opens goes through it
        opened.append(os.path.realpath(path))
        return real_open(path, what)

    monkeypatch.setattr(_input, "_open_regular", spy)
    uri = OUTSIDE[case](room)
    (room / "floor.bin").write_bytes(BLOB)
    doc = scene_doc("floor.bin")
    if what == "buffer":
        doc["buffers"][0]["uri"] = uri
        where = "buffers[0].uri"
    else:
        doc["images"] = [{"uri": uri}]
        where = "images[0].uri"
    err = refused(capsys, _write(room, doc), fragment=f"scene.gltf: {where} ")
    assert repr(uri)[:40] in err
    assert opened == [os.path.realpath(room / "scene.gltf")]  # the scene, nothing else


INSIDE = {
    "plain": "floor.bin",
    "subfolder": "bufs/floor.bin",
    "dots-inside": "bufs/../floor.bin",
    "percent-space": "my%20floor.bin",
    "absolute-inside": "{room}/floor.bin",
    "file-uri-inside": "file://{room}/floor.bin",
}


@pytest.mark.parametrize("case", INSIDE, ids=list(INSIDE))
def test_references_inside_the_folder_are_read(room, case):
    (room / "bufs").mkdir()
    for name in ("floor.bin", "bufs/floor.bin", "my floor.bin"):
        (room / name).write_bytes(BLOB)
    path = _write(room, scene_doc(INSIDE[case].format(room=os.path.realpath(room))))
    im = load_mesh_scene(path, radius=0.05, samples=16, notice=lambda m: None)
    assert im.scene.lights[0].position == (0.0, 0.0, 1.0)
    assert len(im.scene.receivers[0].points) == 16


def test_a_scene_reached_through_a_link_reads_beside_its_real_file(room, tmp_path):
    (room / "floor.bin").write_bytes(BLOB)
    _write(room, scene_doc("floor.bin"))
    other = tmp_path / "elsewhere"
    other.mkdir()
    (other / "scene.gltf").symlink_to(room / "scene.gltf")
    (other / "floor.bin").write_bytes(b"\xff" * len(BLOB))  # never read
    im = load_mesh_scene(other / "scene.gltf", radius=0.05, samples=16, notice=lambda m: None)
    assert np.all(np.abs(im.scene.receivers[0].points[:, :2]) <= 5)


def test_special_files_in_the_folder_are_refused_without_blocking(room):
    os.mkfifo(room / "pipe.bin")
    (room / "dir.bin").mkdir()
    for name, fragment in (("pipe.bin", "not a regular file"), ("dir.bin", "is a folder")):
        proc = run_process(_write(room, scene_doc(name)))
        assert proc.returncode == 2, proc.stderr
        assert f"buffers[0].uri '{name}'" in proc.stderr and fragment in proc.stderr
        assert proc.stderr.count("\n") == 1


@pytest.mark.parametrize(
    "uri, fragment",
    [
        ("data:application/octet-stream;base64,@@@@", "base64 is malformed"),
        ("data:application/octet-stream;base64", "without a ','"),
        (_data_uri(BLOB[:50]), "holds 50 bytes, fewer than its byteLength 108"),
    ],
    ids=["bad-base64", "no-comma", "short"],
)
def test_malformed_data_uris(room, capsys, uri, fragment):
    refused(capsys, _write(room, scene_doc(uri)), fragment=fragment)


def test_data_uri_is_bounded_before_decoding():
    with pytest.raises(DataFileError, match="over the 64 an input"):
        _refs.data_bytes(_data_uri(b"x" * 100), "buffers[0].uri", 64)
    assert _refs.data_bytes(_data_uri(b"x" * 64), "b", 64) == b"x" * 64
    assert _refs.data_bytes("data:,a%20b", "b", 64) == b"a b"


def test_write_back_embeds_only_what_the_scene_owns(room, capsys):
    (room / "floor.bin").write_bytes(BLOB)
    (room / "tex.png").write_bytes(b"\x89PNG fake")
    doc = scene_doc("floor.bin")
    doc["images"] = [{"uri": "tex.png"}]
    doc["extensions"]["KHR_lights_punctual"]["lights"][0]["extras"] = {"mine": [1]}
    path = _write(room, doc)
    back = room.parent / "out" / "back.gltf"
    back.parent.mkdir()
    assert main(["scene", str(path), *ARGS, "--write-back", str(back)]) == 0
    written = json.loads(back.read_text())
    assert written["buffers"][0]["uri"] == _data_uri(BLOB)
    assert (
        written["images"][0]["uri"]
        == "data:image/png;base64," + base64.b64encode(b"\x89PNG fake").decode()
    )
    light = written["extensions"]["KHR_lights_punctual"]["lights"][0]
    assert light["extras"]["mine"] == [1] and light["extras"]["attenfit"][0]["family"]
    # a light whose extras is not an object: refused, nothing written
    doc["extensions"]["KHR_lights_punctual"]["lights"][0]["extras"] = "note"
    path = _write(room, doc)
    back2 = room.parent / "out" / "back2.gltf"
    assert main(["scene", str(path), *ARGS, "--write-back", str(back2)]) == 2
    err = capsys.readouterr().err
    assert "lights[0].extras: is not a JSON object" in err and not back2.exists()


# ----------------------------------------------------------------------------- binary layout
def _view(key, value, view=0):
    def change(doc):
        doc["bufferViews"][view][key] = value

    return change


def _acc(key, value, acc=0):
    def change(doc):
        doc["accessors"][acc][key] = value

    return change


LAYOUT = {
    "stride-negative-huge": (_view("byteStride", -(2**40)), "bufferViews[0].byteStride"),
    "stride-negative": (_view("byteStride", -12), "bufferViews[0].byteStride: must be an integer from 4 to 252, got -12"),
    "stride-2": (_view("byteStride", 2), "from 4 to 252, got 2"),
    "stride-256": (_view("byteStride", 256), "from 4 to 252, got 256"),
    "stride-odd": (_view("byteStride", 14), "byteStride: must be a multiple of 4, got 14"),
    "stride-below-element": (_view("byteStride", 8), "byteStride 8 must be at least its 12-byte elements"),
    "stride-past-view": (_view("byteStride", 16), "need 60 bytes; bufferViews[0] has 48"),
    "view-negative-offset": (_view("byteOffset", -48, 1), "bufferViews[1].byteOffset: must be an integer from 0 to 9,007,199,254,740,992, got -48"),
    "view-past-buffer": (_view("byteLength", 4096, 2), "bufferViews[2]: bytes 96 to 4,192 run past buffers[0]"),
    "view-zero-length": (_view("byteLength", 0), "bufferViews[0].byteLength: must be an integer from 1 to"),
    "view-buffer-index": (_view("buffer", 3), "bufferViews[0].buffer: index 3 is out of range"),
    "accessor-negative-offset": (_acc("byteOffset", -4), "accessors[0].byteOffset: must be an integer from 0 to"),
    "accessor-misaligned": (_acc("byteOffset", 1, 2), "accessors[2].byteOffset: 1"),
    "count-3e9": (_acc("count", 3_000_000_000), "3,000,000,000 elements of 12 bytes"),
    "count-float": (_acc("count", 4.0), "accessors[0].count: must be an integer, got 4.0"),
    "count-zero": (_acc("count", 0), "accessors[0].count: must be an integer from 1 to"),
    "count-10e400": (_acc("count", 10**400), "accessors[0].count: must be an integer from 1 to 9,007,199,254,740,992"),
    "component-5124": (_acc("componentType", 5124), "accessors[0].componentType: must be one of"),
    "component-text": (_acc("componentType", "5126"), "accessors[0].componentType: must be one of"),
    "type-vec5": (_acc("type", "VEC5"), "accessors[0].type: must be one of"),
    "normalized-float": (_acc("normalized", True), "accessors[0].normalized: is only for 8- and 16-bit"),
    "position-as-scalar": (_acc("type", "SCALAR"), "accessors[0] (SCALAR of component type 5126) cannot be POSITION"),
    "float-indices": (_acc("componentType", 5122, 2), "cannot be indices"),
    "normal-count": (_acc("count", 3, 1), "NORMAL has 3 elements, POSITION 4"),
    "indices-not-triangles": (_acc("count", 5, 2), "5 corners are not whole triangles"),
    "sparse": (_acc("sparse", {"count": 1}), "sparse accessors are not read"),
    "view-index": (_acc("bufferView", -1), "accessors[0].bufferView: index -1 is out of range"),
}  # fmt: skip


@pytest.mark.parametrize("case", LAYOUT, ids=list(LAYOUT))
def test_accessors_and_views_cannot_reach_outside_their_buffer(room, capsys, case):
    change, fragment = LAYOUT[case]
    doc = scene_doc()
    change(doc)
    refused(capsys, _write(room, doc), fragment=fragment)


def test_an_index_past_the_points_is_refused(room, capsys):
    idx = np.array([0, 1, 2, 0, 2, 60000], "<u2")
    doc = scene_doc(_data_uri(BLOB[:96] + idx.tobytes()))
    refused(capsys, _write(room, doc), fragment="index 60000 (accessors[2]) is past its 4 points")


def test_the_strides_that_crashed_the_process_exit_2(room):
    """byteStride -2^40 was a SIGSEGV, -12 read the bytes before its view."""
    for stride in (-(2**40), -12):
        doc = scene_doc()
        doc["bufferViews"][0]["byteStride"] = stride
        doc["accessors"][0]["byteOffset"] = 0
        proc = run_process(_write(room, doc))
        assert proc.returncode == 2, (proc.returncode, proc.stderr)
        assert f"byteStride: must be an integer from 4 to 252, got {stride}" in proc.stderr


def test_an_interleaved_view_is_read_within_bounds(room):
    """A valid stride: positions and normals interleaved (24 bytes apart)."""
    inter = np.concatenate([_POS, _NRM], axis=1).tobytes()
    doc = scene_doc(_data_uri(inter + _IDX.tobytes()))
    doc["bufferViews"] = [
        {"buffer": 0, "byteOffset": 0, "byteLength": 96, "byteStride": 24},
        {"buffer": 0, "byteOffset": 96, "byteLength": 12},
    ]
    doc["accessors"][1] = {"bufferView": 0, "byteOffset": 12, "componentType": 5126,
                           "count": 4, "type": "VEC3"}  # fmt: skip
    doc["accessors"][2]["bufferView"] = 1
    doc["buffers"][0]["byteLength"] = 108
    im = load_mesh_scene(_write(room, doc), radius=0.05, samples=16, notice=lambda m: None)
    assert np.allclose(im.scene.receivers[0].normals, [0, 0, 1])


# ----------------------------------------------------------------------------- GLB container
def _glb_case(room, case) -> bytes:
    doc = scene_doc()
    del doc["buffers"][0]["uri"]
    good = glb(doc, BLOB)
    return {
        "short": good[:16],
        "version-1": good[:4] + struct.pack("<I", 1) + good[8:],
        "length-lies": good[:8] + struct.pack("<I", len(good) + 100) + good[12:],
        "chunk-past-end": good[:12] + struct.pack("<I", 1 << 30) + good[16:],
        "bin-first": glb(doc, BLOB)[:16] + b"BIN\0" + good[20:],
        "bin-short": glb(doc, BLOB[:40]),
        "no-bin": glb(doc, None),
    }[case]


GLB = {
    "short": "not a glTF 2.0 file (a GLB of 16 bytes",
    "version-1": "GLB version 1",
    "length-lies": "its GLB header says",
    "chunk-past-end": "runs past the file's end",
    "bin-first": "first chunk is not JSON",
    "bin-short": "buffers[0] holds 40 bytes, fewer than its byteLength 108",
    "no-bin": "buffers[0] has no uri and is not a GLB's first buffer",
}


@pytest.mark.parametrize("case", GLB, ids=list(GLB))
def test_broken_glb_containers(room, capsys, case):
    refused(capsys, _write(room, _glb_case(room, case), "scene.glb"), fragment=GLB[case])


# ----------------------------------------------------------------------------- graph and caps
def _nodes_json(n: int) -> str:
    """A scene of `n` empty nodes (besides the floor and light), written without json.dumps."""
    doc = scene_doc()
    head = json.dumps(doc)[:-1]
    top = '"nodes": [{"name": "floor"'
    return head.replace(top, '"nodes": [' + '{"name": "n"}, ' * n + top[10:], 1) + "}"


def test_a_million_empty_nodes_are_refused_quickly(room):
    text = _nodes_json(1_000_000)
    assert len(text) > 15e6
    path = _write(room, text)
    proc = run_process(path)  # the timeout only catches a hang (it ran past 120 s)
    assert proc.returncode == 2, proc.stderr
    assert "nodes: 1,000,002 items; attenfit reads at most 100,000" in proc.stderr


GRAPH = {
    "cycle": (lambda d: d["nodes"].extend([{"children": [3]}, {"children": [2]}]), "nodes[2]: its ancestors form a cycle"),
    "self-child": (lambda d: d["nodes"][0].update(children=[0]), "nodes[0]: a child of nodes[0] and of itself"),
    "two-parents": (lambda d: d["nodes"].extend([{"children": [1]}, {"children": [1]}]), "nodes[1]: a child of nodes[3] and of nodes[2]"),
    "root-is-child": (lambda d: d["nodes"].append({"children": [0]}), "scenes[0].nodes: nodes[0] is a child of nodes[2]"),
    "root-twice": (lambda d: d["scenes"][0]["nodes"].append(0), "scenes[0].nodes: lists a node twice"),
    "deep": (lambda d: _chain(d, 300), "nested 257 levels deep; attenfit reads at most 256"),
    "lights-object": (lambda d: d["extensions"]["KHR_lights_punctual"].update(lights={"a": 1}), "extensions.KHR_lights_punctual.lights: must be a list of objects"),
    "too-many-lights": (lambda d: d["extensions"]["KHR_lights_punctual"].update(lights=[{}] * 1001), "lights: 1,001 items; attenfit reads at most 1,000"),
    "too-many-light-nodes": (lambda d: _light_nodes(d, 1000), "1,001 nodes carry a light; attenfit answers at most 1,000"),
}  # fmt: skip


def _chain(doc, n):
    base = len(doc["nodes"])
    doc["nodes"] += [{"children": [base + i + 1]} for i in range(n - 1)] + [{}]
    doc["scenes"][0]["nodes"].append(base)


def _light_nodes(doc, n):
    base = len(doc["nodes"])
    doc["nodes"] += [{"extensions": {"KHR_lights_punctual": {"light": 0}}}] * n
    doc["scenes"][0]["nodes"] += list(range(base, base + n))


@pytest.mark.parametrize("case", GRAPH, ids=list(GRAPH))
def test_node_graphs_and_caps(room, capsys, case):
    change, fragment = GRAPH[case]
    doc = scene_doc()
    change(doc)
    refused(capsys, _write(room, doc), fragment=fragment)


# ----------------------------------------------------------------------------- memory
def test_many_buffers_naming_one_big_file_are_counted_before_reading(room, capsys, monkeypatch):
    big = room / "big.bin"
    with open(big, "wb") as fh:  # sparse: 250 MB that take no disk
        fh.truncate(250_000_000)
    doc = scene_doc()
    doc["buffers"] = [{"byteLength": 250_000_000, "uri": "big.bin"} for _ in range(40)]
    doc["bufferViews"] = [{"buffer": k, "byteLength": 240_000_000} for k in range(40)]
    doc["accessors"] = [{"bufferView": k, "componentType": 5126, "count": 19_999_998,
                         "type": "VEC3"} for k in range(40)]  # fmt: skip
    doc["meshes"] = [{"primitives": [{"attributes": {"POSITION": k}}]} for k in range(40)]
    doc["nodes"] = [{"mesh": k} for k in range(40)] + [doc["nodes"][1]]
    doc["scenes"] = [{"nodes": list(range(41))}]

    def never(*a, **k):
        raise AssertionError("a buffer was read before the memory check")

    monkeypatch.setattr(_refs, "read_bytes", never)
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", "8G")
    err = refused(capsys, _write(room, doc), fragment="266,666,640 triangles in 40 mesh instances")
    assert "250,000,000 bytes of buffers" in err and "over the budget of 8 GB" in err


def test_an_accessor_of_3e9_zeros_is_refused_up_front(room, capsys):
    doc = scene_doc()
    doc["accessors"][0] = {"componentType": 5126, "count": 3_000_000_000, "type": "VEC3"}
    del doc["accessors"][1], doc["meshes"][0]["primitives"][0]["attributes"]["NORMAL"]
    del doc["meshes"][0]["primitives"][0]["indices"]
    refused(capsys, _write(room, doc), fragment="1,000,000,000 triangles")


def test_a_json_of_too_many_values_is_refused_before_parsing(room, capsys, monkeypatch):
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", "20M")
    path = _write(room, _nodes_json(90_000))
    refused(capsys, path, fragment="a glTF JSON of")


# ----------------------------------------------------------------------------- JSON shape
def _light(**kw):
    def change(doc):
        doc["extensions"]["KHR_lights_punctual"]["lights"][0].update(kw)

    return change


def _node(k, **kw):
    def change(doc):
        doc["nodes"][k].update(kw)

    return change


def _huge(doc):
    doc["nodes"][1]["translation"] = [0, 0, 1e10]
    doc["nodes"].append({"scale": [1e300] * 3, "children": [1]})
    doc["scenes"][0]["nodes"] = [0, 2]


def _deep(n: int):
    v: object = {}
    for _ in range(n):
        v = {"a": v}
    return v


LP = "extensions.KHR_lights_punctual"
SHAPE = {
    "intensity-text": (_light(intensity="10"), f"{LP}.lights[0].intensity: must be a number, got '10'"),
    "intensity-nan": (_light(intensity=float("nan")), f"{LP}.lights[0].intensity: must be a finite number"),
    "intensity-bool": (_light(intensity=True), "intensity: must be a number, got True"),
    "range-text": (_light(range="far"), f"{LP}.lights[0].range: must be a number"),
    "spot-text": (_light(type="spot", spot={"outerConeAngle": "wide"}), "lights[0].spot.outerConeAngle: must be a number"),
    "spot-list": (_light(type="spot", spot=[1]), "lights[0].spot: must be a JSON object"),
    "name-number": (_light(name=5), "lights[0].name: must be a string"),
    "light-element": (lambda d: d["extensions"]["KHR_lights_punctual"].update(lights=[3]), f"{LP}.lights[0]: must be a JSON object, got 3"),
    "punctual-list": (lambda d: d["extensions"].update(KHR_lights_punctual=[1]), f"{LP}: must be a JSON object"),
    "extensions-text": (lambda d: d.update(extensions="x"), "extensions: must be a JSON object"),
    "scene-5": (lambda d: d.update(scene=5), "scene: index 5 is out of range: scenes has 1 items"),
    "scene-null-no-light": (lambda d: d.update(scene=None, nodes=d["nodes"][:1], scenes=[{"nodes": [0]}]), "no sphere, disk, spot or point light"),
    "primitives-null": (lambda d: d["meshes"][0].update(primitives=None), "no mesh to sample receivers on"),
    "scene-text": (lambda d: d.update(scene="0"), "scene: must be an index into scenes"),
    "scene-nodes": (lambda d: d["scenes"][0].update(nodes=[0, 9]), "scenes[0].nodes[1]: index 9 is out of range"),
    "mesh-index": (_node(0, mesh=7), "nodes[0].mesh: index 7 is out of range: meshes has 1 items"),
    "mesh-negative": (_node(0, mesh=-1), "nodes[0].mesh: index -1 is out of range"),
    "light-index": (_node(1, extensions={"KHR_lights_punctual": {"light": 3}}), "nodes[1].extensions.KHR_lights_punctual.light: index 3"),
    "rotation-3": (_node(1, rotation=[0, 0, 1]), "nodes[1].rotation: must be a list of 4 numbers, got [0, 0, 1]"),
    "rotation-zero": (_node(1, rotation=[0, 0, 0, 0]), "nodes[1].rotation: must be a unit quaternion"),
    "translation-text": (_node(1, translation=[0, "1", 0]), "nodes[1].translation[1]: must be a number, got '1'"),
    "translation-huge-int": (_node(1, translation=[0, 10**400, 0]), "nodes[1].translation[1]: must be a finite number"),
    "matrix-15": (_node(1, matrix=[1] * 15), "nodes[1].matrix: must be a list of 16 numbers"),
    "scale-zero-light": (_node(1, scale=[0, 0, 0]), "non-uniform scale (0.0, 0.0, 0.0)"),
    "huge-translation": (_huge, "light 'bulb' (node 'bulbNode'): its node's world transform is not finite"),
    "far-light": (_node(1, translation=[1e308, 0, 1]), "light 'bulb' (node 'bulbNode'): 1e+308 m from the origin; attenfit reads scenes within 1e+12 m"),
    "far-mesh": (_node(0, translation=[0, -1e13, 0]), "mesh 'floor/floor/primitives[0]': points 1e+13 m from the origin"),
    "zero-scale-mesh": (_node(0, scale=[0, 1, 1]), "its node's world transform is not invertible"),
    "children-text": (_node(0, children="1"), "nodes[0].children: must be a list"),
    "nodes-object": (lambda d: d.update(nodes={"0": {}}), "nodes: must be a list of objects"),
    "primitives-object": (lambda d: d["meshes"][0].update(primitives={}), "meshes[0].primitives: must be a list of objects"),
    "attributes-list": (lambda d: d["meshes"][0]["primitives"][0].update(attributes=[0]), "attributes: must be a JSON object"),
    "attribute-index": (lambda d: d["meshes"][0]["primitives"][0]["attributes"].update(POSITION=9), "attributes.POSITION: index 9 is out of range"),
    "material-index": (lambda d: d["meshes"][0]["primitives"][0].update(material=4), "primitives[0].material: index 4 is out of range"),
    "mode-9": (lambda d: d["meshes"][0]["primitives"][0].update(mode=9), "primitives[0].mode: must be an integer from 0 to 6"),
    "double-sided-text": (lambda d: d["materials"][0].update(doubleSided="yes"), "materials[0].doubleSided: must be true or false"),
    "buffer-length-text": (lambda d: d["buffers"][0].update(byteLength="108"), "buffers[0].byteLength: must be an integer"),
    "uri-number": (lambda d: d["buffers"][0].update(uri=5), "buffers[0].uri: must be a string, got 5"),
    "asset-1": (lambda d: d.update(asset={"version": "1.0"}), "not a glTF 2.0 file (asset.version '1.0')"),
    "required-list": (lambda d: d.update(extensionsRequired="KHR"), "extensionsRequired: must be a list of names"),
    "extras-500-deep": (_light(extras=_deep(500)), "glTF JSON nests arrays or objects more than 32 deep"),
}  # fmt: skip


@pytest.mark.parametrize("case", SHAPE, ids=list(SHAPE))
def test_json_shape_is_checked_with_the_key_path(room, capsys, case):
    change, fragment = SHAPE[case]
    doc = scene_doc()
    change(doc)
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 3000))  # json.dumps of 500 levels
    refused(capsys, _write(room, doc), fragment=fragment)


@pytest.mark.parametrize("depth", [40, 200_000])
def test_json_nested_past_the_limit_is_refused(room, capsys, depth):
    text = json.dumps(scene_doc())[:-1] + ', "extras": ' + "[" * depth + "]" * depth + "}"
    err = refused(capsys, _write(room, text), fragment="scene.gltf: glTF JSON nests")
    assert "32" in err or "too deeply" in err


def test_a_glb_padded_with_nuls_is_read(room):
    doc = scene_doc()
    del doc["buffers"][0]["uri"]
    text = json.dumps(doc).encode()
    text += b"\0" * (4 - len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text
    body += struct.pack("<II", len(BLOB), 0x004E4942) + BLOB
    path = _write(room, struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body, "scene.glb")
    im = load_mesh_scene(path, radius=0.05, samples=16, notice=lambda m: None)
    assert im.scene.lights[0].position == (0.0, 0.0, 1.0)


def test_the_resolver_for_usd_paths_does_not_percent_decode(room):
    folder = _refs.SceneFolder(room / "scene.usda", "scene.usda")
    assert folder.resolve("my%20floor.usda", "subLayers[0]", uri=False).name == "my%20floor.usda"
    assert folder.resolve("my%20floor.usda", "subLayers[0]").name == "my floor.usda"
    with pytest.raises(DataFileError, match=r"subLayers\[0\] '../secret.txt': resolves to"):
        folder.resolve("../secret.txt", "subLayers[0]", uri=False)
    with pytest.raises(DataFileError, match="not checked before reading"):
        folder.read(room / "x.usda", "x.usda", "subLayers[1]", 100)


def test_errors_are_the_documented_classes(room):
    cases = [(SHAPE["scene-5"][0], BadValueError), (SHAPE["intensity-text"][0], BadTypeError),
             (lambda d: d["buffers"][0].update(uri="../secret.txt"), DataFileError)]  # fmt: skip
    for change, cls in cases:
        doc = scene_doc()
        change(doc)
        with pytest.raises(cls):
            load_mesh_scene(_write(room, doc), radius=0.05, samples=16, notice=lambda m: None)


# ----------------------------------------------------------------------------- fuzz
HOSTILE = [None, "text", "../secret.txt", -1, 0, 1, 3, 2**31, 2**64, -(2**40), 1.5, 1e308,
           -1e308, float("nan"), float("inf"), True, [], {}, [1, 2], [0, 0, 0, 1], [[[[1]]]],
           {"a": {"b": []}}, 5126, 5124, "VEC3", "SCALAR", "spot", 252, 3_000_000_000,
           10**400, 2**53]  # fmt: skip


def _paths(v, path=()):
    """Every key path of the JSON value `v` (dicts and lists), its own included."""
    yield path
    if isinstance(v, dict):
        for k, x in v.items():
            yield from _paths(x, (*path, k))
    elif isinstance(v, list):
        for k, x in enumerate(v):
            yield from _paths(x, (*path, k))


def _mutate(doc, path, how, value):
    if not path:
        return
    parent = doc
    for k in path[:-1]:
        parent = parent[k]
    key = path[-1]
    if how == "delete":
        del parent[key]
    elif how == "replace":
        parent[key] = value
    elif how == "null":
        parent[key] = None
    elif how == "wrap":
        parent[key] = [parent[key]] if isinstance(key, str) else {"x": parent[key]}
    elif how == "duplicate" and isinstance(parent, list):
        parent.append(copy.deepcopy(parent[key]))


#: the same examples every run (tests/conftest.py); ATTENFIT_FUZZ_SCALE=10 hunts ten times
#: longer with fresh ones
SCALE = int(os.environ.get("ATTENFIT_FUZZ_SCALE", "1"))
FUZZ = settings(max_examples=120 * SCALE, deadline=None, suppress_health_check=list(HealthCheck))


@FUZZ
@given(data=st.data())
def test_fuzz_gltf_json_never_an_internal_error(tmp_path_factory, data):
    """Mutations of the valid scene (types swapped, extreme numbers, indices out of range,
    keys deleted, values set to null or wrapped in lists, items duplicated; bytes of its
    buffer flipped): exit 0 or 2, never 1."""
    folder = tmp_path_factory.mktemp("fuzz")
    blob = bytearray(BLOB)  # the buffer's bytes flipped too: NaN, huge or negative values
    for i in data.draw(st.lists(st.integers(0, len(BLOB) - 1), max_size=3)):
        blob[i] ^= data.draw(st.integers(1, 255))
    (folder / "floor.bin").write_bytes(bytes(blob))
    doc = scene_doc(data.draw(st.sampled_from([_data_uri(bytes(blob)), "floor.bin"])))
    for _ in range(data.draw(st.integers(1, 3))):
        paths = list(_paths(doc))
        path = data.draw(st.sampled_from(paths))
        how = data.draw(
            st.sampled_from(["replace", "replace", "null", "delete", "wrap", "duplicate"])
        )
        _mutate(doc, path, how, copy.deepcopy(data.draw(st.sampled_from(HOSTILE))))
    if not isinstance(doc, dict):
        return
    path = _write(folder, json.dumps(doc))
    argv = ["scene", str(path), "--radius", "0.05", "--samples", "16", "--engine", "gltf",
            "--quiet", "--write-back", str(folder / "back.gltf")]  # fmt: skip
    import contextlib
    import io

    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = main(argv)
    text = "\n".join(x for x in err.getvalue().splitlines() if not x.startswith("note: "))
    assert code in (0, 2), f"exit {code}: {text}"
    assert "internal error" not in text and "\n" not in text.strip(), text
    if code == 0:
        json.loads((folder / "back.gltf").read_text())


def test_names_that_look_like_mathtext_are_drawn_as_text(room, tmp_path):
    """A light named `$\\frac$` (matplotlib would parse it as mathtext and fail) is answered,
    and its name is drawn as it is in the --out figure."""
    from attenfit.cli import main

    doc = scene_doc()
    doc["extensions"]["KHR_lights_punctual"]["lights"][0]["name"] = "$\\frac{a$ bulb"
    path = _write(room, doc, name="$x$.gltf")
    out = tmp_path / "answer"
    assert main(["scene", str(path), *ARGS, "--out", str(out)]) == 0
    assert any(out.rglob("*.png"))
