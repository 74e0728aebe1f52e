"""The comparison report: every family against exact sphere and disk lights, as published and
fitted, in numbers (report.md, report.json, results.csv) and figures. Implemented in
`attenfit._report`; docs/report.md.
"""

from ._report import DEFAULT_RADIUS as DEFAULT_RADIUS
from ._report import PUBLISHED_CUTOFF as PUBLISHED_CUTOFF
from ._report import PUBLISHED_RULES as PUBLISHED_RULES
from ._report import SWEEP_N as SWEEP_N
from ._report import Report as Report
from ._report import build_report as build_report
from ._report import default_emitters as default_emitters
from ._report import published_params as published_params

__all__ = [
    "DEFAULT_RADIUS",
    "PUBLISHED_CUTOFF",
    "PUBLISHED_RULES",
    "SWEEP_N",
    "Report",
    "build_report",
    "default_emitters",
    "published_params",
]
