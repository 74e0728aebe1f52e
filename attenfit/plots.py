"""Figures of the comparison report: curves against the truth, errors, rendered planes. Each
takes an optional `ax=`, returns `(fig, ax)` and never calls `show()`. Implemented in
`attenfit._report._plots`.
"""

from ._report._plots import STYLE as STYLE
from ._report._plots import curve_styles as curve_styles
from ._report._plots import new_figure as new_figure
from ._report._plots import plot_attenuation as plot_attenuation
from ._report._plots import plot_error_map as plot_error_map
from ._report._plots import plot_plane_comparison as plot_plane_comparison
from ._report._plots import plot_plane_image as plot_plane_image
from ._report._plots import plot_relative_error as plot_relative_error
from ._report._plots import plot_side_by_side as plot_side_by_side

__all__ = [
    "STYLE",
    "curve_styles",
    "new_figure",
    "plot_attenuation",
    "plot_error_map",
    "plot_plane_comparison",
    "plot_plane_image",
    "plot_relative_error",
    "plot_side_by_side",
]
