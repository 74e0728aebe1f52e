"""Validation of emitter fields and receiver arrays, and the vector helpers the truth stage
shares (`_emitters`, `_rect`, `_tube`, `_irradiance`, `_geometry`): eager checks of concrete
values (traced values are let through), stable normalisation, and guarded norms.

The helpers compute in numpy on concrete values and in `jax.numpy` on traced ones
(`array_module`): an emitter's fields and the point-light geometry at a scene's receivers
are host arithmetic, and each `jax.numpy` call outside a compiled program is a program of
its own, which a fresh process traces, lowers and loads from JAX's cache one by one (about
a hundred of them were most of a warm `attenfit scene` of a tube light: docs/performance.md).
"""

from __future__ import annotations

import math
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array, ArrayLike

from .._errors import BadTypeError, BadValueError


# ----------------------------------------------------------------------------- validation
def _is_traced(x: Any) -> bool:
    return isinstance(x, jax.core.Tracer)


def array_module(*xs: Any) -> Any:
    """`jax.numpy` when any of `xs` is traced (inside `jit`, `grad`, `vmap`), else numpy."""
    return jnp if any(_is_traced(x) for x in xs) else np


def _float_dtype(x: Any) -> Any:
    """The float dtype to store `x` in: its own if floating, else JAX's default float; as JAX
    would hold it (float64 is float32 while JAX's x64 mode is off)."""
    dt = getattr(x, "dtype", None)
    if dt is not None and jnp.issubdtype(dt, jnp.floating):
        return jax.dtypes.canonicalize_dtype(dt)
    return jax.dtypes.canonicalize_dtype(jnp.float64)


def _check_real(name: str, x: Any, shape: tuple[int, ...]) -> Any:
    """Check a concrete real value of `shape`; return it as a numpy array of its float dtype
    (a traced value as it is)."""
    if _is_traced(x):
        return x
    if isinstance(x, str | bytes) or x is None:
        raise BadTypeError(f"{name} must be a real number or array, got {type(x).__name__}")
    try:
        arr = np.asarray(x)
    except Exception as exc:  # ragged lists and the like
        raise BadTypeError(f"{name} must be a real number or array, got {x!r}") from exc
    if arr.dtype == bool or not (
        np.issubdtype(arr.dtype, np.floating) or np.issubdtype(arr.dtype, np.integer)
    ):
        raise BadTypeError(f"{name} must be real (float or int), got dtype {arr.dtype}")
    if arr.shape != shape:
        want = "a scalar" if shape == () else f"shape {shape}"
        raise BadValueError(f"{name} must be {want}, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise BadValueError(f"{name} must be finite, got {arr.tolist()}")
    dt = _float_dtype(x)
    with np.errstate(over="ignore"):  # an overflow is reported just below
        cast = arr.astype(dt)  # numpy, so this check also runs while jit is tracing
    if not np.all(np.isfinite(cast)):
        raise BadValueError(f"{name} = {arr.tolist()} overflows {np.dtype(dt)}")
    return cast


def _check_positive(name: str, x: Any) -> Any:
    out = _check_real(name, x, ())
    if not _is_traced(x) and not float(np.asarray(x)) > 0:
        raise BadValueError(f"{name} must be > 0, got {float(np.asarray(x))!r}")
    return out


def _check_radius(name: str, x: Any) -> Any:
    """A positive radius whose square is a normal number of its dtype (else r^2, L overflow)."""
    out = _check_positive(name, x)
    if not _is_traced(x):
        dt = np.dtype(_float_dtype(x))
        fi = np.finfo(dt)
        lo, hi = math.sqrt(float(fi.tiny)), math.sqrt(float(fi.max))
        if not lo < float(np.asarray(x)) < hi:
            raise BadValueError(
                f"{name} must lie within ({lo:.3g}, {hi:.3g}) in {dt} (its square must be "
                f"a normal number), got {float(np.asarray(x)):g}"
            )
    return out


def _normalise(v: Array) -> Array:
    """`v / |v|` along the last axis, scaled to the order of 1 first: the squares of a normal
    like [0, 0, 1e-200] underflow (and of [1e300, 0, 0] overflow) before the square root."""
    xp = array_module(v)
    m = xp.max(xp.abs(v), axis=-1, keepdims=True)
    v = v / xp.where(m > 0, m, 1)
    with np.errstate(invalid="ignore"):  # numpy as JAX: a zero vector is NaN, silently
        return v / xp.linalg.norm(v, axis=-1, keepdims=True)


def _unit(name: str, x: Any) -> Any:
    out = _check_real(name, x, (3,))
    if not _is_traced(x):
        if not float(np.max(np.abs(np.asarray(x, dtype=np.float64)))) > 0:
            raise BadValueError(f"{name} must be a non-zero 3-vector, got {np.asarray(x).tolist()}")
    return _normalise(out)


def _dot(a: Array, b: Array) -> Array:
    return array_module(a, b).sum(a * b, axis=-1)


def _safe_norm(v: Array) -> Array:
    """|v| over the last axis, with gradient 0 (not NaN) at v = 0."""
    xp = array_module(v)
    n2 = _dot(v, v)
    pos = n2 > 0
    return xp.where(pos, xp.sqrt(xp.where(pos, n2, 1)), 0)


def _real_input(name: str, x: Any) -> Any:
    """Refuse (eagerly) a concrete receiver array that is not real: complex, object, text, bool."""
    if _is_traced(x):
        return x
    dt = getattr(x, "dtype", None)
    if dt is None or np.dtype(dt).kind == "O":
        try:
            x = np.asarray(x)
        except Exception as exc:  # ragged lists and the like
            raise BadTypeError(f"{name} must be a real array [..., 3], got {x!r}") from exc
        dt = x.dtype
    if np.dtype(dt).kind == "b" or not (
        jnp.issubdtype(dt, jnp.floating) or jnp.issubdtype(dt, jnp.integer)
    ):
        raise BadTypeError(f"{name} must be real (float or int), got dtype {dt}")
    return x


def _receivers(points: ArrayLike, normals: ArrayLike) -> tuple[Array, Array]:
    """Points and unit normals as float arrays of one dtype, broadcast to one shape [..., 3]."""
    xp = array_module(points, normals)
    p = xp.asarray(_real_input("points", points))
    n = xp.asarray(_real_input("normals", normals))
    dt = _float_dtype(p) if jnp.issubdtype(p.dtype, jnp.floating) else _float_dtype(n)
    p = p.astype(dt)
    n = n.astype(dt)
    if p.shape[-1:] != (3,) or n.shape[-1:] != (3,):
        raise BadValueError(
            f"points and normals must have a last axis of 3, got shapes {p.shape} and {n.shape}"
        )
    try:
        shape = jnp.broadcast_shapes(p.shape, n.shape)
    except ValueError:
        raise BadValueError(
            f"points {p.shape} and normals {n.shape} must have the same (or broadcastable) shapes"
        ) from None
    p = xp.broadcast_to(p, shape)
    n = xp.broadcast_to(n, shape)
    return p, _normalise(n)


def _bcast(x: Array, like: Array) -> Array:
    """An emitter vector field (3,) cast to `like`'s dtype and rank (explicit, for strict rank promotion)."""
    xp = array_module(x, like)
    x = xp.asarray(x).astype(like.dtype)
    return xp.broadcast_to(x, like.shape[:-1] + x.shape[-1:])
