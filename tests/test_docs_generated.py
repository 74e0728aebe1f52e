"""The generated tables of the docs are what the code now produces (`make docs` rewrites them).

Every section `docs/generate.py` makes is deterministic; here each is made again and compared
with the text in its page. Numbers at rounding level (below 1e-10, a value that is exact up to
floating-point noise, e.g. "3.4e-14%") may differ in their digits between library versions;
every other token must match.
"""

from __future__ import annotations

import importlib.util
import re
import sys

import pytest
from _doc_pages import ROOT

_spec = importlib.util.spec_from_file_location("docs_generate", ROOT / "docs" / "generate.py")
generate = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = generate  # dataclasses look their module up
_spec.loader.exec_module(generate)

_NUMBER = re.compile(r"[-+−]?(?:\d+\.?\d*|\.\d+)(?:e[-+]?\d+)?%?")


def _value(token: str) -> float:
    scale = 0.01 if token.endswith("%") else 1.0
    return float(token.rstrip("%").replace("−", "-")) * scale


def same_text(a: str, b: str) -> bool:
    """`a == b`, except that two numbers both below 1e-10 in magnitude count as equal."""
    ta, tb = _NUMBER.split(a), _NUMBER.split(b)
    na, nb = _NUMBER.findall(a), _NUMBER.findall(b)
    if ta != tb or len(na) != len(nb):
        return False
    return all(
        x == y or (abs(_value(x)) < 1e-10 and abs(_value(y)) < 1e-10)
        for x, y in zip(na, nb, strict=True)
    )


def test_rounding_level_numbers_only_are_forgiven():
    assert same_text("| a | 3.4e-14% | 12 |", "| a | 5.1e-14% | 12 |")
    assert not same_text("| a | 3.4e-14% | 12 |", "| a | 3.4e-14% | 13 |")
    assert not same_text("| a | 1.5% |", "| a | 1.6% |")
    assert not same_text("winner `polynomial`", "winner `unreal_epsilon`")


@pytest.fixture(scope="module")
def inputs():
    return generate.Inputs()


#: Sections made from the full default report, its decision's worst-case searches or the
#: example scenes' recommendations (a minute or more each from a cold cache): run with
#: `pytest -m slow` or `python docs/generate.py --check`.
HEAVY = {"report-decision", "report-decision-doc", "report-summary", "report-findings",
         "area-worst", "example-scenes", "spirv-costs", "sass-costs"}  # fmt: skip


@pytest.mark.parametrize(
    "name",
    [pytest.param(n, marks=pytest.mark.slow) if n in HEAVY else n for n in generate.SECTIONS],
)
def test_generated_section_is_current(name, inputs):
    try:
        made = generate.SECTIONS[name].make(inputs).rstrip("\n")
    except generate.SkipSection as why:
        pytest.skip(str(why))
    first, page_first = made.split("\n", 1)[0], generate.current(name).split("\n", 1)[0]
    if first.startswith("Compiled with") and first != page_first:
        pytest.skip(f"{name}: this machine's compilers differ from the page's ({first})")
    assert same_text(made, generate.current(name)), (
        f"{generate.SECTIONS[name].page}: section {name!r} is stale; run `make docs`"
    )


def test_generated_figures_exist():
    for name in ("report_attenuation.png", "yuksel_fig3.png"):
        path = ROOT / "docs" / "figures" / name
        assert path.is_file() and path.stat().st_size > 20_000, path
