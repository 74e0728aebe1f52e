"""A family as a self-contained GLSL, HLSL, WGSL, C or CUDA function: its shader form (the
engines' expression) or its stable form (the expression the JAX code evaluates); an area
model as a function of the receiver geometry (`d, cos_r, cos_e, r, cos_n, g`), its shader
form. Each model writes its shader form on its class (`Model.shader_form`). Implemented in
`attenfit._shaders._export` and `_area_export`; docs/shaders.md.
"""

from ._shaders._export import FORMS as FORMS
from ._shaders._export import LANGUAGES as LANGUAGES
from ._shaders._export import UnsupportedPrimitiveError as UnsupportedPrimitiveError
from ._shaders._export import export as export
from ._shaders._export import function_source as function_source
from ._shaders._model import load_model as load_model
from ._shaders._text import float32_literal as float32_literal

__all__ = [
    "FORMS",
    "LANGUAGES",
    "UnsupportedPrimitiveError",
    "export",
    "float32_literal",
    "function_source",
    "load_model",
]
