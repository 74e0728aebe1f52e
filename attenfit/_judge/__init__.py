"""Stage 5, the judge: how far a model is from the truth on a set of receivers, and which of
several candidate models to name (`rank`: one tie-break for every verdict).

Imports the curves, truth, fitting and shaders stages, and nothing above. The report and the
scene stage decide through it.
"""

from ._area_shading import AREA_WITNESSES as AREA_WITNESSES
from ._area_shading import AreaWitness as AreaWitness
from ._area_shading import area_witnesses as area_witnesses
from ._area_shading import best_intensity as best_intensity
from ._area_shading import window_range as window_range
from ._engine_shading import WITNESSES as WITNESSES
from ._engine_shading import EngineWitness as EngineWitness
from ._engine_shading import engine_receiver_errors as engine_receiver_errors
from ._engine_shading import fast_cos as fast_cos
from ._engine_shading import get_witness as get_witness
from ._rank import Contender as Contender
from ._rank import Ranking as Ranking
from ._rank import rank as rank
from ._receivers import GAP_BAND_LABELS as GAP_BAND_LABELS
from ._receivers import GAP_BANDS as GAP_BANDS
from ._shapes import SHAPE_CONFIGS as SHAPE_CONFIGS
from ._shapes import ShapeConfig as ShapeConfig
from ._shapes import ShapeWorst as ShapeWorst
from ._shapes import shape_worst_case as shape_worst_case
from ._worst import WorstCase as WorstCase
from ._worst import receiver_error as receiver_error
from ._worst import typical_error as typical_error
from ._worst import worst_case as worst_case
