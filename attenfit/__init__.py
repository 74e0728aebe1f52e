"""attenfit: how well does a cheap light-attenuation curve stand in for a real light?

Differentiable attenuation families in JAX, exact ground-truth irradiance from spherical,
disk and capsule emitters, least-squares fits with optimistix, and reports of the
speed/accuracy trade. The public API is re-exported here; implementation lives in private
modules, one concept each.
"""

from ._errors import AttenfitError as AttenfitError
from ._errors import BadTypeError as BadTypeError
from ._errors import BadValueError as BadValueError
from ._errors import DataFileError as DataFileError
from ._errors import OutputExistsError as OutputExistsError
from ._errors import UnknownNameError as UnknownNameError
from ._family import Family as Family
from ._family import get_family as get_family
from ._family import list_families as list_families
from ._family import register_family as register_family


# Families: the attenuation curves and the spotlight directional factors.
from . import directional as directional
from . import families as families
from ._family import family_from_function as family_from_function
from .directional import lambert_disk as lambert_disk
from .directional import spot_frostbite as spot_frostbite
from .directional import spot_t as spot_t
from .directional import spot_threejs as spot_threejs
from .families import Clamped as Clamped
from .families import CryEngineLinear as CryEngineLinear
from .families import DiskFacing as DiskFacing
from .families import FrostbiteWindow as FrostbiteWindow
from .families import GltfRange as GltfRange
from .families import Godot as Godot
from .families import InverseSquare as InverseSquare
from .families import JustCause2 as JustCause2
from .families import MadamsCutoff as MadamsCutoff
from .families import MadamsRational as MadamsRational
from .families import MadamsSphere as MadamsSphere
from .families import MadamsTan as MadamsTan
from .families import Polynomial as Polynomial
from .families import Spline as Spline
from .families import ThreeJS as ThreeJS
from .families import UnrealEpsilon as UnrealEpsilon
from .families import UnrealExponent as UnrealExponent
from .families import UnrealWindow as UnrealWindow
from .families import Yuksel as Yuksel
from .families import YukselAdhoc as YukselAdhoc

# Ground truth: emitters, exact irradiance, quadrature, datasets.
from . import quadrature as quadrature
from ._dataset import Dataset as Dataset
from ._dataset import facing_sweep as facing_sweep
from ._dataset import plane_receivers as plane_receivers
from ._dataset import random_receivers as random_receivers
from ._irradiance import irradiance as irradiance
from .emitters import AbstractEmitter as AbstractEmitter
from .emitters import CapsuleEmitter as CapsuleEmitter
from .emitters import DiskEmitter as DiskEmitter
from .emitters import SphereEmitter as SphereEmitter
from .emitters import emitter_from_dict as emitter_from_dict

# Fitting.
from ._fit import LOSSES as LOSSES
from ._fit import SOLVERS as SOLVERS
from ._fit import FitResult as FitResult
from ._fit import FitResults as FitResults
from ._fit import fit as fit
from ._fit import fit_dataset as fit_dataset
from ._fit import fit_many as fit_many

# Metrics and the comparison report.
from . import metrics as metrics
from . import plots as plots
from .report import Report as Report
from .report import build_report as build_report

# Scene files and recommendations.
from . import scene as scene
from ._recommend import Candidate as Candidate
from ._recommend import Recommendation as Recommendation
from ._recommend import recommend as recommend
from .scene import Scene as Scene

# Cost and shader export. `attenfit.export` is the module; its function is
# `attenfit.export.export`, also available as `attenfit.export_function`.
from . import cost as cost
from . import export as export
from .cost import Cost as Cost
from .cost import ParetoFront as ParetoFront
from .cost import cheapest_within as cheapest_within
from .cost import cost_table as cost_table
from .cost import count_ops as count_ops
from .cost import family_cost as family_cost
from .cost import pareto_front as pareto_front
from .cost import plot_cost_vs_error as plot_cost_vs_error
from .cost import shader_cost as shader_cost
from .export import export as export_function  # noqa: F401 (public alias)

__version__ = "0.1.0"
