"""How attenfit reads a USD attribute: at which time, under which name, and with which
transform (for `_usd`).

Time (`time`): usd-core resolves an attribute at a time code; a value authored only as time
samples (`float inputs:shaping:cone:angle.timeSamples = {1: 25}`, as maya-usd exports an
animated light) has no value at the default time (usd-core then answers the schema's
fallback). With `time=None`, an attribute is read at the default time when it has a default
value (`Usd.Attribute.GetResolveInfo(Usd.TimeCode.Default())` gives `Default`), and at the
stage's start time code (`startTimeCode`, usd-core's `Usd.Stage.GetStartTimeCode`, 0 when
unauthored) when it has only time samples; with a number, every attribute at that time
(usd-core interpolates between samples, and takes the default where there are none).
Transforms follow the same rule, one xformOp at a time (`world_matrix`).

Names: the UsdLux schemas of usd-core before 21.02 named a light's inputs without the
`inputs:` prefix (`float radius`, `float intensity`, `float exposure`; OpenUSD CHANGELOG.md,
21.02: "Input attributes for UsdLuxLight and UsdLuxLightFilter schemas are now connectable
and have been renamed to include the "inputs:" prefix", and 21.05 for ShapingAPI: "All
attributes on these APIs have been given the "inputs:" prefix"). `light_input` reads the
old name when the new one is not authored, and says so (`old_names`).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Iterator
from typing import Any

import numpy as np

from .._errors import BadTypeError, BadValueError, DataFileError
from ._usd_layers import pxr_error

__all__ = [
    "UsdTime",
    "check_time",
    "light_input",
    "prim_errors",
    "show",
    "value_length",
    "world_matrix",
]


def check_time(time: Any) -> float | None:
    """`time` as a finite float, or None; a `BadValueError` naming it otherwise."""
    if time is None:
        return None
    if isinstance(time, bool) or not isinstance(time, int | float):
        raise BadTypeError(f"time: must be a USD time code (a number), got {time!r}")
    if not math.isfinite(time):
        raise BadValueError(f"time: must be a finite USD time code, got {time!r}")
    return float(time)


class UsdTime:
    """The time attenfit reads a stage at: `time` (a number: every attribute at it; None:
    each attribute's default value, or its value at `start` when it has only time samples)."""

    def __init__(self, time: float | None, start: float):
        self.time = time
        self.start = start
        #: whether some attribute was read at the start time code (said in a notice)
        self.used_start = False

    def code(self, attr):
        """The time code to read `attr` at."""
        from pxr import Usd

        if self.time is not None:
            return Usd.TimeCode(self.time)
        info = attr.GetResolveInfo(Usd.TimeCode.Default())
        if info.GetSource() == Usd.ResolveInfoSourceDefault:
            return Usd.TimeCode.Default()
        if attr.GetNumTimeSamples() > 0 or attr.ValueMightBeTimeVarying():
            self.used_start = True
            return Usd.TimeCode(self.start)
        return Usd.TimeCode.Default()  # the schema's fallback

    def get(self, attr) -> Any:
        """The value of `attr` (None for none)."""
        if attr is None or not attr.IsValid():
            return None
        return attr.Get(self.code(attr))

    def describe(self) -> str:
        if self.time is not None:
            return f"time code {self.time:g}"
        return f"the default time (the start time code {self.start:g} for values authored only as time samples)"


#: A light input's name in usd-core before 21.02 (21.05 for ShapingAPI): its name less
#: `inputs:` (`treatAsPoint` never had the prefix).
def _old_name(name: str) -> str:
    return name[len("inputs:") :] if name.startswith("inputs:") else name


def light_input(prim, attr, old_names: list[str]):
    """`attr` (a UsdLux `inputs:` attribute of `prim`), or the attribute of its pre-2021
    name when only that one is authored (its name then appended to `old_names`)."""
    if attr is None or not attr.IsValid():
        return attr
    name = attr.GetName()
    old = _old_name(name)
    if old == name or attr.HasAuthoredValue():
        return attr
    legacy = prim.GetAttribute(old)
    if legacy and legacy.IsValid() and legacy.HasAuthoredValue():
        old_names.append(old)
        return legacy
    return attr


def shaped(prim) -> bool:
    """Whether the light `prim` is shaped: the ShapingAPI applied, or a `shaping:` input
    authored without it (maya-usd writes a spot's cone so). usdImaging reads a light's
    authored inputs whatever schemas are applied (`UsdImagingPrimAdapter::GetLightParamValue`
    falls back to `LookupLightParamAttribute`, pxr/usdImaging/usdImaging/primAdapter.cpp)."""
    from pxr import UsdLux

    if prim.HasAPI(UsdLux.ShapingAPI):
        return True
    return any(
        a.GetName().startswith(("inputs:shaping:", "shaping:")) and a.HasAuthoredValue()
        for a in prim.GetAttributes()
    )


def _local(prim, when: UsdTime):
    """The local transform of `prim` (a Gf.Matrix4d, row vectors), each xformOp read at its
    own time (`UsdTime.code`), composed as usd-core composes them
    (`UsdGeomXformable::GetLocalTransformation`: the ops in order, each applied before the
    ones listed ahead of it), and whether it resets the transform stack."""
    from pxr import Gf, UsdGeom

    xf = UsdGeom.Xformable(prim)
    m = Gf.Matrix4d(1.0)
    if not xf:
        return m, False
    for op in xf.GetOrderedXformOps():
        m = op.GetOpTransform(when.code(op.GetAttr())) * m
    return m, bool(xf.GetResetXformStack())


def world_matrix(prim, when: UsdTime, cache: dict[str, Any]) -> np.ndarray:
    """The local-to-world transform of `prim` (4x4, row vectors) at `when`; `cache` holds
    the world transforms of prims already computed (by path), shared between calls."""
    from pxr import Gf

    chain = []
    p = prim
    while p and p.IsValid() and not p.IsPseudoRoot():
        key = str(p.GetPath())
        if key in cache:
            break
        chain.append((key, p))
        p = p.GetParent()
    world = cache.get(str(p.GetPath()), Gf.Matrix4d(1.0)) if p and p.IsValid() else Gf.Matrix4d(1.0)
    for key, q in reversed(chain):
        local, reset = _local(q, when)
        world = local if reset else local * world
        cache[key] = world
    return np.array(world, dtype=np.float64).reshape(4, 4)


def show(v: Any) -> str:
    """`v` for a message, cut to 40 characters."""
    text = repr(v)
    return text if len(text) <= 40 else text[:37] + "..."


def value_length(attr, when: UsdTime, where: str) -> int:
    """The element count of an array attribute's value (0 when it has none)."""
    v = when.get(attr)
    if v is None:
        return 0
    try:
        return len(v)
    except TypeError:
        raise BadTypeError(f"{where}: {attr.GetName()} must be an array, got {show(v)}") from None


@contextlib.contextmanager
def prim_errors(where: str) -> Iterator[None]:
    """usd-core's errors while a prim is read (an xformOp whose value has the wrong type, an
    attribute of an unknown type...) as one line naming the prim: the file's content."""
    from pxr import Tf

    try:
        yield
    except Tf.ErrorException as exc:
        raise DataFileError(f"{where}: usd-core cannot read it ({pxr_error(exc)})") from None
