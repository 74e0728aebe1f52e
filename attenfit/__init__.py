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

# --- families (issue 2) ---
# --- emitters, irradiance, quadrature, datasets (issue 3) ---
# --- fitting (issue 5) ---
# --- metrics and report (issue 6) ---
# --- cost, scene, export (issue 7) ---

__version__ = "0.1.0"
