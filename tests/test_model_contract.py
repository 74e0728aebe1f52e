"""The one model base (`attenfit._curves.Model`): every registered model, family or area
model, has the same methods and class-level facts, and no subclass overrides a concrete
method of the base (the abstract/final pattern: only abstract members are overridden)."""

from __future__ import annotations

import inspect
import json

import numpy as np
import pytest

import attenfit as af
from attenfit import area
from attenfit._curves import CONSTRAINTS, RECT_INPUTS, TUBE_INPUTS, Model, point_light_class

FAMILIES = [af.get_family(n) for n in af.list_families()]
AREA = [area.get_area_model(n) for n in area.list_area_models()]
#: Every registered model, and the point-light class of every family.
MODELS = FAMILIES + AREA + [point_light_class(c) for c in FAMILIES]

#: Hooks equinox runs for every class that defines them (each class's own, in turn): adding
#: one is not overriding the base's.
_ADDITIVE = {"__check_init__"}
#: The abstract bases whose concrete methods no subclass may define again.
BASES = (Model, af.Family, area.AreaModel, area.PointLight)


def _concrete_methods(base: type) -> set[str]:
    """The names of the concrete methods (functions, class and static methods) of `base`."""
    abstract = getattr(base, "__abstractmethods__", frozenset())
    out = set()
    for name, value in vars(base).items():
        if name.startswith("__") and name != "__call__":  # the dataclass's own, and hooks
            continue
        if isinstance(value, classmethod | staticmethod | property) or inspect.isfunction(value):
            if name not in abstract and name not in _ADDITIVE:
                out.add(name)
    return out


def overridden(cls: type, base: type = Model) -> list[str]:
    """`Class.method` for each concrete method of `base` that a class between `cls` and
    `base` (both ends included on the `cls` side) defines again."""
    concrete = _concrete_methods(base)
    bad = []
    for klass in cls.__mro__[: cls.__mro__.index(base)]:
        bad += [f"{klass.__name__}.{n}" for n in sorted(concrete & set(vars(klass)))]
    return bad


def test_the_override_check_catches_an_override():
    class Bad(af.Family):
        name = "bad"
        formula = "1"
        source = "nowhere"
        default_free = ()
        shader_form = af.no_shader_form

        def __call__(self, d):
            return d

        def params(self):  # a concrete method of the base, overridden
            return {}

    assert overridden(Bad) == ["Bad.params"]
    assert "params" in _concrete_methods(Model) and "evaluate" not in _concrete_methods(Model)
    assert "range_distance" in _concrete_methods(af.Family)
    assert "__call__" in _concrete_methods(area.AreaModel)


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
def test_no_model_overrides_a_concrete_method_of_a_base(cls):
    for base in BASES:
        if issubclass(cls, base):
            assert overridden(cls, base) == [], base.__name__


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
def test_class_level_facts(cls):
    assert issubclass(cls, Model) and not inspect.isabstract(cls)
    assert cls.name.isidentifier() and cls.formula and cls.source
    assert cls.kind in ("family", "area model")
    assert cls.inputs == (0 if issubclass(cls, af.Family) else len(cls.input_names))
    if not issubclass(cls, af.Family):  # the sphere's, disk's and point light's, or a frame's
        assert cls.input_names in (area.AREA_INPUTS, RECT_INPUTS, TUBE_INPUTS)
    names = cls.param_names()
    assert tuple(cls.defaults()) == names
    assert set(cls.default_free) <= set(names)
    assert set(cls.length_params) <= set(names)
    assert set(cls.constraints) <= set(names)
    assert {cls.constraint(p) for p in names} <= set(CONSTRAINTS)
    with pytest.raises(af.UnknownNameError, match="has no parameter 'nope'"):
        cls.constraint("nope")
    desc = json.loads(json.dumps(cls.describe()))
    assert desc["name"] == cls.name and list(desc["params"]) == list(names)
    assert desc["default_free"] == list(cls.default_free)


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
def test_instances_agree_with_their_class(cls):
    m = cls()
    assert type(m) is cls
    assert m.param_names() == cls.param_names()
    assert tuple(m.params()) == cls.param_names() and len(m.param_leaves()) == len(m.params())
    assert m.free_by_default() == tuple(cls.default_free)
    for p, v in cls.defaults().items():
        np.testing.assert_array_equal(np.asarray(m.params()[p]), np.asarray(v))
    again = m.replace(**cls.defaults())
    assert type(again) is cls and again.params().keys() == m.params().keys()
    with pytest.raises(af.UnknownNameError, match="has no parameter"):
        m.replace(nope=1.0)


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
def test_evaluate_reads_the_inputs_the_class_declares(cls):
    """`evaluate` at `inputs` rows of samples equals calling the model: a family at `d`, an
    area model at facing receivers of a sphere (`cos_r = cos_e = cos_n = g = 1`)."""
    m = cls()
    d = np.array([0.3, 1.0, 2.5])
    if cls.inputs == 0:
        want = np.asarray(m(d))
        got = np.asarray(m.evaluate(d))
    elif cls.input_names == area.AREA_INPUTS:
        one = np.ones_like(d)
        want = np.asarray(m(d, one, one, 0.1 * one, one, one))
        got = np.asarray(m.evaluate(np.stack([d, one, one, 0.1 * one, one, one])))
    else:  # a rectangle's or a tube's: receivers on its z axis, facing it
        zero, one = np.zeros_like(d), np.ones_like(d)
        rows = [zero, zero, d, zero, zero, -one, 0.2 * one, 0.1 * one]
        want = np.asarray(m(*rows))
        got = np.asarray(m.evaluate(np.stack(rows)))
    assert got.shape == d.shape
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("fam", FAMILIES, ids=lambda c: c.name)
def test_a_point_light_has_its_familys_facts(fam):
    pl = area.PointLight(fam())
    cls = type(pl)
    assert cls is point_light_class(fam) and isinstance(pl, area.PointLight)
    assert cls.param_names() == fam.param_names()
    assert cls.default_free == fam.default_free
    assert cls.length_params == fam.length_params
    assert dict(cls.constraints) == dict(fam.constraints)
    assert cls.describe()["family"] == fam.name
    assert pl.params().keys() == fam().params().keys()


def test_a_point_light_refuses_another_family():
    with pytest.raises(af.BadTypeError, match="takes a Yuksel instance, got Clamped"):
        point_light_class(af.Yuksel)(af.Clamped())


@pytest.mark.parametrize(
    "cls", [c for c in FAMILIES if c.range_setter() is not None], ids=lambda c: c.name
)
def test_a_light_range_sets_the_family_range(cls):
    """The parameter a light's range R sets (`range_setter`, `range_value`) gives a curve
    whose range (`range_distance`) is R, and that is 0 there and beyond."""
    r, R = 0.2, 7.5
    values = {cls.range_setter(): cls.range_value(R, r)}
    if "r" in cls.param_names():
        values["r"] = r
    fam = cls(**values)
    assert float(fam.range_distance()) == pytest.approx(R, rel=1e-12)
    beyond = np.asarray(fam(np.array([R * (1 + 1e-9), 2 * R])))
    assert np.all(beyond == 0)
    assert float(np.asarray(fam(np.float64(0.5 * R)))) > 0


def test_the_shader_form_is_abstract_on_the_base():
    assert "shader_form" in Model.__abstractmethods__
    assert "shader_form" not in _concrete_methods(af.Family)


@pytest.mark.parametrize("cls", MODELS, ids=lambda c: c.__name__)
def test_each_model_writes_its_own_shader_form(cls):
    """Every model's class gives its form (a model without one says so: `no_shader_form`),
    named after the model, reading its inputs and parameters (an area model's also the
    light's `radius`), citing where it comes from."""
    form = cls().shader_form()
    assert (form is not None) == cls.has_shader_form()
    if form is None:
        assert cls._params_home().shader_form is af.no_shader_form
        return
    assert form.family == cls.name and form.source and isinstance(form.engine, bool)
    if cls.inputs == 0:
        assert form.inputs == ("d",) and form.params == cls.param_names()
    else:
        assert form.inputs == cls.form_inputs
        assert set(form.params) - set(cls.form_sizes) == set(cls.param_names())
