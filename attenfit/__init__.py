"""attenfit: how well does a cheap light-attenuation curve stand in for a real light?

Differentiable attenuation families in JAX, exact ground-truth irradiance from spherical,
disk and capsule emitters, least-squares fits with optimistix, and reports of the
speed/accuracy trade.

The public API is re-exported here, grouped by pipeline stage. The implementation lives in
one private subpackage per stage, each importing only the stages below it: `_curves`,
`_truth`, `_fit`, `_shaders`, `_report`, `_scenes`, with the command line (`cli`, `_cli`)
on top (docs/architecture.md). The public modules (`attenfit.families`, `attenfit.parts`,
`attenfit.cost`, ...) re-export their stage's names.

Importing attenfit is cheap: each name below is imported on first use (`__getattr__`), so
`attenfit --help` and `attenfit families` never import JAX's compiled paths or matplotlib.
"""

from __future__ import annotations

import ast
import importlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._errors import AttenfitError as AttenfitError
from ._errors import BadTypeError as BadTypeError
from ._errors import BadValueError as BadValueError
from ._errors import DataFileError as DataFileError
from ._errors import OutputExistsError as OutputExistsError
from ._errors import UnknownNameError as UnknownNameError
from ._version import __version__ as __version__

if TYPE_CHECKING:  # the public API, imported on first use (`__getattr__` reads this block)
    from ._curves import Family as Family
    from ._curves import get_family as get_family
    from ._curves import list_families as list_families
    from ._curves import register_family as register_family

    # Curves: the attenuation families, the parts they are built from, spotlight falloffs.
    from . import directional as directional
    from . import families as families
    from . import parts as parts
    from ._curves import family_from_function as family_from_function
    from ._curves import no_shader_form as no_shader_form
    from ._curves import lambert_disk as lambert_disk
    from ._curves import spot_frostbite as spot_frostbite
    from ._curves import spot_t as spot_t
    from ._curves import spot_threejs as spot_threejs
    from ._curves import Clamped as Clamped
    from ._curves import CryEngineLinear as CryEngineLinear
    from ._curves import DiskFacing as DiskFacing
    from ._curves import FrostbiteWindow as FrostbiteWindow
    from ._curves import GltfRange as GltfRange
    from ._curves import Godot as Godot
    from ._curves import InverseSquare as InverseSquare
    from ._curves import JustCause2 as JustCause2
    from ._curves import MadamsCutoff as MadamsCutoff
    from ._curves import MadamsRational as MadamsRational
    from ._curves import MadamsSphere as MadamsSphere
    from ._curves import MadamsTan as MadamsTan
    from ._curves import Polynomial as Polynomial
    from ._curves import Spline as Spline
    from ._curves import ThreeJS as ThreeJS
    from ._curves import UnrealEpsilon as UnrealEpsilon
    from ._curves import UnrealExponent as UnrealExponent
    from ._curves import UnrealWindow as UnrealWindow
    from ._curves import Yuksel as Yuksel
    from ._curves import YukselAdhoc as YukselAdhoc

    # Area-light models: irradiance from the receiver's geometry (docs/area.md).
    from . import area as area
    from ._curves import AreaModel as AreaModel
    from ._curves import PointLight as PointLight
    from ._curves import SnyderSphere as SnyderSphere
    from ._curves import FrostbiteDisk as FrostbiteDisk
    from ._curves import VectorDisk as VectorDisk
    from ._curves import UnrealWrap as UnrealWrap
    from ._curves import GodotWrap as GodotWrap
    from ._curves import HdrpSphere as HdrpSphere
    from ._curves import MrpSphere as MrpSphere
    from ._curves import get_area_model as get_area_model
    from ._curves import list_area_models as list_area_models
    from ._truth import area_inputs as area_inputs
    from ._truth import area_irradiance as area_irradiance

    # Ground truth: emitters, exact irradiance, quadrature, datasets.
    from . import emitters as emitters
    from . import quadrature as quadrature
    from ._truth import Dataset as Dataset
    from ._truth import facing_sweep as facing_sweep
    from ._truth import plane_receivers as plane_receivers
    from ._truth import random_receivers as random_receivers
    from ._truth import irradiance as irradiance
    from ._truth import AbstractEmitter as AbstractEmitter
    from ._truth import CapsuleEmitter as CapsuleEmitter
    from ._truth import DiskEmitter as DiskEmitter
    from ._truth import RectEmitter as RectEmitter
    from ._truth import TubeEmitter as TubeEmitter
    from ._truth import SphereEmitter as SphereEmitter
    from ._truth import emitter_from_dict as emitter_from_dict

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
    from . import report as report
    from ._report import Report as Report
    from ._report import build_report as build_report

    # Scene files and recommendations.
    from . import scene as scene
    from ._scenes import Candidate as Candidate
    from ._scenes import Recommendation as Recommendation
    from ._scenes import recommend as recommend
    from ._scenes import Scene as Scene

    # Cost and shader export. `attenfit.export` is the module; its function is
    # `attenfit.export.export`, also available as `attenfit.export_function`.
    from . import cost as cost
    from . import export as export
    from ._shaders import Cost as Cost
    from ._shaders import ParetoFront as ParetoFront
    from ._shaders import cheapest_within as cheapest_within
    from ._shaders import cost_table as cost_table
    from ._shaders import count_ops as count_ops
    from ._shaders import family_cost as family_cost
    from ._shaders import pareto_front as pareto_front
    from ._report import plot_cost_vs_error as plot_cost_vs_error
    from ._shaders import shader_cost as shader_cost
    from ._shaders import export as export_function  # noqa: F401 (a public alias)


def _public() -> dict[str, tuple[str, str | None]]:
    """name -> (module, attribute or None for the module itself), read from the imports of
    the `if TYPE_CHECKING:` block above: the one list of the public API."""
    global _PUBLIC
    if _PUBLIC is None:
        tree = ast.parse(Path(__file__).read_text(encoding="utf-8"))
        block = next(n for n in tree.body if isinstance(n, ast.If))
        table: dict[str, tuple[str, str | None]] = {}
        for node in block.body:
            assert isinstance(node, ast.ImportFrom)
            for alias in node.names:
                if node.module is None:  # from . import families as families
                    table[alias.asname or alias.name] = ("." + alias.name, None)
                else:
                    table[alias.asname or alias.name] = ("." + node.module, alias.name)
        _PUBLIC = table
    return _PUBLIC


_PUBLIC: dict[str, tuple[str, str | None]] | None = None


def __getattr__(name: str) -> Any:
    if name == "__all__":  # the lazy names, and those imported above from attenfit's modules
        eager = (
            n
            for n, v in globals().items()
            if not n.startswith("_") and getattr(v, "__module__", "").startswith(__name__)
        )
        return sorted({*_public(), *eager, "__version__"})
    try:
        module, attribute = _public()[name]
    except KeyError:
        raise AttributeError(f"module 'attenfit' has no attribute {name!r}") from None
    value = importlib.import_module(module, __name__)
    if attribute is not None:
        value = getattr(value, attribute)
    globals()[name] = value  # later lookups skip this function
    return value


def __dir__() -> list[str]:
    return sorted({*globals(), *_public()})
