"""A scene's `precision`: the shader forms are judged in float32 or float16 at the scene's
receivers, and a family that fails there is refused with the reason."""

from __future__ import annotations

import pytest

import attenfit
from attenfit import Scene


def _scene(precision=None, float32=None, d=(0.5, 3.0), radius=0.1) -> Scene:
    cons: dict = {"families": ["inverse_square", "clamped"]}
    if precision is not None:
        cons["precision"] = precision
    if float32 is not None:
        cons["float32"] = float32
    return Scene.from_dict(
        {
            "tolerance": 0.05,
            "constraints": cons,
            "lights": [{"kind": "sphere", "radius": radius, "height": 1.0}],
            "receivers": [{"kind": "distribution", "distance": list(d), "n": 200}],
        },
        source="t.toml",
    )


def test_precision_key_and_its_float32_synonym():
    assert _scene().precision == "float64"
    assert _scene("float16").precision == "float16"
    assert _scene(float32=True).precision == "float32" and _scene(float32=True).float32
    assert _scene("float32").float32
    assert Scene.from_dict(_scene("float16").to_dict()).precision == "float16"


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"precision": "half"}, "t.toml: [constraints].precision: must be one of float64, float32, float16, got 'half'"),
        ({"precision": "float16", "float32": True}, "t.toml: [constraints].precision: is 'float16' but float32 = true says float32"),
    ],
)  # fmt: skip
def test_bad_precision_is_a_one_line_error(kwargs, message):
    with pytest.raises(attenfit.BadValueError) as info:
        _scene(**kwargs)
    assert str(info.value) == message


def test_float16_refuses_what_overflows_at_the_scenes_distances():
    """1/d^2 exceeds float16's 65504 below d = 3.9 mm: inverse square fails there."""
    rec = attenfit.recommend(_scene("float16", d=(2e-3, 0.5), radius=1e-3), measure=False)
    inv = next(c for c in rec.candidates if c.family == "inverse_square")
    assert inv.status == "fail"
    assert inv.reason.startswith("fails in float16: overflows (inf) for d in [")
    assert "float16 shading" in rec.to_markdown()
