"""Stage 4, shaders: a family as a scalar program read from its jaxpr (`_trace`), what that
program costs (`_cost`), and the program printed as GLSL, HLSL, WGSL or C (`_export`).

Imports the curves stage (and the fitting stage's results, by duck typing) and nothing above.
"""

from ._cost import CATEGORIES as CATEGORIES
from ._cost import SHADER_WEIGHTS as SHADER_WEIGHTS
from ._cost import Cost as Cost
from ._cost import ParetoFront as ParetoFront
from ._cost import cheapest_within as cheapest_within
from ._cost import cost_table as cost_table
from ._cost import count_ops as count_ops
from ._cost import family_cost as family_cost
from ._cost import measure_throughput as measure_throughput
from ._cost import pareto_front as pareto_front
from ._cost import shader_cost as shader_cost
from ._export import LANGUAGES as LANGUAGES
from ._export import export as export
from ._export import float32_literal as float32_literal
from ._export import load_model as load_model
from ._program import Program as Program
from ._trace import trace as trace
