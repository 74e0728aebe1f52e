"""Stage 2, the ground truth: Lambertian emitters, their exact irradiance, an independent
quadrature, datasets of receivers with their irradiance, and the receiver geometry that
the area-light models read.

Imports the curves stage (the `AreaInputs` an area model reads) and nothing above it.
"""

from ._dataset import FORMAT as FORMAT
from ._dataset import FORMAT_VERSION as FORMAT_VERSION
from ._dataset import Dataset as Dataset
from ._dataset import facing_sweep as facing_sweep
from ._dataset import plane_receivers as plane_receivers
from ._dataset import random_receivers as random_receivers
from ._emitters import AbstractEmitter as AbstractEmitter
from ._emitters import CapsuleEmitter as CapsuleEmitter
from ._emitters import DiskEmitter as DiskEmitter
from ._emitters import SphereEmitter as SphereEmitter
from ._emitters import emitter_from_dict as emitter_from_dict
from ._geometry import area_inputs as area_inputs
from ._geometry import area_irradiance as area_irradiance
from ._geometry import frame_inputs as frame_inputs
from ._geometry import model_inputs as model_inputs
from ._irradiance import irradiance as irradiance
from ._rect import RectEmitter as RectEmitter
from ._tube import TubeEmitter as TubeEmitter
