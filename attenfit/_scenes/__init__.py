"""Stage 7, scenes: a scene file (`_toml`) read into a `Scene` (`_scene`, `_types`), its
ground truth at exactly its receivers (`_lighting`), every family fitted there (`_light_fits`)
and the cheapest within its tolerance recommended (`_recommend`, `_advice`). USD and
glTF files (`_usd`, `_gltf`, `_sample`, `_files`) are answered per light for an engine
(`_engine`, `_choices`, `_answer`) and written back (`_writeback`).

Imports every stage below it (curves, truth, fitting, shaders, report's plots).
"""

from ._advice import Candidate as Candidate
from ._advice import Recommendation as Recommendation
from ._advice import plot_scene_errors as plot_scene_errors
from ._answer import FileAnswer as FileAnswer
from ._answer import answer_file as answer_file
from ._answer import answer_scene as answer_scene
from ._choices import LightChoice as LightChoice
from ._engine import ENGINES as ENGINES
from ._engine import get_engine as get_engine
from ._files import SIDE_KEYS as SIDE_KEYS
from ._files import ImportedScene as ImportedScene
from ._files import engine_scene as engine_scene
from ._files import is_mesh_scene as is_mesh_scene
from ._files import load_mesh_scene as load_mesh_scene
from ._files import scene_files as scene_files
from ._lighting import spot_profile as spot_profile
from ._recommend import recommend as recommend
from ._scene import Scene as Scene
from ._toml import SCENE_KEYS as SCENE_KEYS
from ._types import LIGHT_KINDS as LIGHT_KINDS
from ._types import RECEIVER_KINDS as RECEIVER_KINDS
from ._types import SPOT_PROFILES as SPOT_PROFILES
from ._types import DistanceDistribution as DistanceDistribution
from ._types import LightTruth as LightTruth
from ._types import PlaneReceivers as PlaneReceivers
from ._types import PointReceivers as PointReceivers
from ._types import SceneLight as SceneLight
from ._writeback import WRITE_BACK_MARKS as WRITE_BACK_MARKS
