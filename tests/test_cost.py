"""`attenfit.cost`: operation counts of known expressions, shader cost, throughput, Pareto front."""

from __future__ import annotations

import math

import jax.numpy as jnp
import matplotlib
import numpy as np
import pytest

import attenfit
from attenfit import cost
from attenfit.cost import SHADER_WEIGHTS as W

#: The library's own families (other test modules may register test families).
BUILTIN = {getattr(attenfit.families, c).name for c in attenfit.families.__all__}

matplotlib.use("Agg")


# ----------------------------------------------------------------------------- hand-made families
class _InvSq(attenfit.Family):
    name = "cost_test_inverse_square"
    formula = "1/d^2"
    source = "test"
    default_free = ()
    shader_form = attenfit.no_shader_form

    def __call__(self, d):
        d = jnp.asarray(d)
        return 1.0 / (d * d)


class _Yuksel(attenfit.Family):
    r: float = 0.1
    name = "cost_test_yuksel"
    formula = "2/(s(s+d)), s = sqrt(d^2+r^2)"
    source = "test"
    default_free = ("r",)
    shader_form = attenfit.no_shader_form

    def __call__(self, d):
        d = jnp.asarray(d)
        r = jnp.asarray(self.r, d.dtype)
        s = jnp.sqrt(d * d + r * r)
        return 2.0 / (s * (s + d))


class _Window(attenfit.Family):
    r_max: float = 10.0
    name = "cost_test_window"
    formula = "(1 - (d/r_max)^4)+^2 / d^2, clipped"
    source = "test"
    default_free = ("r_max",)
    shader_form = attenfit.no_shader_form

    def __call__(self, d):
        d = jnp.asarray(d)
        rm = jnp.asarray(self.r_max, d.dtype)
        x = jnp.clip(1 - (d / rm) ** 4, 0.0, 1.0)
        return jnp.where(d < rm, x**2 / jnp.maximum(d, 0.01) ** 2, 0.0)


class _Tan(attenfit.Family):
    d_max: float = 10.0
    name = "cost_test_tan"
    formula = "1/(1 + tan(d/d_max))^2"
    source = "test"
    default_free = ("d_max",)
    shader_form = attenfit.no_shader_form

    def __call__(self, d):
        d = jnp.asarray(d)
        dm = jnp.asarray(self.d_max, d.dtype)
        return 1.0 / (1.0 + jnp.tan(d / (2 * dm))) ** 2


def _ops(**nonzero):
    out = dict.fromkeys(cost.CATEGORIES, 0)
    out.update(nonzero)
    return out


def test_inverse_square_is_one_multiply_and_one_division():
    assert cost.count_ops(_InvSq()) == _ops(mul=1, div=1)
    assert cost.shader_cost(_InvSq()) == W["mul"] + W["div"]


def test_yuksel_counts():
    # d*d + r*r -> sqrt -> s + d -> s*(s+d) -> 2/...; r*r is uniform; d*d fuses into the add
    assert cost.count_ops(_Yuksel()) == _ops(add=2, mul=2, fma=1, div=1, sqrt=1, uniform=1)
    assert cost.shader_cost(_Yuksel()) == 2 * W["add"] + 2 * W["mul"] - 1 + W["div"] + W["sqrt"]


def test_window_counts_integer_powers_as_xla_multiplies():
    # d/rm; ^4 = two squarings; 1 - x^4 (an FMA); clip = max + min; d < rm; x^2;
    # max(d, .01); ^2; /; where
    assert cost.count_ops(_Window()) == _ops(add=1, mul=4, fma=1, div=2, select=4, compare=1), (
        cost.count_ops(_Window())
    )


def test_tan_is_a_transcendental_and_parameter_work_is_uniform():
    ops = cost.count_ops(_Tan())
    assert ops == _ops(add=1, mul=1, div=2, transcendental=1, uniform=1), ops
    assert cost.shader_cost(_Tan()) == W["add"] + W["mul"] + 2 * W["div"] + W["tan"]


def test_registered_families_as_the_brief_states():
    inv = cost.count_ops("inverse_square")
    assert inv["div"] == 1 and inv["mul"] == 1 and inv["sqrt"] == 0
    assert inv["transcendental"] == 0
    assert cost.count_ops("yuksel")["sqrt"] == 1
    assert cost.count_ops("madams_tan")["transcendental"] >= 1
    assert cost.count_ops("unreal_exponent")["transcendental"] >= 1  # pow


def test_weights_follow_the_documented_composition():
    assert W["rsqrt"] == 4 and W["sqrt"] == W["rsqrt"] + W["mul"]
    assert W["div"] == 4 + W["mul"]
    assert W["pow"] == W["exp2"] + W["mul"] + 4
    assert W["tan"] == 2 * 5 - 1 + W["div"]  # sin + cos sharing one range reduction, + div
    assert W["abs"] == W["neg"] == 0


def test_cost_table_without_measuring_covers_every_family():
    names = [n for n in attenfit.list_families() if n in BUILTIN]
    table = cost.cost_table(names, measure=False)
    assert list(table) == names and len(names) >= 20
    for name, c in table.items():
        assert c.ns_per_eval is None and c.ratio_to_inverse_square is None
        assert set(c.ops) == set(cost.CATEGORIES)
        assert c.shader_cost >= W["div"], name  # every family divides at least once
        assert c.to_dict()["family"] == name
    # the bare curve is the cheapest of all by the weighted count
    assert min(table.values(), key=lambda c: c.shader_cost).family == "inverse_square"


def test_measured_throughput_is_relative_to_inverse_square():
    table = cost.cost_table(["inverse_square", "madams_tan"], n=4096, repeats=3)
    inv, tan = table["inverse_square"], table["madams_tan"]
    assert inv.ratio_to_inverse_square == 1.0
    assert inv.ns_per_eval > 0 and tan.ns_per_eval > 0 and tan.ns_iqr >= 0
    assert tan.ratio_to_inverse_square == pytest.approx(tan.ns_per_eval / inv.ns_per_eval)
    one = cost.family_cost("yuksel", n=4096, repeats=2)  # times inverse_square alongside
    assert one.family == "yuksel" and one.ratio_to_inverse_square > 0


def test_measure_throughput_rejects_bad_arguments():
    with pytest.raises(attenfit.BadValueError, match="distinct"):
        cost.measure_throughput(["yuksel", "yuksel"])
    with pytest.raises(attenfit.BadValueError, match="n must be"):
        cost.measure_throughput(["yuksel"], n=10)
    with pytest.raises(attenfit.BadValueError, match="d_range"):
        cost.measure_throughput(["yuksel"], d_range=(1.0, 0.5))
    with pytest.raises(attenfit.UnknownNameError, match="unknown family 'nope'"):
        cost.family_cost("nope", measure=False)


# ----------------------------------------------------------------------------- Pareto front
ERRORS = {"a": 0.5, "b": 0.1, "c": 0.2, "d": 0.01, "e": 0.01, "f": float("nan"), "g": 0.1}
COSTS = {"a": 1.0, "b": 2.0, "c": 3.0, "d": 10.0, "e": 12.0, "f": 0.5, "g": 2.0}


def test_pareto_front_by_hand():
    pf = cost.pareto_front(ERRORS, COSTS)
    # by cost: f (0.5, inf) a (1, .5) b,g (2, .1) c (3, .2) d (10, .01) e (12, .01)
    # f is the cheapest, so nothing dominates it despite its NaN (= infinite) error;
    # b and g tie exactly, so neither dominates the other
    assert pf.front == ("f", "a", "b", "g", "d")
    assert pf.dominated == {"c": "b", "e": "d"}
    rows = pf.table()
    assert [r["family"] for r in rows] == ["f", "a", "b", "g", "c", "d", "e"]
    assert rows[4] == {
        "family": "c",
        "cost": 3.0,
        "error": 0.2,
        "on_front": False,
        "dominated_by": "b",
    }


def test_pareto_front_uses_cost_records():
    costs = {k: cost.Cost(k, v * 2, v, {}, 100 - v) for k, v in COSTS.items()}
    by_shader = cost.pareto_front(ERRORS, costs)  # reversed costs: e is now the cheapest
    assert by_shader.front == ("e",) and set(by_shader.dominated) == set(COSTS) - {"e"}
    by_time = cost.pareto_front(ERRORS, costs, by="ns_per_eval")
    assert by_time.front == ("f", "a", "b", "g", "d")


@pytest.mark.parametrize(
    ("errors", "costs", "kwargs", "message"),
    [
        ({"a": 1.0}, {"b": 1.0}, {}, "have an error or a cost but not both"),
        ({}, {}, {}, "at least one family"),
        ({"a": -1.0}, {"a": 1.0}, {}, "must be >= 0"),
        ({"a": 1.0}, {"a": math.inf}, {}, "finite"),
        ({"a": 1.0}, {"a": 1.0}, {"by": "speed"}, "by must be"),
        (
            {"a": 1.0},
            {"a": cost.Cost("a", None, None, {}, 3.0)},
            {"by": "ns_per_eval"},
            "not measured",
        ),
    ],
)
def test_pareto_front_rejects_bad_input(errors, costs, kwargs, message):
    with pytest.raises(attenfit.BadValueError, match=message):
        cost.pareto_front(errors, costs, **kwargs)


def test_plot_cost_vs_error(tmp_path):
    import matplotlib.pyplot as plt

    fig, ax = cost.plot_cost_vs_error(ERRORS, COSTS, title="hand-made")
    assert ax.get_xscale() == "log" and ax.get_yscale() == "log"
    labels = {t.get_text() for t in ax.texts}
    assert labels == {"a", "b, g", "c", "d", "e"}  # f's error is infinite: in the legend
    assert any("f" in t.get_text() for t in ax.get_legend().get_texts())
    fig.savefig(tmp_path / "pareto.png")
    plt.close(fig)
    fig2, ax2 = plt.subplots()
    out = cost.plot_cost_vs_error(ERRORS, COSTS, ax=ax2)
    assert out == (fig2, ax2)
    plt.close(fig2)


def test_numpy_evaluation_of_the_traced_program_matches_jax():
    """The traced program (what is counted and exported) computes the family's values."""
    from attenfit._shaders import trace

    d = np.geomspace(1e-3, 30.0, 301).astype(np.float32)
    for fam in (_Yuksel(), _Window(), _Tan()):
        want = np.asarray(fam(jnp.asarray(d)))
        got = trace(fam).evaluate_numpy(d)
        np.testing.assert_allclose(got, want, rtol=2e-6, atol=0)


def test_cheapest_within_tolerance():
    assert cost.cheapest_within(ERRORS, COSTS, 0.2) == ["b", "g", "c", "d", "e"]
    assert cost.cheapest_within(ERRORS, COSTS, 0.05) == ["d", "e"]
    assert cost.cheapest_within(ERRORS, COSTS, 1e-3) == []
    assert cost.cheapest_within(ERRORS, COSTS, 1.0)[0] == "a"  # f's NaN error never qualifies
    with pytest.raises(attenfit.BadValueError, match="tolerance must be"):
        cost.cheapest_within(ERRORS, COSTS, -1.0)
    with pytest.raises(attenfit.BadValueError, match="no cost"):
        cost.cheapest_within({"zz": 0.0}, COSTS, 1.0)
