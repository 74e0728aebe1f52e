"""Stage 4, shaders: every model's shader form (`Model.shader_form`, written on its class in
the expression language of `_ir`) and a family's stable form (a scalar program read from its
jaxpr, `_trace`), printed as GLSL, HLSL, WGSL, C or CUDA (`_print`, `_stable`, `_export`; an
area model's by `_area_export`); what they cost (`_cost`: the traced-operation estimate;
`_compilers`, `_area_cost`: real compilers) and how precise they are in float16 and float32
(`_precision`). No form is written here.

Imports the curves stage (and the fitting stage's results, by duck typing) and nothing above.
"""

from .._ir import ShaderForm as ShaderForm
from .._ir import evaluate_form as evaluate_form
from ._area_cost import area_compiled_cost as area_compiled_cost
from ._area_cost import area_function_source as area_function_source
from ._area_cost import evaluate_area_form as evaluate_area_form
from ._area_export import area_export_form as area_export_form
from ._area_export import area_source as area_source
from ._compilers import Compiled as Compiled
from ._compilers import CompiledCost as CompiledCost
from ._compilers import CompilerError as CompilerError
from ._compilers import compiled_cost as compiled_cost
from ._compilers import compilers as compilers
from ._compilers import cost_method as cost_method
from ._compilers import in_parallel as in_parallel
from ._compilers import structural_cost as structural_cost
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
from ._cost import rank_key as rank_key
from ._cost import shader_cost as shader_cost
from ._export import FORMS as FORMS
from ._export import LANGUAGES as LANGUAGES
from ._export import export as export
from ._export import function_source as function_source
from ._export import scalar_params as scalar_params
from ._model import as_model as as_model
from ._model import load_model as load_model
from ._precision import PRECISIONS as PRECISIONS
from ._precision import Precision as Precision
from ._precision import precision as precision
from ._precision import shade_in as shade_in
from ._program import Program as Program
from ._text import float32_literal as float32_literal
from ._trace import trace as trace
