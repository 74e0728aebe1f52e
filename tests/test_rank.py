"""One ranking for every verdict (`attenfit/_judge/_rank.py`, `attenfit._shaders.rank_key`).

The tie-break itself, on hand-made contenders whose order is worked out in the comments; and
the same tie put to every place that names "the cheapest model within the tolerance": the
report's decision table, a scene's all-lights recommendation and its per-light answers, the
area models a scene escalates to, the report's ceiling section and `attenfit.cost`. They
must all name the same model.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import pytest

import attenfit
from attenfit._judge import Contender, rank

NAN = float("nan")


def names(cs) -> list[str]:
    return [c.name for c in cs]


# ----------------------------------------------------------------------------- the tie-break
def test_cheapest_first_then_smaller_error_then_name():
    r = rank(
        [
            Contender("d", 0.04, 3.0),  # dearer
            Contender("c", 0.02, 2.0),  # equal cost, equal error: by name after b
            Contender("b", 0.02, 2.0),
            Contender("a", 0.03, 2.0),  # equal cost, larger error
            Contender("e", 0.01, 1.0),  # cheapest
        ],
        0.05,
    )
    assert names(r.within) == ["e", "b", "c", "a", "d"]
    assert r.best is not None and r.best.name == "e" and r.outside == ()


def test_errors_equal_to_three_digits_go_to_fewer_parameters():
    # 0.0300004 and 0.0300012 print alike ("3%"): the simpler model wins though it errs more;
    # where the errors differ in 3 digits the smaller wins whatever the parameters
    tie = [Contender("more", 0.0300004, 2.0, params=1), Contender("fewer", 0.0300012, 2.0)]
    assert names(rank(tie, 0.05).within) == ["fewer", "more"]
    apart = [Contender("more", 0.0299, 2.0, params=1), Contender("fewer", 0.0301, 2.0)]
    assert names(rank(apart, 0.05).within) == ["more", "fewer"]


def test_a_published_model_precedes_its_fitted_variant_at_a_full_tie():
    cs = [Contender("m (fitted)", 0.01, 5.0, 2), Contender("m", 0.01, 5.0, 2)]
    assert names(rank(cs, 0.05).within) == ["m", "m (fitted)"]


def test_nan_and_missing_errors_never_qualify():
    cs = [Contender("nan", NAN, 0.0), Contender("none", None, 0.0), Contender("ok", 0.5, 9.0)]
    r = rank(cs, 1e9)
    assert names(r.within) == ["ok"]
    assert names(r.outside) == ["nan", "none"]  # no finite error: last, by name
    assert r.closest is not None and r.closest.name == "ok"
    assert rank(cs[:2], 1.0).closest is None and rank(cs[:2], 1.0).best is None


def test_unknown_cost_comes_after_every_known_cost():
    cs = [
        Contender("unknown", 0.001, None),
        Contender("nan", 0.001, NAN),
        Contender("x", 0.04, 1e6),
    ]
    assert names(rank(cs, 0.05).within) == ["x", "nan", "unknown"]


def test_a_candidate_ruled_out_is_never_within_but_can_be_closest():
    cs = [Contender("broken", 0.001, 1.0, allowed=False), Contender("ok", 0.04, 3.0)]
    r = rank(cs, 0.05)
    assert names(r.within) == ["ok"] and names(r.outside) == ["broken"]
    assert r.closest is not None and r.closest.name == "broken"


def test_tolerance_is_inclusive():
    assert names(rank([Contender("edge", 0.05, 1.0)], 0.05).within) == ["edge"]


def test_closest_is_chosen_among_every_model_class():
    # the report's disk, contact to r, at 1%: a distance curve 161% off, an area model 2.51%
    curve = Contender("yuksel_adhoc", 1.61, 2.0, 1, item="distance curve")
    area = Contender("vector_disk", 0.0251, 88.0, 0, item="area model")
    r = rank([curve, area], 0.01)
    assert r.best is None
    assert r.closest is area and r.closest.item == "area model"
    assert names(r.outside) == ["vector_disk", "yuksel_adhoc"]  # most accurate first
    # and at 5% the area model is the cheapest within
    assert names(rank([curve, area], 0.05).within) == ["vector_disk"]


def test_closest_ties_on_error_go_to_the_cheaper_then_the_same_rule():
    cs = [
        Contender("dear", 0.2, 9.0),
        Contender("cheap_b", 0.2, 1.0),
        Contender("cheap_a", 0.2, 1.0),
        Contender("far", 0.9, 0.5),
    ]
    r = rank(cs, 0.1)
    assert r.closest is not None and r.closest.name == "cheap_a"
    assert names(r.outside) == ["cheap_a", "cheap_b", "dear", "far"]


def test_items_are_carried_through_in_order():
    a, b = object(), object()
    r = rank([Contender("b", 0.5, 1.0, item=b), Contender("a", 0.01, 1.0, item=a)], 0.1)
    assert r.items() == (a, b)


@pytest.mark.parametrize(
    ("tolerance", "error", "match"),
    [
        (-0.1, attenfit.BadValueError, "tolerance must be a number >= 0, got -0.1"),
        (NAN, attenfit.BadValueError, "tolerance must be a number >= 0, got nan"),
        ("5%", attenfit.BadTypeError, "tolerance must be a number, got '5%'"),
        (True, attenfit.BadTypeError, "tolerance must be a number, got True"),
    ],
)
def test_bad_tolerance_is_a_one_line_error(tolerance, error, match):
    with pytest.raises(error, match=f"^{match}$"):
        rank([Contender("a", 0.1, 1.0)], tolerance)


def test_bad_contenders_are_one_line_errors():
    with pytest.raises(attenfit.BadTypeError, match="rank takes Contender records, got tuple"):
        rank([("a", 0.1, 1.0)], 0.1)  # type: ignore[list-item]
    with pytest.raises(attenfit.BadValueError, match="contender 'a': params must be"):
        Contender("a", 0.1, 1.0, params=-1)


def test_cheapest_within_of_attenfit_cost_is_the_same_rule():
    errors = {"b": 0.02, "c": 0.02, "a": 0.03, "e": 0.01, "d": 0.04, "n": NAN}
    costs = {"b": 2.0, "c": 2.0, "a": 2.0, "e": 1.0, "d": 3.0, "n": 0.0}
    expected = ["e", "b", "c", "a", "d"]  # as in the first test, worked out by hand
    assert attenfit.cost.cheapest_within(errors, costs, 0.05) == expected
    r = rank((Contender(k, errors[k], costs[k]) for k in errors), 0.05)
    assert names(r.within) == expected


# ----------------------------------------------------------------------------- every verdict
#: One tie, put to every decider: `yuksel_adhoc` (1 parameter) and `inverse_square` (none)
#: cost 2 and err 3.00004% and 3.00012%, the same to 3 digits, so the simpler
#: `inverse_square` wins within 5% (a rule of cost, then exact error, the report's and the
#: per-light answers' before `rank`, named `yuksel_adhoc`). `disk_facing` errs least (2%)
#: but costs 3: at 1% nothing is within and it is the closest.
TIE = {
    "yuksel_adhoc": (0.0300004, {"r": 0.1}),
    "inverse_square": (0.0300012, {}),
    "disk_facing": (0.0200000, {"r": 0.1}),
}
COST = {"yuksel_adhoc": 2.0, "inverse_square": 2.0, "disk_facing": 3.0}
WINNER, CLOSEST = "inverse_square", "disk_facing"


@dataclasses.dataclass
class _Config:
    name: str = "disk"
    kind: str = "disk"
    radius: float = 0.1
    receivers: Any = True


@dataclasses.dataclass
class _Report:
    configs: tuple
    results: list
    costs: dict


def _report() -> _Report:
    rows = [
        {
            "config": "disk",
            "family": fam,
            "mode": "published",
            "status": "ok",
            "params": params,
            "receivers": {"facing": {"bands": {"near": {"n": 5, "max_abs": e, "worst_at": 2.0}}}},
        }
        for fam, (e, params) in TIE.items()
    ]
    costs = {fam: {"shader_cost": c} for fam, c in COST.items()}
    return _Report((_Config(),), rows, costs)


def _scene_candidates() -> list:
    from attenfit._scenes._advice import Candidate

    out = []
    for fam, (e, params) in reversed(TIE.items()):  # not in the winning order
        out.append(
            Candidate(
                family=fam, status="pass" if e <= 0.05 else "fail", reason="within tolerance",
                error=e, error_by_light=(e,), shader_cost=COST[fam], params=(params,),
                models=(attenfit.get_family(fam)(),),
            )
        )  # fmt: skip
    return out


def test_the_report_decides_the_tie_by_the_one_rule():
    from attenfit._report import _decide

    entries = {e["tolerance"]: e for e in _decide.decide(_report(), sources=(), verify=False)}
    assert entries[0.05]["model"] == WINNER and entries[0.2]["model"] == WINNER
    assert entries[0.01]["model"] is None and entries[0.01]["best"] == CLOSEST


def test_the_reports_closest_may_be_an_area_model():
    from attenfit._report import _decide

    area = _decide.Candidate(
        model="area_stub", mode="published", params="none", cost=88.0,
        errors={"near": 0.015}, worst={"near": ("floor", 1.5)}, kind="area model",
    )  # fmt: skip
    entries = _decide.decide(_report(), sources=[lambda cfg, rep: [area]], verify=False)
    at1 = next(e for e in entries if e["tolerance"] == 0.01)
    assert at1["model"] is None and at1["best"] == "area_stub"
    assert at1["model_kind"] == "area model" and at1["error"] == 0.015
    assert "the closest distance curve, `disk_facing` published, is 2% off" in at1["why"]
    md = _decide.decision_markdown(entries)
    assert "none; closest: `area_stub` published (area model)" in md


def test_a_scene_decides_the_tie_by_the_one_rule():
    from attenfit._scenes._choices import pick_for_light
    from attenfit._scenes._recommend import order

    cands = _scene_candidates()
    ordered, winner, runner_up, closest = order(cands, 0.05)
    assert winner is not None and winner.family == WINNER
    assert runner_up is not None and runner_up.family == "yuksel_adhoc"
    assert [c.family for c in ordered] == ["inverse_square", "yuksel_adhoc", "disk_facing"]
    assert closest is not None and closest.family == CLOSEST
    # the per-light answer for its only light: the same family
    pick, status = pick_for_light(cands, 0, 0.05)
    assert pick is not None and (pick.family, status) == (WINNER, "pass")
    pick, status = pick_for_light(cands, 0, 0.01)
    assert pick is not None and (pick.family, status) == (CLOSEST, "fail")


def test_a_scene_light_failed_for_another_reason_is_not_picked_there():
    from attenfit._scenes._choices import pick_for_light

    cands = _scene_candidates()
    broken = dataclasses.replace(
        next(c for c in cands if c.family == WINNER), status="fail", reason="fails in float16"
    )
    others = [c for c in cands if c.family != WINNER]
    pick, status = pick_for_light([broken, *others], 0, 0.05)
    assert pick is not None and (pick.family, status) == ("yuksel_adhoc", "pass")


def test_the_area_models_and_the_ceiling_decide_the_tie_by_the_one_rule():
    from attenfit._report._ceiling_eval import cheapest_within
    from attenfit._scenes._escalate import AreaCandidate

    # an area model shipped and fitted, equal cost, errors equal to 3 digits: the one with
    # fewer parameters; at a full tie the shipped one (its name is a prefix of the fitted's)
    a = AreaCandidate("wrap", False, {"k": 1.0}, 0.0300012, (0.0300012,), 21.0, "pass")
    b = AreaCandidate("wrap", True, {"k": 0.9}, 0.0300004, (0.0300004,), 21.0, "pass")
    c = AreaCandidate("exact", False, {}, 0.0300019, (0.0300019,), 21.0, "pass")
    r = rank([x.contender() for x in (a, b, c)], 0.05)
    assert [x.item.label for x in r.within] == ["exact", "wrap (fitted)", "wrap"]

    def model(x, fitted=False):
        return {"name": x.model, "fitted": fitted, "params": x.params, "max_rel": x.error,
                "cost": x.cost}  # fmt: skip

    row = {"models": [model(a), model(b, True), model(c)]}
    assert cheapest_within(row, 0.05)["name"] == "exact"
    row = {"models": [model(b, True), model(dataclasses.replace(a, error=b.error))]}
    assert cheapest_within(row, 0.05)["fitted"] is False
    assert cheapest_within(row, 0.01) is None


def test_every_decider_names_the_same_model():
    from attenfit._report import _decide
    from attenfit._scenes._choices import pick_for_light
    from attenfit._scenes._recommend import order

    report = {
        e["tolerance"]: e["model"] or e["best"] for e in _decide.decide(_report(), (), verify=False)
    }
    cands = _scene_candidates()
    for tol in (0.01, 0.05, 0.2):
        _, winner, _, closest = order(cands, tol)
        scene = (winner or closest).family
        per_light = pick_for_light(cands, 0, tol)[0].family
        errors = {f: e for f, (e, _) in TIE.items()}
        counts = {f: len(p) for f, (_, p) in TIE.items()}
        cost = attenfit.cost.cheapest_within(errors, COST, tol, params=counts)
        assert report[tol] == scene == per_light, tol
        assert (cost[0] if cost else CLOSEST) == report[tol]
    assert math.isclose(TIE[WINNER][0], TIE["yuksel_adhoc"][0], rel_tol=1e-4)  # a tie indeed
    # without parameter counts `attenfit.cost` ranks by cost, then error: the other one
    assert attenfit.cost.cheapest_within(errors, COST, 0.05)[0] == "yuksel_adhoc"
