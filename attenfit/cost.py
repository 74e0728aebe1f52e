"""What each attenuation curve costs: operation counts and a shader cost from the traced
expression, measured throughput, and the Pareto front of cost against error. Implemented in
`attenfit._shaders._cost` (whose docstring gives the weights and their sources); docs/shaders.md.
"""

from ._report import plot_cost_vs_error as plot_cost_vs_error
from ._shaders._cost import CATEGORIES as CATEGORIES
from ._shaders._cost import SHADER_WEIGHTS as SHADER_WEIGHTS
from ._shaders._cost import Cost as Cost
from ._shaders._cost import ParetoFront as ParetoFront
from ._shaders._cost import cheapest_within as cheapest_within
from ._shaders._cost import cost_table as cost_table
from ._shaders._cost import count_ops as count_ops
from ._shaders._cost import family_cost as family_cost
from ._shaders._cost import measure_throughput as measure_throughput
from ._shaders._cost import pareto_front as pareto_front
from ._shaders._cost import shader_cost as shader_cost

__all__ = [
    "CATEGORIES",
    "SHADER_WEIGHTS",
    "Cost",
    "ParetoFront",
    "cheapest_within",
    "cost_table",
    "count_ops",
    "family_cost",
    "measure_throughput",
    "pareto_front",
    "plot_cost_vs_error",
    "shader_cost",
]
