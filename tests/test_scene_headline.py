"""A scene's answer reads as one answer: one headline, and a fitted `r` far from the light's
radius reported as a shape parameter of the curve (issue 28, item 6)."""

from __future__ import annotations

from pathlib import Path

import pytest

import attenfit as af
from attenfit._scenes._advice import SHAPE_RATIO, param_text

SCENES = Path(__file__).resolve().parent.parent / "examples" / "scenes"


@pytest.mark.parametrize(
    ("value", "shape"),
    [(0.08, False), (0.16, False), (0.04, False), (2.66, True), (0.01, True)],
)
def test_a_fitted_radius_far_from_the_lights_is_a_shape_parameter(value, shape):
    text = param_text("r", value, 0.08)
    assert text.startswith(f"r = {value:.6g}")
    assert ("shape parameter" in text) is shape
    if shape:
        assert f"{value / 0.08:.3g}x the light's radius 0.08" in text
    assert SHAPE_RATIO == 2.0


def test_other_parameters_and_unknown_radii_are_plain():
    assert param_text("r_max", 40.0, 0.08) == "r_max = 40"
    assert param_text("r", 2.66, None) == "r = 2.66"


def test_a_recommendation_inside_a_file_answer_is_no_second_headline():
    rec = af.recommend(af.Scene.load(SCENES / "room.toml"), measure=False)
    alone = rec.to_markdown()
    assert alone.startswith("# Recommendation for")
    assert f"**{rec.summary()}**" in alone
    inside = rec.to_markdown(together=True)
    assert inside.startswith("## All lights together: one family for every light")
    assert "**" not in inside.split("\n\n")[1]  # the verdict is not a headline there
    assert not [x for x in inside.splitlines()[1:] if x.startswith("## ")]  # one level down
