"""Hostile USD scenes: files that try to read outside their folder, hang, exhaust memory, crash
usd-core, or trick an output into replacing an input (docs/errors.md, docs/usd-gltf.md).

Each case is a small `.usda` written into `tmp_path` (a FIFO made with `os.mkfifo`, a sparse
1 GiB file with `truncate`); each asserts exit 2 with one line naming the value and where it
sits, nothing written, and every input byte-identical afterwards. The cases that could hang
run `attenfit` in a subprocess with a generous timeout (only to catch a hang, never to time
anything). A seeded fuzz campaign mutates a valid scene (extreme numbers, swapped types,
asset paths pointing outside, deleted lines) and asserts exit 0 or 2, never 1.
"""

from __future__ import annotations

import base64
import os
import random
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from attenfit import BadValueError
from attenfit.cli import main

pxr = pytest.importorskip("pxr")
from pxr import Usd, UsdGeom, Vt  # noqa: E402

from attenfit._scenes import _usd_crate, _usd_layers  # noqa: E402
from attenfit._scenes._files import load_mesh_scene  # noqa: E402
from attenfit.scene import answer_file  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SCALE = int(os.environ.get("ATTENFIT_FUZZ_SCALE", "1"))

FLOOR = """def Mesh "floor"
{
    int[] faceVertexCounts = [4]
    int[] faceVertexIndices = [0, 1, 2, 3]
    point3f[] points = [(-5, -5, 0), (5, -5, 0), (5, 5, 0), (-5, 5, 0)]
    normal3f[] normals = [(0, 0, 1), (0, 0, 1), (0, 0, 1), (0, 0, 1)] (
        interpolation = "vertex"
    )
}
"""
BULB = """def SphereLight "bulb"
{
    float inputs:radius = 0.05
    double3 xformOp:translate = (0, 0, 2)
    uniform token[] xformOpOrder = ["xformOp:translate"]
}
"""
FAST = ["--engine", "godot", "--samples", "16", "--quiet"]


def usda(meta: str = "", body: str = FLOOR + BULB) -> str:
    return f"#usda 1.0\n(\n    metersPerUnit = 1\n{meta}\n)\n{body}"


def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def _snapshot(top: Path) -> dict[str, object]:
    """Every entry under `top`: a regular file's bytes (a large one's size), else its kind."""
    out: dict[str, object] = {}
    for p in sorted(top.rglob("*")):
        key = str(p.relative_to(top))
        if p.is_symlink():
            out[key] = ("link", os.readlink(p))
        elif p.is_fifo():
            out[key] = "fifo"
        elif p.is_dir():
            out[key] = "dir"
        elif p.stat().st_size > 1 << 20:
            out[key] = ("size", p.stat().st_size)
        else:
            out[key] = p.read_bytes()
    return out


def _refused(capsys, tmp_path: Path, *argv, fragment: str | list[str]) -> str:
    """Run `attenfit scene ARGV` in-process: exit 2, one line holding each fragment, and
    nothing under `tmp_path` written, removed or changed."""
    before = _snapshot(tmp_path)
    code = main(["scene", *map(str, argv)])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.count("\n") == 1 and err.startswith("attenfit: error: "), err
    for frag in [fragment] if isinstance(fragment, str) else fragment:
        assert frag in err, err
    assert _snapshot(tmp_path) == before
    return err


def _subprocess(tmp_path: Path, *argv) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    return subprocess.run(
        [sys.executable, "-m", "attenfit", "scene", *map(str, argv)],
        capture_output=True,
        text=True,
        env=env,
        cwd=tmp_path,
        timeout=300,  # a hang, not a measurement
    )


# ----------------------------------------------------------------------------- outside the folder
def _arc(asset: str) -> dict[str, tuple[str, str]]:
    """Scenes naming `asset` through each kind of composition arc: (root metadata, body)."""
    return {
        "sublayer": (f"    subLayers = [@{asset}@]", FLOOR + BULB),
        "reference": ("", FLOOR + BULB + f'def Xform "r" (\n    references = @{asset}@\n)\n{{\n}}\n'),
        "payload": ("", FLOOR + BULB + f'def Xform "p" (\n    payload = @{asset}@\n)\n{{\n}}\n'),
        "variant": ("", FLOOR + BULB + 'def Xform "v" (\n    variants = {\n        string s = "a"\n'
                    '    }\n    prepend variantSets = "s"\n)\n{\n    variantSet "s" = {\n'
                    f'        "a" (\n            references = @{asset}@\n        ) {{\n        }}\n'
                    "    }\n}\n"),
        "clip": ("", FLOOR + BULB + 'def Xform "c" (\n    clips = {\n        dictionary d = {\n'
                 f"            asset[] assetPaths = [@{asset}@]\n        }}\n    }}\n)\n{{\n}}\n"),
        "manifest": ("", FLOOR + BULB + 'def Xform "c" (\n    clips = {\n        dictionary d = {\n'
                     f"            asset manifestAssetPath = @{asset}@\n        }}\n    }}\n)\n{{\n}}\n"),
    }  # fmt: skip


@pytest.mark.parametrize("arc", list(_arc("x")))
@pytest.mark.parametrize("how", ["relative", "absolute"])
def test_a_file_outside_the_folder_is_refused_by_every_arc(tmp_path, capsys, arc, how):
    secret = _write(tmp_path / "outside.usda", usda(body=FLOOR))
    asset = "../outside.usda" if how == "relative" else str(secret)
    meta, body = _arc(asset)[arc]
    root = _write(tmp_path / "scene" / "root.usda", usda(meta, body))
    _refused(capsys, tmp_path, root, *FAST, fragment=[
        "root.usda: ", f"{asset!r} in layer 'root.usda' resolves to {secret}, outside the scene's folder "
        f"{tmp_path / 'scene'}"])  # fmt: skip


def test_a_symlink_out_of_the_folder_and_dev_zero_are_refused(tmp_path, capsys):
    secret = _write(tmp_path / "outside.usda", usda(body=FLOOR))
    (tmp_path / "scene").mkdir()
    os.symlink(secret, tmp_path / "scene" / "link.usda")
    os.symlink("/dev/zero", tmp_path / "scene" / "zero.usda")
    root = _write(tmp_path / "scene" / "root.usda", usda("    subLayers = [@link.usda@]"))
    _refused(capsys, tmp_path, root, *FAST,
             fragment=f"'link.usda' in layer 'root.usda' resolves to {secret}, outside the scene's folder")  # fmt: skip
    for asset in ("zero.usda", "/dev/zero.usda"):
        _write(root, usda(f"    subLayers = [@{asset}@]"))
        _refused(capsys, tmp_path, root, *FAST, fragment="outside the scene's folder")
    # the root itself may be a link: the scene's folder is the one holding the file it names
    os.symlink(root, tmp_path / "root-link.usda")
    _write(root, usda("    subLayers = [@../outside.usda@]"))
    _refused(capsys, tmp_path, tmp_path / "root-link.usda", *FAST,
             fragment="'../outside.usda' in layer 'root.usda' resolves to")  # fmt: skip


def test_a_nested_reference_out_is_refused_naming_the_layer_that_names_it(tmp_path, capsys):
    _write(tmp_path / "outside.usda", usda(body=FLOOR))
    _write(tmp_path / "scene" / "a" / "one.usda", usda("    subLayers = [@../b/two.usda@]", ""))
    _write(tmp_path / "scene" / "b" / "two.usda", usda(body='def "x" (\n    references = '
                                                        '@../../outside.usda@\n)\n{\n}\n'))  # fmt: skip
    root = _write(tmp_path / "scene" / "root.usda", usda("    subLayers = [@a/one.usda@]"))
    _refused(capsys, tmp_path, root, *FAST,
             fragment="reference or payload '../../outside.usda' in layer 'b/two.usda' resolves")  # fmt: skip


@pytest.mark.parametrize(
    ("asset", "fragment"),
    [
        ("missing.usda", "sublayer 'missing.usda' in layer 'root.usda' does not exist"),
        ("props.usdz", "not a USD layer (.usd, .usda, .usdc)"),
        ("mesh.abc", "not a USD layer"),
        ("sub.usda:SDF_FORMAT_ARGS:a=b", "no file format arguments"),
        ("pkg.usdz[inner.usda]", "no package members"),
        ("folder.usda", "is a folder, not a file"),
    ],
)
def test_layers_that_are_not_plain_usd_files_are_refused(tmp_path, capsys, asset, fragment):
    (tmp_path / "folder.usda").mkdir()
    for name in ("props.usdz", "mesh.abc", "sub.usda"):
        _write(tmp_path / name, usda(body=""))
    root = _write(tmp_path / "root.usda", usda(f"    subLayers = [@{asset}@]"))
    _refused(capsys, tmp_path, root, *FAST, fragment=[asset, fragment])


def test_template_clips_are_refused(tmp_path, capsys):
    body = (
        FLOOR
        + BULB
        + (
            'def Xform "c" (\n    clips = {\n        dictionary d = {\n'
            "            asset templateAssetPath = @clip.#.usda@\n        }\n    }\n)\n{\n}\n"
        )
    )
    root = _write(tmp_path / "root.usda", usda(body=body))
    _refused(capsys, tmp_path, root, *FAST,
             fragment="prim /c: value clips 'd' are given by a template")  # fmt: skip


@pytest.mark.parametrize("arc", ["sublayer", "payload"])
def test_a_fifo_layer_is_refused_without_hanging(tmp_path, arc):
    meta, body = _arc("pipe.usda")[arc]
    root = _write(tmp_path / "root.usda", usda(meta, body))
    os.mkfifo(tmp_path / "pipe.usda")
    before = _snapshot(tmp_path)
    proc = _subprocess(tmp_path, root, *FAST, "--out", tmp_path / "out")
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.count("\n") == 1
    assert "'pipe.usda' in layer 'root.usda' is not a regular file (a pipe" in proc.stderr
    assert _snapshot(tmp_path) == before


def test_usd_core_warnings_are_notes_and_a_refusal_stays_one_line(tmp_path, capsys):
    """usd-core prints its warnings on standard error itself ("Warning: in _ReportErrors at
    line 3326 of stage.cpp -- ..."); attenfit traps them and gives each as one note."""
    proc_root = _write(tmp_path / "root.usda", usda(body=FLOOR + BULB + 'def "x" (\n    '
                                                   "references = </Nope>\n)\n{\n}\n"))  # fmt: skip
    proc = _subprocess(tmp_path, proc_root, *FAST)
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == (
        f"note: root.usda: usd-core: In </x>: Unresolved reference prim path @{proc_root}@</Nope> "
        f"introduced by @{proc_root}@</x>\n"
    )
    notes: list[str] = []
    with pytest.raises(BadValueError, match=r"no mesh to sample receivers on$"):
        load_mesh_scene(_write(proc_root, usda(body=BULB + 'def "x" (\n    references = '
                                               "</Nope>\n)\n{\n}\n")), notice=notes.append)  # fmt: skip
    assert notes == [f"root.usda: usd-core: In </x>: Unresolved reference prim path "
                     f"@{proc_root}@</Nope> introduced by @{proc_root}@</x>"]  # fmt: skip


def test_a_refusal_says_what_usd_core_warned(tmp_path):
    body = FLOOR + BULB.replace("0.05", "0.05\n    float inputs:exposure = 18446744073709551616")
    with pytest.raises(BadValueError) as err:
        load_mesh_scene(_write(tmp_path / "root.usda", usda(body=body)), notice=lambda m: None)
    assert str(err.value).startswith(
        "root.usda: SphereLight /bulb: inputs:intensity 1 x 2^inputs:exposure (1.84467e+19) gives"
    )
    assert re.search(
        r"\(usd-core warned: Integer literal '18446744073709551616' on line \d+ in file "
        + re.escape(str(tmp_path / "root.usda"))
        + r" out of range, parsing as double\. Consider exponential notation for large "
        r"floating point values\.\)$",
        str(err.value),
    )


def test_a_sublayer_cycle_answers(tmp_path, capsys):
    root = _write(tmp_path / "root.usda", usda("    subLayers = [@a.usda@]"))
    _write(tmp_path / "a.usda", usda("    subLayers = [@b.usda@]", ""))
    _write(tmp_path / "b.usda", usda("    subLayers = [@a.usda@, @root.usda@]", ""))
    assert main(["scene", str(root), *FAST, "--json"]) == 0  # usd-core warns, attenfit answers
    assert '"/bulb"' in capsys.readouterr().out


# ----------------------------------------------------------------------------- sizes and memory
def test_a_1gib_sublayer_is_refused_by_its_size(tmp_path, capsys):
    root = _write(tmp_path / "root.usda", usda("    subLayers = [@big.usda@]"))
    with open(tmp_path / "big.usda", "wb") as fh:
        fh.truncate(1 << 30)  # sparse: no disk used
    _refused(capsys, tmp_path, root, *FAST,
             fragment="sublayer 'big.usda' in layer 'root.usda' is 1.02e+03 MiB, over the 256 MiB")  # fmt: skip


def test_a_text_sublayer_over_the_memory_budget_is_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", "2M")
    root = _write(tmp_path / "root.usda", usda("    subLayers = [@sub.usda@]"))
    pts = ", ".join(["(0, 0, 0)"] * 10_000)
    _write(
        tmp_path / "sub.usda", usda(body=f'def Mesh "m"\n{{\n    point3f[] points = [{pts}]\n}}\n')
    )
    _refused(capsys, tmp_path, root, *FAST,
             fragment=["root.usda: its 2 layers (up to sublayer 'sub.usda' in layer 'root.usda') "
                       "needs about", "ATTENFIT_MEMORY_BUDGET"])  # fmt: skip


def test_a_small_crate_file_whose_mesh_inflates_is_refused_before_triangulating(
    tmp_path, capsys, monkeypatch
):
    """The attack's 236 kB `.usdc` held 30,000,000 triangles (crate compresses the repeated
    face-vertex arrays 1,500 to 1); this one holds 3,000,000 in 24 kB, under a 1 GB budget."""
    n = 3_000_000
    path = tmp_path / "bomb.usdc"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/bomb")
    mesh.CreatePointsAttr(Vt.Vec3fArray.FromNumpy(np.eye(3, dtype=np.float32)))
    mesh.CreateFaceVertexCountsAttr(Vt.IntArray.FromNumpy(np.full(n, 3, np.int32)))
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.tile(np.arange(3, dtype=np.int32), n)))  # fmt: skip
    stage.GetRootLayer().Save()
    del stage, mesh
    assert path.stat().st_size < 100_000
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", "1G")
    _refused(capsys, tmp_path, path, *FAST,
             fragment=["bomb.usdc: 1 meshes of 3,000,000 triangles (the largest /bomb, "
                       "3,000,000) needs about 3.12 GB of memory, over the budget of 1 GB"])  # fmt: skip
    # the arrays alone (48 MB decompressed), from the crate's headers, before usd-core opens it
    monkeypatch.setenv("ATTENFIT_MEMORY_BUDGET", "20M")
    root = _write(tmp_path / "root.usda", usda("    subLayers = [@bomb.usdc@]"))
    _refused(capsys, tmp_path, root, *FAST,
             fragment="root.usda: its 2 layers (up to sublayer 'bomb.usdc' in layer 'root.usda') "
                      "needs about 48")  # fmt: skip


def _crate_fields(data: bytes) -> tuple[int, list[int]]:
    """The FIELDS section's start and its value representations, of a crate file's bytes."""
    toc = int.from_bytes(data[16:24], "little")
    for k in range(int.from_bytes(data[toc : toc + 8], "little")):
        entry = toc + 8 + 32 * k
        if data[entry : entry + 16].rstrip(b"\0") == b"FIELDS":
            start = int.from_bytes(data[entry + 16 : entry + 24], "little")
    n = int.from_bytes(data[start : start + 8], "little")
    p = start + 16 + int.from_bytes(data[start + 8 : start + 16], "little")
    size = int.from_bytes(data[p : p + 8], "little")
    raw = _usd_crate._fast_decompress(bytes(data[p + 8 : p + 8 + size]), 8 * n)
    return start, [int.from_bytes(raw[i : i + 8], "little") for i in range(0, len(raw), 8)]


@pytest.mark.parametrize("damage", ["toc", "fields", "reps", "array"])
def test_a_crate_file_with_damaged_headers_is_refused_before_usd_core_opens_it(
    tmp_path, capsys, damage
):
    path = tmp_path / "scene.usdc"
    stage = Usd.Stage.CreateNew(str(path))
    mesh = UsdGeom.Mesh.Define(stage, "/m")
    mesh.CreateFaceVertexIndicesAttr(Vt.IntArray.FromNumpy(np.arange(1000, dtype=np.int32)))
    stage.GetRootLayer().Save()
    del stage, mesh
    data = bytearray(path.read_bytes())
    start, reps = _crate_fields(data)
    assert sum(r >> 63 for r in reps) == 1  # one array: the indices
    fragment = "scene.usdc: a USD crate file whose headers do not parse"
    if damage == "toc":
        data[16:24] = (len(data) + 100).to_bytes(8, "little")
    elif damage == "fields":
        data[start : start + 8] = (10**9).to_bytes(8, "little")
    elif damage == "reps":  # the value representations' LZ4 block, garbled
        p = start + 16 + int.from_bytes(data[start + 8 : start + 16], "little") + 8
        data[p + 1 : p + 9] = b"\xff" * 8
    else:  # the array declares 2^40 elements: 4 TB once decompressed
        offset = next(r for r in reps if r >> 63) & ((1 << 48) - 1)
        data[offset : offset + 8] = (1 << 40).to_bytes(8, "little")
        fragment = "scene.usdc: its root layer needs about 4.4 TB of memory, over the budget"
    path.write_bytes(bytes(data))
    _refused(capsys, tmp_path, path, *FAST, fragment=fragment)


def _explosion(levels: int, instanced: bool) -> str:
    """`/L(k)` holds four prims referencing `/L(k-1)`: 4^levels prims from a few lines."""
    inst = "        instanceable = true\n" if instanced else ""
    out = ['class "L0"\n{\n    def Xform "m"\n    {\n    }\n}\n']
    for k in range(1, levels + 1):
        kids = "".join(
            f'    def Xform "c{j}" (\n{inst}        references = </L{k - 1}>\n    )\n    {{\n    }}\n'
            for j in range(4)
        )
        out.append(f'class "L{k}"\n{{\n{kids}}}\n')
    out.append(f'def Xform "top" (\n    references = </L{levels}>\n)\n{{\n}}\n')
    return usda(body=FLOOR + BULB + "".join(out))


@pytest.mark.parametrize("instanced", [False, True])
def test_references_that_compose_a_million_prims_are_refused_before_composing(
    tmp_path, capsys, instanced
):
    """Without instancing, usd-core took 7 minutes to open such a file (4^10 prims)."""
    root = _write(tmp_path / "root.usda", _explosion(10, instanced))
    _refused(capsys, tmp_path, root, *FAST, fragment=(
        "root.usda: its references, payloads, inherits and instances compose more than "
        "200,000 prims"))  # fmt: skip


@pytest.mark.parametrize("arc", ["sublayer", "reference"])
def test_a_composition_bomb_in_another_layer_is_refused(tmp_path, capsys, arc):
    bomb = _explosion(9, False).replace(FLOOR + BULB, "")
    _write(tmp_path / "bomb.usda", bomb.replace('def Xform "top"', 'def Xform "unused"'))
    if arc == "sublayer":
        root = _write(tmp_path / "root.usda", usda("    subLayers = [@bomb.usda@]"))
    else:
        ref = 'def "x" (\n    references = @bomb.usda@</L9>\n)\n{\n}\n'
        root = _write(tmp_path / "root.usda", usda(body=FLOOR + BULB + ref))
    _refused(capsys, tmp_path, root, *FAST, fragment="compose more than 200,000 prims")
    # a smaller one (4^7 = 16,384 prims under /x) composes
    _write(tmp_path / "bomb.usda", _explosion(7, False).replace(FLOOR + BULB, ""))
    if arc == "reference":
        _write(root, usda(body=FLOOR + BULB + ref.replace("</L9>", "</L7>")))
    assert main(["scene", str(root), *FAST]) == 0, capsys.readouterr().err


def test_deep_nesting_is_refused_before_the_parser_sees_it(tmp_path, capsys):
    """usd-core's parser crashes (a segmentation fault) on 100,000 nested prims."""
    n = 100_000
    root = _write(tmp_path / "root.usda", usda(body=FLOOR + BULB + 'def "a" {\n' * n + "}\n" * n))
    _refused(capsys, tmp_path, root, *FAST, fragment="root.usda: nests brackets 100,000 deep")
    # brackets inside strings, asset paths and comments do not count, nor hide real ones
    body = 'def "a" (\n    doc = "' + "}" * 5000 + '"\n)\n{\n}\n# ' + "{" * 5000 + "\n"
    _write(root, usda(body=FLOOR + BULB + body + 'def "b" {\n' * 1500 + "}\n" * 1500))
    _refused(capsys, tmp_path, root, *FAST, fragment="nests brackets 1,50")


def test_prims_nested_deep_through_references_are_refused(tmp_path, capsys):
    """Each layer is flat, but `/P(k)` holds a prim referencing `/P(k-1)`: 1,500 levels."""
    chain = "".join(
        f'def "P{k}"\n{{\n    def "c" (\n        references = </P{k - 1}>\n    )\n    {{\n    }}\n}}\n'
        for k in range(1, 1501)
    )
    _write(tmp_path / "chain.usda", usda(body='def "P0"\n{\n}\n' + chain))
    ref = 'def "x" (\n    references = @chain.usda@</P1500>\n)\n{\n}\n'
    root = _write(tmp_path / "root.usda", usda(body=FLOOR + BULB + ref))
    _refused(capsys, tmp_path, root, *FAST,
             fragment="root.usda: its prims (references followed) nest up to 1,501 deep")  # fmt: skip


def test_more_layers_than_allowed_are_refused(tmp_path, capsys, monkeypatch):
    monkeypatch.setattr(_usd_layers, "MAX_LAYERS", 3)
    for k in range(4):
        _write(tmp_path / f"l{k}.usda", usda(f"    subLayers = [@l{k + 1}.usda@]", ""))
    _write(tmp_path / "l4.usda", usda(body=""))
    root = _write(tmp_path / "root.usda", usda("    subLayers = [@l0.usda@]"))
    _refused(capsys, tmp_path, root, *FAST, fragment="root.usda: more than 3 layers")


# ----------------------------------------------------------------------------- outputs and inputs
def _composed(tmp_path: Path) -> Path:
    """A scene of three files: the floor in `layers/floor.usda` (a sublayer), the bulb in
    `props/lamp.usda` (a reference)."""
    _write(tmp_path / "layers" / "floor.usda", usda(body=FLOOR))
    _write(tmp_path / "props" / "lamp.usda", usda('    defaultPrim = "bulb"', BULB))
    return _write(
        tmp_path / "root.usda",
        usda("    subLayers = [@layers/floor.usda@]",
             'def "rig" (\n    references = @props/lamp.usda@\n)\n{\n}\n'),
    )  # fmt: skip


def test_write_back_onto_a_sublayer_or_reference_is_refused(tmp_path, capsys):
    root = _composed(tmp_path)
    for target in ("layers/floor.usda", "props/lamp.usda"):
        _refused(capsys, tmp_path, root, *FAST, "--write-back", tmp_path / target, "--force",
                 fragment=f"output '{tmp_path / target}' is an input of this command")  # fmt: skip


def test_out_holding_a_sublayer_is_refused_even_with_force(tmp_path, capsys):
    root = _composed(tmp_path)
    _refused(capsys, tmp_path, root, *FAST, "--out", tmp_path / "layers", "--force",
             fragment=f"output '{tmp_path / 'layers'}' holds an input of this command "
                      f"('{tmp_path / 'layers' / 'floor.usda'}')")  # fmt: skip


def test_the_same_path_twice_is_refused_up_front(tmp_path, capsys):
    root = _composed(tmp_path)
    x = tmp_path / "X.gltf"
    _refused(capsys, tmp_path, root, *FAST, "--out", x, "--write-back", x,
             fragment=f"--out '{x}' and --write-back '{x}' name the same path")  # fmt: skip
    _refused(capsys, tmp_path, root, *FAST, "--out", tmp_path / "o", "--write-back",
             tmp_path / "o" / "copy.usda", fragment="lies inside --out")  # fmt: skip


def test_links_to_an_input_are_refused(tmp_path, capsys):
    root = _composed(tmp_path)
    os.symlink(tmp_path / "layers" / "floor.usda", tmp_path / "soft.usda")
    os.link(tmp_path / "layers" / "floor.usda", tmp_path / "hard.usda")
    _refused(capsys, tmp_path, root, *FAST, "--write-back", tmp_path / "soft.usda", "--force",
             fragment="is an input of this command")  # fmt: skip
    _refused(capsys, tmp_path, root, *FAST, "--write-back", tmp_path / "hard.usda", "--force",
             fragment="is (a hard link to) an input of this command")  # fmt: skip
    _refused(capsys, tmp_path, root, *FAST, "--out", tmp_path / "root.usda" / "x",
             fragment="lies inside an input of this command")  # fmt: skip


def test_force_replaces_only_what_attenfit_wrote(tmp_path, capsys):
    root = _composed(tmp_path)
    _write(tmp_path / "mine.usda", usda(body=FLOOR))  # the user's, not a scene input
    (tmp_path / "docs").mkdir()
    _write(tmp_path / "docs" / "notes.txt", "keep me")
    _refused(capsys, tmp_path, root, *FAST, "--write-back", tmp_path / "mine.usda", "--force",
             fragment="was not written by attenfit; --force replaces only attenfit's own")  # fmt: skip
    _refused(capsys, tmp_path, root, *FAST, "--out", tmp_path / "docs", "--force",
             fragment="holds none of answer.json, recommendation.json")  # fmt: skip
    # attenfit's own outputs are replaced
    copy, out = tmp_path / "copy.usda", tmp_path / "answer"
    argv = ["scene", str(root), *FAST, "--write-back", str(copy), "--out", str(out)]
    assert main(argv) == 0
    assert main([*argv, "--force"]) == 0, capsys.readouterr().err
    layer = pxr.Sdf.Layer.FindOrOpen(str(copy))
    assert layer.customLayerData["attenfitWriteBack"] == "root.usda"
    assert (out / "answer.json").is_file()
    assert (tmp_path / "mine.usda").read_text() == usda(body=FLOOR)


def test_the_api_refuses_outputs_onto_a_layer_of_the_scene(tmp_path):
    """Outside the command line (no command tracking its inputs), the answer knows the files
    its scene read: `save` and `write_back` refuse them too."""
    root = _composed(tmp_path)
    ans = answer_file(root, engine="godot", samples=16, notice=lambda m: None)
    assert set(ans.imported.inputs) == {
        str(root),
        str(tmp_path / "layers" / "floor.usda"),
        str(tmp_path / "props" / "lamp.usda"),
    }
    before = _snapshot(tmp_path)
    with pytest.raises(BadValueError, match="is an input of this command"):
        ans.write_back(tmp_path / "props" / "lamp.usda", force=True)
    with pytest.raises(BadValueError, match="holds an input of this command"):
        ans.save(tmp_path / "layers", force=True)
    assert _snapshot(tmp_path) == before


def test_a_gltf_out_holding_its_buffer_is_refused(tmp_path, capsys):
    """The same rule for glTF: its buffers are inputs, found before any work."""
    pytest.importorskip("pygltflib")
    from test_scene_files import _gltf, _light_node

    path = _gltf(tmp_path, [{"type": "point", "intensity": 10.0}], [_light_node("L", 0)])
    data = path.read_text()
    m = re.search(r'"uri": "data:application/octet-stream;base64,([^"]*)"', data)
    assert m is not None
    (tmp_path / "bin").mkdir()
    (tmp_path / "bin" / "floor.bin").write_bytes(base64.b64decode(m.group(1)))
    path.write_text(data.replace(m.group(0), '"uri": "bin/floor.bin"'))
    _refused(capsys, tmp_path, path, *FAST, "--radius", "0.05", "--out", tmp_path / "bin",
             "--force", fragment=f"holds an input of this command ('{tmp_path / 'bin' / 'floor.bin'}')")  # fmt: skip


# ----------------------------------------------------------------------------- former internal errors
LIGHTS = {
    "radius": ('    double inputs:radius = 1e300\n', "SphereLight /bulb: radius 1e+300 m"),
    "exposure": ("    float inputs:exposure = 10000\n", "SphereLight /bulb: inputs:intensity 1 "
                 "x 2^inputs:exposure (10000) gives a point-equivalent intensity of 2^"),
    "nan": ("    float inputs:intensity = nan\n", "SphereLight /bulb: inputs:intensity must be finite"),
    "type": ('    string inputs:radius = "big"\n', "SphereLight /bulb: inputs:radius must be a "
             "number, got 'big'"),
    "cone": ("    float inputs:shaping:cone:angle = -5\n", "SphereLight /bulb: inputs:shaping:cone:angle -5 deg"),
    "flag": ('    int inputs:normalize = 3\n', "SphereLight /bulb: inputs:normalize must be true or false, got 3"),
}  # fmt: skip


@pytest.mark.parametrize("case", list(LIGHTS))
def test_extreme_light_values_exit_2_naming_the_prim_and_attribute(tmp_path, capsys, case):
    line, fragment = LIGHTS[case]
    body = FLOOR + BULB.replace('    float inputs:radius = 0.05\n', line if case != "cone"
                                else '    float inputs:radius = 0.05\n' + line)  # fmt: skip
    if case == "cone":
        body = body.replace('def SphereLight "bulb"', 'def SphereLight "bulb" (\n    prepend '
                            'apiSchemas = ["ShapingAPI"]\n)')  # fmt: skip
    root = _write(tmp_path / "root.usda", usda(body=body))
    _refused(capsys, tmp_path, root, *FAST, fragment=f"root.usda: {fragment}")


@pytest.mark.parametrize(
    ("old", "new", "fragment"),
    [  # found by the fuzz campaign: usd-core raised, or handed back a value of no type
        ("    double3 xformOp:translate = (0, 0, 2)", "    float xformOp:translate = 2",
         "SphereLight /bulb: usd-core cannot read it (Invalid combination of opType"),
        ("point3f[] points", "point90f[] points",
         "Mesh /floor: points must be an array, got"),
    ],
)  # fmt: skip
def test_values_usd_core_cannot_read_exit_2_naming_the_prim(tmp_path, capsys, old, new, fragment):
    root = _write(tmp_path / "root.usda", usda().replace(old, new))
    _refused(capsys, tmp_path, root, *FAST, fragment=f"root.usda: {fragment}")


def test_a_radius_given_of_1e300_exits_2(tmp_path, capsys):
    body = FLOOR + BULB.replace("float inputs:radius = 0.05", "bool treatAsPoint = 1")
    root = _write(tmp_path / "root.usda", usda(body=body))
    _refused(capsys, tmp_path, root, *FAST, "--radius", "1e300",
             fragment="SphereLight /bulb: radius 1e+300 m")  # fmt: skip


def test_meters_per_unit_of_1e300_exits_2(tmp_path, capsys):
    root = _write(
        tmp_path / "root.usda", usda().replace("metersPerUnit = 1", "metersPerUnit = 1e300")
    )
    _refused(capsys, tmp_path, root, *FAST,
             fragment="root.usda: metersPerUnit 1e+300: must be a length from 1e-12 to 1e12 m")  # fmt: skip


def test_a_floor_scaled_flat_exits_2(tmp_path, capsys):
    floor = FLOOR.replace(
        '    int[] faceVertexCounts',
        '    double3 xformOp:scale = (1, 1, 0)\n    uniform token[] xformOpOrder = '
        '["xformOp:scale"]\n    int[] faceVertexCounts',
    )  # fmt: skip
    root = _write(tmp_path / "root.usda", usda(body=floor + BULB))
    _refused(capsys, tmp_path, root, *FAST,
             fragment="root.usda: Mesh /floor: its world transform is singular (scales 1, 1, 0)")  # fmt: skip


def test_points_too_far_for_metres_exit_2(tmp_path, capsys):
    floor = FLOOR.replace("(-5, -5, 0), (5, -5, 0)", "(-1e300, -5, 0), (1e300, -5, 0)").replace(
        "point3f[]", "double3[]"
    )
    root = _write(tmp_path / "root.usda", usda(body=floor + BULB).replace(
        "metersPerUnit = 1", "metersPerUnit = 1e12"))  # fmt: skip
    _refused(capsys, tmp_path, root, *FAST, fragment="Mesh /floor: points not finite in metres")


def test_a_light_inside_an_instance_is_written_back_per_instance(tmp_path, capsys):
    """Writing to an instance proxy raised inside usd-core (exit 1): the copy makes each
    instance holding a light not instanceable, so each keeps its own answer."""
    lamps = "".join(
        f'def Xform "lamp{k}" (\n    instanceable = true\n    references = </Proto>\n)\n{{\n'
        f"    double3 xformOp:translate = ({k}, 0, 2)\n"
        '    uniform token[] xformOpOrder = ["xformOp:translate"]\n}\n'
        for k in (1, 2)
    )
    proto = 'class "Proto"\n{\n    def SphereLight "bulb"\n    {\n        float inputs:radius = 0.05\n    }\n}\n'  # fmt: skip
    root = _write(tmp_path / "root.usda", usda(body=FLOOR + proto + lamps))
    before = root.read_bytes()
    copy = tmp_path / "copy.usda"
    assert main(["scene", str(root), *FAST, "--write-back", str(copy)]) == 0
    assert root.read_bytes() == before
    stage = Usd.Stage.Open(str(copy))
    ranges = [
        stage.GetPrimAtPath(f"/lamp{k}/bulb").GetAttribute("attenfit:params:r_max").Get()
        for k in (1, 2)
    ]
    assert all(r is not None and r > 0 for r in ranges)
    im = load_mesh_scene(copy, samples=16, notice=lambda m: None)
    assert im.names == ("/lamp1/bulb", "/lamp2/bulb")
    assert [x.position for x in im.scene.lights] == [(1.0, 0.0, 2.0), (2.0, 0.0, 2.0)]


# ----------------------------------------------------------------------------- fuzz campaign
NUMBERS = ["nan", "inf", "-inf", "1e300", "-1e300", "1e-320", "0", "-0", "1e40", "3.4e38",
           "-5", "1e-45", "7e22", "18446744073709551616", "2147483648"]  # fmt: skip
TYPES = ["float", "double", "int", "string", "bool", "token", "half", "float3", "asset", "uint"]
OUTSIDE = ["../x.usda", "/dev/zero", "/etc/passwd", "pipe.usda", "big.usda", "root.usda",
           "none.usda", "", "anon:0x1", "http://example.com/a.usda", "a.usdz", "@"]  # fmt: skip
SPOT = """def DiskLight "spot" (
    prepend apiSchemas = ["ShapingAPI"]
)
{
    float inputs:radius = 0.1
    float inputs:intensity = 3
    float inputs:exposure = 1
    bool inputs:normalize = 1
    float inputs:shaping:cone:angle = 40
    float inputs:shaping:cone:softness = 0.3
    double3 xformOp:translate = (1, 0, 3)
    float3 xformOp:scale = (2, 2, 2)
    uniform token[] xformOpOrder = ["xformOp:translate", "xformOp:scale"]
}
"""
BASE = usda('    upAxis = "Z"', FLOOR + BULB + SPOT)


def _mutate(text: str, rng: random.Random) -> str:
    lines = text.split("\n")
    for _ in range(rng.randint(1, 3)):
        how = rng.choice(["number", "type", "asset", "delete", "duplicate"])
        k = rng.randrange(len(lines))
        if how == "number":
            nums = list(re.finditer(r"-?\d+(\.\d+)?(e-?\d+)?", lines[k]))
            if nums:
                m = rng.choice(nums)
                lines[k] = lines[k][: m.start()] + rng.choice(NUMBERS) + lines[k][m.end() :]
        elif how == "type":
            lines[k] = re.sub(r"\b(float|double|int|bool|point3f|normal3f|double3|float3)\b",
                              rng.choice(TYPES), lines[k], count=1)  # fmt: skip
        elif how == "asset":
            arc = rng.choice(["subLayers = [@{}@]", "references = @{}@", "payload = @{}@"])
            asset = rng.choice(OUTSIDE)
            if arc.startswith("subLayers"):
                lines.insert(3, "    " + arc.format(asset))
            else:
                lines.append(f'def Xform "z" (\n    {arc.format(asset)}\n)\n{{\n}}')
        elif how == "delete":
            del lines[k]
        else:
            lines.insert(k, lines[k])
    return "\n".join(lines)


def test_fuzz_mutated_usda_exits_0_or_2(tmp_path, capsys):
    """100 seeded mutations of a valid scene (a sphere and a scaled, normalised disk spot):
    each answers (0) or is refused in one line (2); never an internal error or a hang.
    `ATTENFIT_FUZZ_SCALE=10` runs ten times as many, from a fresh seed."""
    os.mkfifo(tmp_path / "pipe.usda")
    with open(tmp_path / "big.usda", "wb") as fh:
        fh.truncate(300 << 20)
    root = tmp_path / "root.usda"
    root.write_text(BASE, encoding="utf-8")
    assert main(["scene", str(root), *FAST]) == 0, capsys.readouterr().err  # unmutated: valid
    rng = random.Random(20261125 if SCALE == 1 else random.randrange(1 << 30))
    codes = []
    for k in range(100 * SCALE):
        text = _mutate(BASE, rng)
        root.write_text(text, encoding="utf-8")
        code = main(["scene", str(root), *FAST, "--write-back", str(tmp_path / "copy.usda"),
                     "--force"])  # fmt: skip
        err = capsys.readouterr().err
        assert code in (0, 2), f"mutation {k}: exit {code}: {err}\n{text}"
        assert "internal error" not in err and "Traceback" not in err, f"{k}: {err}\n{text}"
        if code == 2:
            *notes, last = err.strip().split("\n")  # one error line, after any notes
            assert last.startswith("attenfit: error: "), f"{k}: {err}"
            assert all(x.startswith("note: ") for x in notes), f"{k}: {err}"
        codes.append(code)
    assert codes.count(0) >= 10 and codes.count(2) >= 30, codes  # the campaign hits both
