"""`attenfit.cost.compiled_cost`: instruction counts from real compilers, labelled, cached,
and the traced-operation estimate where no compiler is installed."""

from __future__ import annotations

import pytest

import attenfit
from attenfit import cost
from attenfit._shaders import _compilers as _compile

BUILTIN = {getattr(attenfit.families, c).name for c in attenfit.families.__all__}
FAMILIES = [n for n in attenfit.list_families() if n in BUILTIN]


def _need(target: str) -> None:
    why = _compile.missing(target)
    if why:
        pytest.skip(f"{target}: {why}")


@pytest.fixture(autouse=True)
def _private_cache(tmp_path, monkeypatch):
    monkeypatch.setenv("ATTENFIT_CACHE_DIR", str(tmp_path / "cache"))


def test_inverse_square_is_a_multiply_and_a_divide_in_spirv():
    _need("spirv")
    c = cost.compiled_cost(attenfit.get_family("inverse_square")())
    assert c.form == "shader" and c.method == "spirv"
    # 1.0 / (d * d): OpFMul, OpFDiv
    assert c.spirv.total == 2 and c.spirv.classes["arithmetic"] == 2
    assert "glslangValidator" in c.spirv.tool and "spirv-opt -O" in c.label()


def test_yuksel_has_one_sqrt_as_an_extended_instruction():
    _need("spirv")
    c = cost.compiled_cost(attenfit.Yuksel(r=0.05))
    assert c.spirv.classes["extended"] == 1  # sqrt
    assert c.spirv.classes["select"] == 0 and c.spirv.classes["branch"] == 0


def test_sass_counts_mufu_apart():
    _need("sass")
    c = cost.compiled_cost(attenfit.Yuksel(r=0.05))
    # 2/(...) is a reciprocal, sqrt a square root: two MUFU operations under fast math
    assert c.sass.classes["mufu"] == 2
    assert "ptxas" in c.sass.tool and "sm_89" in c.sass.tool


@pytest.mark.parametrize("name", FAMILIES)
def test_the_shader_form_costs_no_more_than_the_stable_form(name):
    _need("spirv")
    fam = attenfit.get_family(name)()
    shader = cost.compiled_cost(fam, sass=False)
    stable = cost.compiled_cost(fam, form="stable", sass=False)
    assert stable.form == "stable"
    assert shader.spirv.total <= stable.spirv.total, (name, shader.spirv, stable.spirv)


def test_results_are_cached_by_source_text(tmp_path):
    _need("spirv")
    fam = attenfit.get_family("clamped")()
    first = cost.compiled_cost(fam, sass=False)

    def entries():
        return list((tmp_path / "cache" / "entries").rglob("compiled/*.bin"))

    assert len(entries()) == 1
    second = cost.compiled_cost(fam, sass=False)
    assert second == first and len(entries()) == 1
    other = cost.compiled_cost(fam.replace(r_min=0.3), sass=False)  # a new text, a new entry
    assert len(entries()) == 2
    assert other.spirv.total == first.spirv.total
    # the structural cost (what ranks a scene's candidates) does not depend on the values
    a = cost.structural_cost(fam.replace(r_min=0.02))
    b = cost.structural_cost(fam.replace(r_min=1.7))
    assert a == b and len(entries()) == 3


def test_without_compilers_the_cost_is_a_labelled_estimate(monkeypatch):
    monkeypatch.setattr(_compile, "compilers", lambda: dict.fromkeys(["glslangValidator"]))
    c = cost.compiled_cost(attenfit.get_family("inverse_square")())
    assert c.method == "estimate" and c.spirv is None and c.sass is None
    assert c.label().startswith("estimate")
    w = cost.SHADER_WEIGHTS
    assert c.cost == w["mul"] + w["div"]  # 1/(d*d) weighed by the traced-operation model
