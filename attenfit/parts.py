"""The parts attenuation families are built from: base falloffs, range windows, distance warps.

Every named family is a product `base(warp(d)) * window(d)` of these pure, stable,
differentiable functions; compose them into a family of your own (docs/families.md, "Write your
own family"). The implementation and its numerical notes: `attenfit._curves._parts`.
"""

from ._curves._parts import clamped_inverse_square as clamped_inverse_square
from ._curves._parts import cutoff_bias as cutoff_bias
from ._curves._parts import distance as distance
from ._curves._parts import inverse_square as inverse_square
from ._curves._parts import keep_nan as keep_nan
from ._curves._parts import linear_tail_window as linear_tail_window
from ._curves._parts import monotone_cubic as monotone_cubic
from ._curves._parts import polynomial as polynomial
from ._curves._parts import power_clamped_value as power_clamped_value
from ._curves._parts import power_min_distance as power_min_distance
from ._curves._parts import promote as promote
from ._curves._parts import rational_warp as rational_warp
from ._curves._parts import smooth_window as smooth_window
from ._curves._parts import softened_inverse_square as softened_inverse_square
from ._curves._parts import stable_hypot as stable_hypot
from ._curves._parts import surface_distance as surface_distance
from ._curves._parts import surface_gap as surface_gap
from ._curves._parts import surface_sphere as surface_sphere
from ._curves._parts import tan_warp as tan_warp
from ._curves._parts import yuksel as yuksel

__all__ = [
    "clamped_inverse_square",
    "cutoff_bias",
    "distance",
    "inverse_square",
    "keep_nan",
    "linear_tail_window",
    "monotone_cubic",
    "polynomial",
    "power_clamped_value",
    "power_min_distance",
    "promote",
    "rational_warp",
    "smooth_window",
    "softened_inverse_square",
    "stable_hypot",
    "surface_distance",
    "surface_gap",
    "surface_sphere",
    "tan_warp",
    "yuksel",
]
