"""Stage 6, the report: metrics of an approximation's error (`_metrics`), plots
(`_plots`, `_cost_plot`), the configurations a report compares on (`_configs`), published
parameters (`_published`), the result rows (`_evaluate`), the combined fit
(`_fit_all`), findings (`_findings`), and the `Report` itself (`_document`, `_build`).

Imports the curves, truth, fitting and shaders stages, and nothing above.
"""

from ._area_shapes import split_shapes as split_shapes
from ._build import build_report as build_report
from ._build import resolve_emitters as resolve_emitters
from ._build import resolve_families as resolve_families
from ._build import shape_rows as shape_rows
from ._configs import DEFAULT_RADIUS as DEFAULT_RADIUS
from ._configs import PLANE_PX as PLANE_PX
from ._configs import PUBLISHED_CUTOFF as PUBLISHED_CUTOFF
from ._configs import SWEEP_N as SWEEP_N
from ._configs import default_emitters as default_emitters
from ._configs import published_range as published_range
from ._cost_plot import plot_cost_vs_error as plot_cost_vs_error
from ._document import Report as Report
from ._plots import plain_log_ticks as plain_log_ticks
from ._published import PUBLISHED_RULES as PUBLISHED_RULES
from ._published import published_params as published_params
from ._witness import cached_witness as cached_witness
from ._witness import store_witness as store_witness
from ._witness import witness_key as witness_key
from ._witness import witness_section as witness_section
