"""Emitters: validated constructors, radiance, the stand-in point light, dict round trips."""

import json
import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import attenfit as af

GOOD = {
    af.SphereEmitter: dict(center=[0.0, 0.0, 1.0], radius=0.5),
    af.DiskEmitter: dict(center=[0.0, 0.0, 1.0], normal=[0.0, 0.0, -2.0], radius=0.5),
    af.CapsuleEmitter: dict(a=[0.0, 0.0, 0.0], b=[1.0, 0.0, 0.0], radius=0.25),
}

BAD = [
    (
        af.SphereEmitter,
        "center",
        [0.0, float("nan"), 0.0],
        af.BadValueError,
        "center must be finite",
    ),
    (af.SphereEmitter, "center", [0.0, 1.0], af.BadValueError, r"center must be shape \(3,\)"),
    (af.SphereEmitter, "center", "origin", af.BadTypeError, "center must be a real number"),
    (af.SphereEmitter, "radius", 0.0, af.BadValueError, "radius must be > 0"),
    (af.SphereEmitter, "radius", -1.0, af.BadValueError, "radius must be > 0"),
    (af.SphereEmitter, "radius", float("inf"), af.BadValueError, "radius must be finite"),
    (af.SphereEmitter, "radius", [1.0, 2.0], af.BadValueError, "radius must be a scalar"),
    (af.SphereEmitter, "radius", 1 + 2j, af.BadTypeError, "radius must be real"),
    (af.SphereEmitter, "intensity", 0.0, af.BadValueError, "intensity must be > 0"),
    (
        af.DiskEmitter,
        "normal",
        [0.0, 0.0, 0.0],
        af.BadValueError,
        "normal must be a non-zero 3-vector",
    ),
    (af.DiskEmitter, "two_sided", "yes", af.BadTypeError, "two_sided must be True or False"),
    (af.CapsuleEmitter, "b", [1.0, float("inf"), 0.0], af.BadValueError, "b must be finite"),
    (af.CapsuleEmitter, "radius", True, af.BadTypeError, "radius must be real"),
]


@pytest.mark.parametrize("cls, arg, value, exc, msg", BAD)
def test_constructors_reject_bad_values_naming_the_argument(cls, arg, value, exc, msg):
    kwargs = dict(GOOD[cls])
    kwargs[arg] = value
    with pytest.raises(exc, match=msg):
        cls(**kwargs)
    assert issubclass(exc, ValueError | TypeError)


@pytest.mark.parametrize("cls", list(GOOD))
def test_radiance_is_yuksel_normalisation(cls):
    em = cls(**GOOD[cls], intensity=3.0)
    r = GOOD[cls]["radius"]
    assert float(em.radiance) == pytest.approx(3.0 / (math.pi * r * r), rel=1e-15)


def test_disk_normal_is_normalised_and_ints_become_floats():
    d = af.DiskEmitter([0, 0, 1], [0, 0, -2], 1)
    np.testing.assert_array_equal(np.asarray(d.normal), [0.0, 0.0, -1.0])
    assert jnp.issubdtype(d.radius.dtype, jnp.floating)


def test_emitters_construct_under_jit_and_vmap():
    @jax.jit
    def area_intensity(r):
        return af.SphereEmitter(jnp.zeros(3), r).radiance * math.pi * r * r

    np.testing.assert_allclose(float(area_intensity(2.0)), 1.0, rtol=1e-15)
    radii = jnp.asarray([0.5, 1.0, 2.0])
    L = jax.vmap(lambda r: af.DiskEmitter(jnp.zeros(3), jnp.asarray([0.0, 0.0, 1.0]), r).radiance)(
        radii
    )
    np.testing.assert_allclose(np.asarray(L), 1 / (math.pi * np.asarray(radii) ** 2), rtol=1e-15)


def test_point_light_sphere_and_disk():
    p = np.array([[0.0, 0.0, -2.0], [3.0, 0.0, 1.0], [0.0, 0.0, 4.0]])
    n = np.array([[0.0, 0.0, 1.0], [-1.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    s = af.SphereEmitter([0.0, 0.0, 1.0], 0.5, 2.0)
    d, w = s.point_light(p, n)
    np.testing.assert_allclose(np.asarray(d), [3.0, 3.0, 3.0])
    np.testing.assert_allclose(np.asarray(w), [2.0, 2.0 / math.sqrt(2), 0.0], rtol=1e-15)
    disk = af.DiskEmitter([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 0.5, 2.0)
    d, w = disk.point_light(p, n)
    # g = max(0, m.(p - c)/d): 1 straight below, 0 in the plane, 0 behind
    np.testing.assert_allclose(np.asarray(w), [2.0, 0.0, 0.0], atol=1e-15)
    two = af.DiskEmitter([0.0, 0.0, 1.0], [0.0, 0.0, -1.0], 0.5, 2.0, two_sided=True)
    d, w = two.point_light(p, -n)
    np.testing.assert_allclose(np.asarray(w), [0.0, 0.0, 2.0], atol=1e-15)


def _projected_area(a, b, r, l, grid=500):
    """Area of the capsule's shadow along direction l, by counting grid cells (independent)."""
    a, b, l = (np.asarray(x, dtype=np.float64) for x in (a, b, l))
    l = l / np.linalg.norm(l)
    u = np.cross(l, [1.0, 0, 0] if abs(l[0]) < 0.9 else [0, 1.0, 0])
    u /= np.linalg.norm(u)
    v = np.cross(l, u)
    half = np.linalg.norm(b - a) / 2 + r + 0.01
    xs = (np.arange(grid) + 0.5) / grid * 2 * half - half
    X, Y = np.meshgrid(xs, xs)
    mid = (a + b) / 2
    q = mid + X[..., None] * u + Y[..., None] * v  # points on a plane through the middle
    # a line along l through q hits the capsule iff its distance to the segment <= r
    ab = b - a
    ab_p = ab - (ab @ l) * l  # project everything onto the plane perpendicular to l
    qa = q - a
    qa_p = qa - (qa @ l)[..., None] * l
    den = ab_p @ ab_p
    t = np.clip((qa_p @ ab_p) / den, 0, 1) if den > 0 else np.zeros(X.shape)
    dist = np.linalg.norm(qa_p - t[..., None] * ab_p, axis=-1)
    return np.mean(dist <= r) * (2 * half) ** 2


def test_capsule_point_light_uses_closest_point_and_projected_area():
    a, b, r = [0.0, 0.0, 0.0], [2.0, 0.0, 0.0], 0.3
    cap = af.CapsuleEmitter(a, b, r, 1.5)
    p = np.array([[1.0, 3.0, 0.0], [-4.0, 0.0, 0.0], [3.0, 0.0, 1.0]])
    n = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
    d, w = cap.point_light(p, n)
    np.testing.assert_allclose(np.asarray(d), [3.0, 4.0, math.sqrt(2.0)], rtol=1e-15)
    np.testing.assert_allclose(
        np.asarray(cap.closest_point(p)), [[1.0, 0, 0], [0, 0, 0], [2.0, 0, 0]]
    )
    for k in range(3):
        l = np.asarray(cap.closest_point(p))[k] - p[k]
        cos = max(0.0, float(n[k] @ l) / np.linalg.norm(l))
        g_area = _projected_area(a, b, r, l) / (math.pi * r * r)
        assert float(w[k]) == pytest.approx(1.5 * g_area * cos, rel=5e-3)


@pytest.mark.parametrize("cls", list(GOOD))
def test_dict_round_trip_through_json(cls):
    em = cls(**GOOD[cls], intensity=2.5)
    data = json.loads(json.dumps(em.to_dict()))
    back = af.emitter_from_dict(data)
    assert type(back) is cls
    assert back.to_dict() == em.to_dict()


def test_emitter_from_dict_errors():
    with pytest.raises(af.UnknownNameError, match="unknown emitter kind 'cube'"):
        af.emitter_from_dict({"kind": "cube"})
    with pytest.raises(af.BadValueError, match=r"lacks \['radius'\]"):
        af.emitter_from_dict({"kind": "sphere", "center": [0, 0, 0]})
    with pytest.raises(af.BadValueError, match=r"unknown keys \['colour'\]"):
        af.emitter_from_dict({"kind": "sphere", "center": [0, 0, 0], "radius": 1, "colour": 1})
    with pytest.raises(af.BadValueError, match="radius must be > 0"):
        af.emitter_from_dict({"kind": "sphere", "center": [0, 0, 0], "radius": -1})


def test_the_kinds_are_the_final_shapes_not_their_abstract_bases():
    """`emitter_from_dict` knows every final shape; the shapes' abstract bases (centred, flat,
    around a segment) are no kind, and each shape states the facts the builders read."""
    from attenfit._truth._emitters import _kinds

    kinds = _kinds()
    assert set(kinds) == {"sphere", "disk", "capsule", "rect", "tube"}
    for cls, _, _ in kinds.values():
        assert not getattr(cls, "__abstractmethods__", None), cls.__name__
