"""The geometry an area-light model reads, from an emitter and its receivers; and its prediction.

`area_inputs(emitter, points, normals)` gives the `AreaInputs` of `attenfit._curves._area`
(distance, cosine at the receiver, cosine at the emitter, radius, the receiver's normal
against the disk's axis, and the point-light model's emitter factor); `area_irradiance`
turns a model's `E / I` into irradiance at those receivers.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from jaxtyping import Array, ArrayLike, Float

from .._curves import AREA_INPUTS, AreaInputs, AreaModel
from .._errors import BadTypeError, BadValueError
from ._emitter_checks import _bcast, _dot, _receivers, _safe_norm, array_module
from ._emitters import AbstractEmitter, _kinds

__all__ = ["area_inputs", "area_irradiance", "frame_inputs", "model_inputs"]


def area_inputs(
    emitter: AbstractEmitter,
    points: Float[ArrayLike, "*b 3"],
    normals: Float[ArrayLike, "*b 3"],
) -> AreaInputs:
    """The `AreaInputs` of receivers `points` with `normals` (normalised here) lit by `emitter`.

    Sphere: `d` from the centre, `cos_e = 1`, `cos_n = cos_r` (the disk that faces the
    receiver), `g = 1`. Disk: `cos_e = m.(p - c)/d` (negative behind a one-sided disk),
    `cos_n = -n.m`, `g = max(0, cos_e)`; a two-sided disk is read from the face the receiver
    sees (`cos_e = |.|`, `m` flipped with it). Capsule: `d` and `l` to the closest point of
    its segment, `cos_e = 1`, `cos_n = cos_r`, `g` its projected-area factor
    (`CapsuleEmitter.point_light`); a tube as a capsule, with its own `g` (no end
    hemispheres: `TubeEmitter.point_light`). A rectangle is read as a one-sided disk of its equal-area
    radius. A receiver at a disk's centre gets `d = 0` and cosines 0.
    """
    if not isinstance(emitter, AbstractEmitter):
        raise BadTypeError(f"emitter must be an attenfit emitter, got {type(emitter).__name__}")
    p, n = _receivers(points, normals)
    xp = array_module(p, *jax.tree_util.tree_leaves(emitter))
    dv = emitter.closest_point(p) - p
    d = _safe_norm(dv)
    dsafe = xp.where(d > 0, d, 1)
    cos_r = _dot(n, dv) / dsafe
    r = xp.broadcast_to(xp.asarray(emitter.radius).astype(p.dtype), d.shape)
    cos_e, cos_n, g = emitter.area_factors(p, n, dv, dsafe, cos_r, r)
    return AreaInputs(d, cos_r, cos_e, r, cos_n, g)


def frame_inputs(
    emitter: AbstractEmitter,
    points: Float[ArrayLike, "*b 3"],
    normals: Float[ArrayLike, "*b 3"],
) -> tuple[Array, ...]:
    """The receivers in the light's frame (`RECT_INPUTS` or `TUBE_INPUTS` of
    `attenfit._curves._area`): point x, y, z and unit normal nx, ny, nz, then the light's
    size (a rectangle's half width and half height; a tube's half length and radius).

    A rectangle's frame: its centre the origin, x its tangent (width), z its normal (the lit
    side z > 0), y = z cross x. A tube's: its centre the origin, x along `a -> b`, y and z any
    right-handed pair across it (its models are symmetric about the axis).
    """
    p, n = _receivers(points, normals)
    if not isinstance(emitter, AbstractEmitter):
        raise BadTypeError(
            f"frame inputs are for a RectEmitter or a TubeEmitter, got {type(emitter).__name__}"
        )
    c, ex, ez, sizes = emitter.light_frame(p.dtype)  # BadTypeError: a shape without a frame
    xp = array_module(p, c, ex, ez, *sizes)
    rot = xp.stack([ex, xp.cross(ez, ex), ez])  # rows: the frame's axes
    q = (p - _bcast(c, p)) @ rot.T
    m = n @ rot.T
    shape = q.shape[:-1]
    size = tuple(xp.broadcast_to(v, shape) for v in sizes)
    return (*(q[..., k] for k in range(3)), *(m[..., k] for k in range(3)), *size)


def model_inputs(
    model: AreaModel | type[AreaModel],
    emitter: AbstractEmitter,
    points: Float[ArrayLike, "*b 3"],
    normals: Float[ArrayLike, "*b 3"],
) -> tuple[Array, ...]:
    """The inputs `model` reads (its class's `input_names`) at the receivers: `area_inputs`
    for `AREA_INPUTS`, `frame_inputs` for a rectangle's or a tube's models (whose light
    must be that shape)."""
    cls = model if isinstance(model, type) else type(model)
    names = cls.input_names
    if names == AREA_INPUTS:
        return area_inputs(emitter, points, normals)
    want = [k for k, _, _ in _kinds().values() if k.frame_input_names == names]
    if not want:
        raise BadValueError(f"area model {cls.name!r} reads inputs {names} no light provides")
    if type(emitter).frame_input_names != names:
        raise BadTypeError(
            f"area model {cls.name!r} is written for a {want[0].__name__}, got "
            f"{type(emitter).__name__}"
        )
    return frame_inputs(emitter, points, normals)


def area_irradiance(
    model: AreaModel,
    emitter: AbstractEmitter,
    points: Float[ArrayLike, "*b 3"],
    normals: Float[ArrayLike, "*b 3"],
) -> Float[Array, "*b"]:
    """The irradiance `model` predicts at the receivers: `I * model(model_inputs(...))`."""
    if not isinstance(model, AreaModel):
        raise BadTypeError(f"model must be an attenfit area model, got {type(model).__name__}")
    x = model_inputs(model, emitter, points, normals)
    return jnp.asarray(emitter.intensity).astype(x[0].dtype) * model(*x)
