"""Area-light models: irradiance approximations that read the receiver's geometry, not only d.

The exact sphere (Snyder 1996, Frostbite's `illuminanceSphereOrDisk`), Frostbite's disk, the
exact disk above the horizon with a sphere cap below it, Unreal's and Godot's horizon wraps,
Unity HDRP's fitted sphere irradiance and the most representative point; `PointLight(family)`
is the point-light model of every distance family in the same terms. `area_inputs` reads
the geometry from an emitter and its receivers. Implemented in `attenfit._curves._area`,
`_area_models` (each model with its shader form), `attenfit._truth._geometry` and
`attenfit._shaders._area_cost` (compiled costs); docs/area.md.
"""

from ._curves import AREA_FORM_INPUTS as AREA_FORM_INPUTS
from ._curves import AREA_INPUTS as AREA_INPUTS
from ._curves import AreaInputs as AreaInputs
from ._curves import AreaModel as AreaModel
from ._curves import FrostbiteDisk as FrostbiteDisk
from ._curves import GodotWrap as GodotWrap
from ._curves import HdrpSphere as HdrpSphere
from ._curves import MrpSphere as MrpSphere
from ._curves import PointLight as PointLight
from ._curves import SnyderSphere as SnyderSphere
from ._curves import UnrealWrap as UnrealWrap
from ._curves import VectorDisk as VectorDisk
from ._curves import cone_cosine as cone_cosine
from ._curves import get_area_model as get_area_model
from ._curves import list_area_models as list_area_models
from ._curves import register_area_model as register_area_model
from ._shaders import area_compiled_cost as area_compiled_cost
from ._shaders import area_function_source as area_function_source
from ._truth import area_inputs as area_inputs
from ._truth import area_irradiance as area_irradiance

__all__ = [
    "AREA_FORM_INPUTS",
    "AREA_INPUTS",
    "AreaInputs",
    "AreaModel",
    "FrostbiteDisk",
    "GodotWrap",
    "HdrpSphere",
    "MrpSphere",
    "PointLight",
    "SnyderSphere",
    "UnrealWrap",
    "VectorDisk",
    "area_compiled_cost",
    "area_function_source",
    "area_inputs",
    "area_irradiance",
    "cone_cosine",
    "get_area_model",
    "list_area_models",
    "register_area_model",
]
