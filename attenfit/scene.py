"""Scene files: a scene's lights, receivers and tolerance, its ground truth at exactly its
receivers, and the cheapest family that meets its tolerance (`recommend`). Implemented in
`attenfit._scenes`; docs/scenes.md describes the format key by key.
"""

from ._scenes import LIGHT_KINDS as LIGHT_KINDS
from ._scenes import RECEIVER_KINDS as RECEIVER_KINDS
from ._scenes import SCENE_KEYS as SCENE_KEYS
from ._scenes import SPOT_PROFILES as SPOT_PROFILES
from ._scenes import Candidate as Candidate
from ._scenes import DistanceDistribution as DistanceDistribution
from ._scenes import LightTruth as LightTruth
from ._scenes import PlaneReceivers as PlaneReceivers
from ._scenes import PointReceivers as PointReceivers
from ._scenes import Recommendation as Recommendation
from ._scenes import Scene as Scene
from ._scenes import SceneLight as SceneLight
from ._scenes import recommend as recommend
from ._scenes import spot_profile as spot_profile

__all__ = [
    "LIGHT_KINDS",
    "RECEIVER_KINDS",
    "SCENE_KEYS",
    "SPOT_PROFILES",
    "Candidate",
    "DistanceDistribution",
    "LightTruth",
    "PlaneReceivers",
    "PointReceivers",
    "Recommendation",
    "Scene",
    "SceneLight",
    "recommend",
    "spot_profile",
]
