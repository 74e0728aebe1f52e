"""Spotlight and disk directional factors against the engines' own forms."""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import attenfit
from attenfit import directional

UMBRA, PENUMBRA = math.radians(40.0), math.radians(30.0)
COS = np.linspace(-1.0, 1.0, 401)


def frostbite_engine(c, cos_inner, cos_outer):
    """Frostbite getAngleAtt with its CPU-side scale/offset (Lagarde & de Rousiers 2014)."""
    scale = 1.0 / max(0.001, cos_inner - cos_outer)
    offset = -cos_outer * scale
    return np.clip(c * scale + offset, 0, 1) ** 2


def glsl_smoothstep(e0, e1, x):
    t = np.clip((x - e0) / (e1 - e0), 0, 1)
    return t * t * (3 - 2 * t)


def test_spot_t_rtr4():
    t = np.asarray(attenfit.spot_t(jnp.asarray(COS), UMBRA, PENUMBRA))
    ref = np.clip((COS - math.cos(UMBRA)) / (math.cos(PENUMBRA) - math.cos(UMBRA)), 0, 1)
    np.testing.assert_allclose(t, ref, rtol=1e-13, atol=1e-15)


def test_spot_frostbite_against_getangleatt():
    got = np.asarray(attenfit.spot_frostbite(jnp.asarray(COS), UMBRA, PENUMBRA))
    ref = frostbite_engine(COS, math.cos(PENUMBRA), math.cos(UMBRA))
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-15)
    # Hard edge (penumbra = umbra): the 0.001 floor of the engine, no division by zero.
    hard = np.asarray(attenfit.spot_frostbite(jnp.asarray(COS), UMBRA, UMBRA))
    ref = frostbite_engine(COS, math.cos(UMBRA), math.cos(UMBRA))
    np.testing.assert_allclose(hard, ref, rtol=1e-12, atol=1e-15)


def test_spot_threejs_against_smoothstep_and_spotlightnode():
    angle, penumbra = math.pi / 3, 0.25  # three.js SpotLight parameters
    cone_cos, penumbra_cos = math.cos(angle), math.cos(angle * (1 - penumbra))
    got = np.asarray(attenfit.spot_threejs(jnp.asarray(COS), angle, angle * (1 - penumbra)))
    np.testing.assert_allclose(
        got, glsl_smoothstep(cone_cos, penumbra_cos, COS), rtol=1e-12, atol=1e-15
    )


def test_lambert_disk():
    got = np.asarray(attenfit.lambert_disk(jnp.asarray(COS)))
    np.testing.assert_array_equal(got, np.maximum(COS, 0))


@pytest.mark.parametrize(
    "fn",
    [directional.spot_t, directional.spot_frostbite, directional.spot_threejs],
    ids=["t", "frostbite", "threejs"],
)
@pytest.mark.parametrize("dtype", [jnp.float32, jnp.float64])
def test_gradients_finite_everywhere_including_t0_t1(fn, dtype):
    cu, cp = math.cos(UMBRA), math.cos(PENUMBRA)
    c = [-1.0, cu, cp, 0.5 * (cu + cp), 1.0, cu - 1e-7, cp + 1e-7]
    # Each cosine with a soft edge and with a hard one (penumbra = umbra), in one call.
    cs = jnp.asarray(c + c, dtype=dtype)
    us = jnp.full((len(cs),), UMBRA, dtype=dtype)
    ps = jnp.asarray([PENUMBRA] * len(c) + [UMBRA] * len(c), dtype=dtype)
    grads = jax.vmap(jax.grad(fn, argnums=(0, 1, 2)))(cs, us, ps)
    for g in grads:
        assert g.dtype == dtype and np.isfinite(np.asarray(g)).all()
    vals = np.asarray(fn(cs, us, ps))
    assert vals.dtype == dtype and (vals >= 0).all() and (vals <= 1).all()


def test_gradient_matches_finite_differences():
    c = 0.5 * (math.cos(UMBRA) + math.cos(PENUMBRA))
    for fn in (attenfit.spot_frostbite, attenfit.spot_threejs):
        g = float(jax.grad(fn)(jnp.float64(c), UMBRA, PENUMBRA))
        h = 1e-6
        fd = (float(fn(c + h, UMBRA, PENUMBRA)) - float(fn(c - h, UMBRA, PENUMBRA))) / (2 * h)
        assert g == pytest.approx(fd, rel=1e-7)


def test_lambert_gradient_at_zero():
    assert float(jax.grad(attenfit.lambert_disk)(jnp.float64(0.0))) == 1.0


def test_broadcasting_and_errors():
    c = jnp.linspace(0.5, 1.0, 6).reshape(2, 3)
    umbra = jnp.asarray([0.6, 0.7, 0.8])
    got = attenfit.spot_frostbite(c, umbra, 0.3 * umbra)
    assert got.shape == (2, 3)
    with pytest.raises(attenfit.BadValueError, match="must not exceed umbra"):
        attenfit.spot_t(0.5, 0.3, 0.4)
    with pytest.raises(attenfit.BadValueError, match=r"umbra must be an angle in \[0, pi\]"):
        attenfit.spot_threejs(0.5, -0.1, 0.0)
    assert np.isnan(float(attenfit.spot_frostbite(jnp.nan, UMBRA, PENUMBRA)))
