"""A family as a self-contained GLSL, HLSL, WGSL or C function, printed from the expression the
JAX code evaluates. Implemented in `attenfit._shaders._export`; docs/shaders.md.
"""

from ._shaders._export import LANGUAGES as LANGUAGES
from ._shaders._export import UnsupportedPrimitiveError as UnsupportedPrimitiveError
from ._shaders._export import export as export
from ._shaders._export import float32_literal as float32_literal
from ._shaders._export import load_model as load_model

__all__ = [
    "LANGUAGES",
    "UnsupportedPrimitiveError",
    "export",
    "float32_literal",
    "load_model",
]
