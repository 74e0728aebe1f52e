"""Lambertian area emitters (sphere, one- or two-sided disk, capsule, one-sided rectangle, tube)
and the point light each stands in for. Implemented in `attenfit._truth._emitters`, `_rect` and
`_tube`;
docs/ground-truth.md.
"""

from ._truth import AbstractEmitter as AbstractEmitter
from ._truth import CapsuleEmitter as CapsuleEmitter
from ._truth import DiskEmitter as DiskEmitter
from ._truth import RectEmitter as RectEmitter
from ._truth import SphereEmitter as SphereEmitter
from ._truth import TubeEmitter as TubeEmitter
from ._truth import emitter_from_dict as emitter_from_dict

__all__ = [
    "AbstractEmitter",
    "CapsuleEmitter",
    "DiskEmitter",
    "RectEmitter",
    "SphereEmitter",
    "TubeEmitter",
    "emitter_from_dict",
]
