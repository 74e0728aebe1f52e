"""Directional factors `g` of the point-light model `E = I g f(d) max(0, n.l)`: spotlight
falloffs (Frostbite's t^2, three.js's smoothstep) and a one-sided disk's cosine, as functions
and as families of `cos(theta_s)`. Implemented in `attenfit._curves._directional`.
"""

from ._curves import MIN_COS_WIDTH as MIN_COS_WIDTH
from ._curves import SPOT_FALLOFFS as SPOT_FALLOFFS
from ._curves import SpotFalloff as SpotFalloff
from ._curves import SpotFrostbite as SpotFrostbite
from ._curves import SpotThreeJS as SpotThreeJS
from ._curves import lambert_disk as lambert_disk
from ._curves import spot_frostbite as spot_frostbite
from ._curves import spot_t as spot_t
from ._curves import spot_threejs as spot_threejs

__all__ = [
    "MIN_COS_WIDTH",
    "SPOT_FALLOFFS",
    "SpotFalloff",
    "SpotFrostbite",
    "SpotThreeJS",
    "lambert_disk",
    "spot_frostbite",
    "spot_t",
    "spot_threejs",
]
