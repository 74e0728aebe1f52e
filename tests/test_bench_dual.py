"""The fitting benchmark's numpy Jacobians (`benchmarks/dual.py`) against JAX's own.

scipy's side of `python -m benchmarks fit` differentiates each family's float64 scalar
program (`attenfit._shaders.trace(family, float64=True)`) in forward mode with numpy; here
its values must equal the family evaluated by JAX in float64, and its Jacobians `jax.jacfwd`'s,
for every parameterised family, at random parameters and distances on both sides of every
clamp and range.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np
import pytest

import attenfit as af
from attenfit._shaders import trace

ROOT = Path(__file__).resolve().parents[1]


def _dual_module():
    spec = importlib.util.spec_from_file_location("bench_dual", ROOT / "benchmarks" / "dual.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["bench_dual"] = module
    spec.loader.exec_module(module)
    return module


dual = _dual_module()

FITTED = [n for n in af.list_families() if af.get_family(n).default_free]
#: distances from inside every clamp (1e-4 m, 0.01 m) to beyond every default range (10 m)
D = np.concatenate([[0.0, 1e-5, 1e-4], np.geomspace(2e-4, 30.0, 200)])


def _split(cls, values, free, p):
    out, i = dict(values), 0
    for name in free:
        size = np.size(values[name])
        out[name] = p[i : i + size].reshape(np.shape(values[name]))
        i += size
    return out


@pytest.mark.parametrize("name", FITTED)
@pytest.mark.parametrize("seed", [0, 1])
def test_values_and_jacobians_equal_jax(name, seed):
    cls = af.get_family(name)
    free = cls.default_free
    rng = np.random.default_rng(seed)
    values = {k: np.asarray(v, np.float64) for k, v in cls.defaults().items()}
    p = np.concatenate(
        [np.ravel(values[k]) * np.exp(rng.uniform(-1, 1, np.size(values[k]))) for k in free]
    )
    bound = dual.DualProgram(cls(), free).bind(D, values)
    f, jac = bound.value_and_jacobian(p)

    def model(pv):
        return cls(**_split(cls, values, free, pv))(jnp.asarray(D))

    want_f = np.asarray(model(jnp.asarray(p)))
    want_jac = np.asarray(jax.jacfwd(model)(jnp.asarray(p))).T
    # Both evaluate the same formula in another order: float64 reassociation errs by a few
    # ulps of the operands, which for a curve cut off to near 0 (madams_cutoff) are the
    # curve's larger values, not the small result: judge against the curve's scale.
    atol = 1e-13 * np.max(np.abs(want_f[np.isfinite(want_f)]))  # gltf_range is inf at 0
    np.testing.assert_allclose(bound.value(p), want_f, rtol=1e-12, atol=atol)
    np.testing.assert_allclose(f, want_f, rtol=1e-12, atol=atol)
    scale = np.max(np.abs(want_jac), axis=1, keepdims=True)
    np.testing.assert_allclose(jac / scale, want_jac / scale, rtol=0, atol=1e-13)


def test_float64_trace_keeps_constants_exact():
    # madams_tan's warp has pi/2 and 2/pi; godot's clamp is 1e-4 m: in float64 exactly
    consts = {
        a.value
        for name in ("madams_tan", "godot")
        for op in trace(af.get_family(name)(), float64=True).ops
        for a in op.args
        if not hasattr(a, "id")
    }
    assert np.pi / 2 in consts and 1e-4 in consts
    consts32 = {a.value for op in trace(af.Godot()).ops for a in op.args if not hasattr(a, "id")}
    assert 1e-4 not in consts32 and float(np.float32(1e-4)) in consts32
