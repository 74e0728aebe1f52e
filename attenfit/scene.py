"""Scene files: a scene's lights, receivers and tolerance, its ground truth at exactly its
receivers, and the cheapest family that meets its tolerance (`recommend`). Implemented in
`attenfit._scenes`; docs/scenes.md describes the format key by key. USD and glTF files
(`answer_file`, `load_mesh_scene`): docs/usd-gltf.md.
"""

from ._scenes import ENGINES as ENGINES
from ._scenes import LIGHT_KINDS as LIGHT_KINDS
from ._scenes import RECEIVER_KINDS as RECEIVER_KINDS
from ._scenes import SCENE_KEYS as SCENE_KEYS
from ._scenes import SIDE_KEYS as SIDE_KEYS
from ._scenes import SPOT_PROFILES as SPOT_PROFILES
from ._scenes import Candidate as Candidate
from ._scenes import DistanceDistribution as DistanceDistribution
from ._scenes import FileAnswer as FileAnswer
from ._scenes import ImportedScene as ImportedScene
from ._scenes import LightChoice as LightChoice
from ._scenes import LightTruth as LightTruth
from ._scenes import PlaneReceivers as PlaneReceivers
from ._scenes import PointReceivers as PointReceivers
from ._scenes import Recommendation as Recommendation
from ._scenes import Scene as Scene
from ._scenes import SceneLight as SceneLight
from ._scenes import answer_file as answer_file
from ._scenes import load_mesh_scene as load_mesh_scene
from ._scenes import recommend as recommend
from ._scenes import spot_profile as spot_profile

__all__ = [
    "ENGINES",
    "LIGHT_KINDS",
    "RECEIVER_KINDS",
    "SCENE_KEYS",
    "SIDE_KEYS",
    "SPOT_PROFILES",
    "Candidate",
    "DistanceDistribution",
    "FileAnswer",
    "ImportedScene",
    "LightChoice",
    "LightTruth",
    "PlaneReceivers",
    "PointReceivers",
    "Recommendation",
    "Scene",
    "SceneLight",
    "answer_file",
    "load_mesh_scene",
    "recommend",
    "spot_profile",
]
