"""The named attenuation families, every one registered (`attenfit.list_families()`).

Each is a small final `eqx.Module` whose fields are its parameters; `family(d)` evaluates f(d)
in 1/length^2, `d` the distance from the light's centre. How they are built, and what every
family guarantees, is in `attenfit._curves` and docs/families.md.
"""

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

__all__ = [
    "Clamped",
    "CryEngineLinear",
    "DiskFacing",
    "FrostbiteWindow",
    "GltfRange",
    "Godot",
    "InverseSquare",
    "JustCause2",
    "MadamsCutoff",
    "MadamsRational",
    "MadamsSphere",
    "MadamsTan",
    "Polynomial",
    "Spline",
    "ThreeJS",
    "UnrealEpsilon",
    "UnrealExponent",
    "UnrealWindow",
    "Yuksel",
    "YukselAdhoc",
]
