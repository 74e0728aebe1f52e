"""Independent ground truth rendered with Mitsuba 3.

`data_gen` imports `attenfit` (for its emitters and `Dataset` format); `attenfit` never
imports `data_gen` (except lazily inside the `attenfit gen` verb).

* `data_gen.variants`: which Mitsuba variant to use (`llvm_ad_rgb` only after a probe in a
  child process succeeds; otherwise `scalar_rgb`).
* `data_gen.scenes`: Mitsuba scene dicts for sphere, disk, capsule, rectangle and tube lights.
* `data_gen.estimate`: per-receiver Monte Carlo irradiance with standard errors.
* `data_gen.render`, `data_gen.batch`: Mitsuba-rendered `attenfit.Dataset`s, in one go or in
  resumable chunks.
* `data_gen.maps`: irradiance images of a plane under lights.
"""

from .batch import render_batch as render_batch
from .estimate import estimate_detail as estimate_detail
from .estimate import estimate_irradiance as estimate_irradiance
from .maps import render_plane_map as render_plane_map
from .render import render_dataset as render_dataset
from .scenes import CapsuleLight as CapsuleLight
from .scenes import DiskLight as DiskLight
from .scenes import Plane as Plane
from .scenes import RectLight as RectLight
from .scenes import SphereLight as SphereLight
from .scenes import TubeLight as TubeLight
from .variants import select_variant as select_variant
