"""Stage 1, the curves: the `Model` base, the `Family` base and registry, the parts every family is built from,
the named families, and the spot falloffs.

Imports nothing from the other stages. The named families register themselves on import,
in the order `list_families()` reports them.
"""

# The named families register themselves on import, in this order (the order of
# `list_families()`, of reports and tables): keep the imports unsorted.
from ._model_base import CONSTRAINTS as CONSTRAINTS
from ._model_base import Model as Model
from ._model_base import no_shader_form as no_shader_form
from ._forms import AREA_FORM_INPUTS as AREA_FORM_INPUTS
from ._family import Family as Family
from ._family import family_from_function as family_from_function
from ._family import float32_family as float32_family
from ._family import get_family as get_family
from ._family import list_families as list_families
from ._family import register_family as register_family
from ._softened import Clamped as Clamped
from ._softened import DiskFacing as DiskFacing
from ._softened import InverseSquare as InverseSquare
from ._softened import Polynomial as Polynomial
from ._softened import UnrealEpsilon as UnrealEpsilon
from ._softened import Yuksel as Yuksel
from ._softened import YukselAdhoc as YukselAdhoc
from ._madams import MadamsCutoff as MadamsCutoff
from ._madams import MadamsRational as MadamsRational
from ._madams import MadamsSphere as MadamsSphere
from ._madams import MadamsTan as MadamsTan
from ._windowed import CryEngineLinear as CryEngineLinear
from ._windowed import FrostbiteWindow as FrostbiteWindow
from ._windowed import GltfRange as GltfRange
from ._windowed import Godot as Godot
from ._windowed import JustCause2 as JustCause2
from ._windowed import ThreeJS as ThreeJS
from ._windowed import UnrealExponent as UnrealExponent
from ._windowed import UnrealWindow as UnrealWindow
from ._spline import Spline as Spline
from ._spline import spline_curve as spline_curve
from ._area import AREA_INPUTS as AREA_INPUTS
from ._area import INPUT_RANGES as INPUT_RANGES
from ._area import RECT_INPUTS as RECT_INPUTS
from ._area import TUBE_INPUTS as TUBE_INPUTS
from ._area import AreaInputs as AreaInputs
from ._area import AreaModel as AreaModel
from ._area import PointLight as PointLight
from ._area import cone_cosine as cone_cosine
from ._area import get_area_model as get_area_model
from ._area import list_area_models as list_area_models
from ._area import point_light_class as point_light_class
from ._area import register_area_model as register_area_model
from ._area_models import SnyderSphere as SnyderSphere
from ._area_models import FrostbiteDisk as FrostbiteDisk
from ._area_models import VectorDisk as VectorDisk
from ._area_models import UnrealWrap as UnrealWrap
from ._area_models import GodotWrap as GodotWrap
from ._area_models import HdrpSphere as HdrpSphere
from ._area_models import MrpSphere as MrpSphere
from ._clipped_disk import ClippedDisk as ClippedDisk
from ._rect_models import ClippedRect as ClippedRect
from ._rect_models import FrostbiteRect as FrostbiteRect
from ._rect_models import RectModel as RectModel
from ._rect_models import ThreeRect as ThreeRect
from ._unreal_rect import UnrealRect as UnrealRect
from ._tube_models import FrostbiteTube as FrostbiteTube
from ._tube_models import KarisTube as KarisTube
from ._tube_models import LambertLine as LambertLine
from ._tube_models import TubeModel as TubeModel
from ._directional import MIN_COS_WIDTH as MIN_COS_WIDTH
from ._directional import SPOT_FALLOFFS as SPOT_FALLOFFS
from ._directional import SpotFalloff as SpotFalloff
from ._directional import SpotFrostbite as SpotFrostbite
from ._directional import SpotThreeJS as SpotThreeJS
from ._directional import lambert_disk as lambert_disk
from ._directional import spot_frostbite as spot_frostbite
from ._directional import spot_t as spot_t
from ._directional import spot_threejs as spot_threejs
