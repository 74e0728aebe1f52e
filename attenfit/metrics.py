"""Error metrics of an attenuation curve against the truth: pure functions over arrays,
returning plain numbers ready for JSON. Implemented in `attenfit._report._metrics`.
"""

from ._report._metrics import BANDS as BANDS
from ._report._metrics import attenuation_errors as attenuation_errors
from ._report._metrics import band_errors as band_errors
from ._report._metrics import discarded_fraction as discarded_fraction
from ._report._metrics import error_stats as error_stats
from ._report._metrics import grid_energy as grid_energy
from ._report._metrics import image_errors as image_errors
from ._report._metrics import plane_energy as plane_energy
from ._report._metrics import relative_error as relative_error
from ._report._metrics import value_at_zero as value_at_zero
from ._report._metrics import window_edge as window_edge
from ._report._metrics import window_reach as window_reach

__all__ = [
    "BANDS",
    "attenuation_errors",
    "band_errors",
    "discarded_fraction",
    "error_stats",
    "grid_energy",
    "image_errors",
    "plane_energy",
    "relative_error",
    "value_at_zero",
    "window_edge",
    "window_reach",
]
