"""The engine snippets compiled for the cost column (`attenfit._shaders._engines`) and the
engine witness (`attenfit._judge._engine_shading`) transcribe the same engine functions:
each snippet's text, the very GLSL that is compiled, is run here (a small reader of its C
subset: declarations, compound assignments, `if`, `return`) and compared with the witness's
distance falloff for the same engine at sample distances."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from attenfit._judge import get_witness
from attenfit._shaders._engines import ENGINE_SNIPPETS, engine_source

D = np.concatenate([np.geomspace(0.003, 0.5, 25), np.linspace(0.5, 11.5, 45)])


def _python(source: str) -> str:
    """The snippet's GLSL as Python (its subset only; anything else is refused)."""
    text = "\n".join(ln for ln in source.splitlines() if not ln.startswith("#"))
    text = re.sub(r"//[^\n]*", "", text)
    text = re.sub(r"(\d(?:\.\d*)?(?:[eE][+-]?\d+)?)f\b", r"\1", text)  # 1.0f -> 1.0
    text = re.sub(r"([{;])", r"\1\n", text).replace("}", "\n}\n")
    out, depth = [], 0
    for raw in text.splitlines():
        line = raw.strip()
        if not line:
            continue
        if line == "}":
            depth -= 1
            continue
        m = re.fullmatch(r"FN float (\w+)\(([^)]*)\) \{", line)
        if m:
            args = ", ".join(a.split()[-1] for a in m.group(2).split(","))
            out.append("    " * depth + f"def {m.group(1)}({args}):")
            depth += 1
            continue
        m = re.fullmatch(r"if \((.*)\) \{", line)
        if m:
            out.append("    " * depth + f"if {m.group(1)}:")
            depth += 1
            continue
        m = re.fullmatch(r"(?:float )?(.*);", line)
        assert m, f"not in the snippet subset: {line!r}"
        out.append("    " * depth + m.group(1))
    assert depth == 0
    return "\n".join(out)


def _run_snippet(family: str, params: dict[str, float], d: np.ndarray) -> np.ndarray:
    def clamp(x, lo, hi):
        return min(max(x, lo), hi)

    scope = {
        "clamp": clamp,
        "saturate": lambda x: clamp(x, 0.0, 1.0),
        "pow": math.pow,
        "sqrt": math.sqrt,
        "max": max,
        "min": min,
    }
    exec(_python(engine_source(family, params, "glsl")), scope)
    return np.array([scope["engine"](float(x)) for x in d])


#: (snippet family, its parameters, the witness's engine, the same light in its properties)
PAIRS = [
    ("godot", {"r_max": 9.0, "a": 1.7}, "godot", {"omni_range": 9.0, "omni_attenuation": 1.7}),
    ("threejs", {"cutoff": 9.0, "decay": 2.0}, "threejs", {"distance": 9.0, "decay": 2.0}),
    ("threejs", {"cutoff": 0.0, "decay": 1.6}, "threejs", {"distance": 0.0, "decay": 1.6}),
    (
        "unreal_window",
        {"r_max": 9.0, "eps": 1e-4},
        "unreal",
        {"AttenuationRadius": 900.0, "bUseInverseSquaredFalloff": True},
    ),
    (
        "unreal_exponent",
        {"r_max": 9.0, "p": 3.0},
        "unreal",
        {
            "AttenuationRadius": 900.0,
            "bUseInverseSquaredFalloff": False,
            "LightFalloffExponent": 3.0,
        },
    ),
    ("frostbite_window", {"r_max": 9.0, "r_min": 0.01}, "filament", {"falloff": 9.0}),
    ("frostbite_window", {"r_max": 9.0, "r_min": 0.01}, "bevy", {"range": 9.0}),
    ("frostbite_window", {"r_max": 9.0, "r_min": 2.0**-7}, "unity", {"range": 9.0}),
    ("gltf_range", {"range": 9.0}, "gltf", {"range": 9.0}),
    ("gltf_range", {"range": 0.0}, "gltf", {"range": 0.0}),
]


@pytest.mark.parametrize(("family", "params", "engine", "props"), PAIRS)
def test_snippet_and_witness_agree(family, params, engine, props):
    got = _run_snippet(family, params, D)
    want = get_witness(engine).distance(D, props)
    np.testing.assert_allclose(got, want, rtol=2e-5, atol=1e-6 * np.abs(want).max())


def test_every_engine_witness_has_a_snippet():
    """Every engine's distance falloff is compiled for the cost column (the witnesses'
    engines, by the snippets they are compared with above)."""
    from attenfit._judge import WITNESSES

    assert {w.name for w in WITNESSES} == {p[2] for p in PAIRS}
    assert {p[0] for p in PAIRS} <= set(ENGINE_SNIPPETS)
