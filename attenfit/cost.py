"""What each attenuation curve costs: instruction counts from real compilers (SPIR-V through
glslangValidator and spirv-opt, NVIDIA SASS through NVRTC and ptxas) of the form that ships
(`compiled_cost`), the precision of that form in float32 and float16 (`precision`), operation
counts and a shader cost estimated from the traced expression, measured throughput, and the
Pareto front of cost against error. Implemented in `attenfit._shaders._compilers`,
`_precision` and `_cost` (whose docstring gives the weights and their sources);
docs/shaders.md.
"""

from ._report import plot_cost_vs_error as plot_cost_vs_error
from ._shaders._compilers import Compiled as Compiled
from ._shaders._compilers import CompiledCost as CompiledCost
from ._shaders._compilers import CompilerError as CompilerError
from ._shaders._compilers import compiled_cost as compiled_cost
from ._shaders._compilers import compilers as compilers
from ._shaders._compilers import cost_method as cost_method
from ._shaders._compilers import structural_cost as structural_cost
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
from ._shaders._precision import PRECISIONS as PRECISIONS
from ._shaders._precision import Precision as Precision
from ._shaders._precision import precision as precision

__all__ = [
    "CATEGORIES",
    "PRECISIONS",
    "SHADER_WEIGHTS",
    "Compiled",
    "CompiledCost",
    "CompilerError",
    "Cost",
    "ParetoFront",
    "Precision",
    "cheapest_within",
    "compiled_cost",
    "compilers",
    "cost_method",
    "cost_table",
    "count_ops",
    "family_cost",
    "measure_throughput",
    "pareto_front",
    "plot_cost_vs_error",
    "precision",
    "shader_cost",
    "structural_cost",
]
