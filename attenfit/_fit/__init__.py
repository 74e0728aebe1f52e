"""Stage 3, fitting: `fit`, `fit_dataset` and `fit_many` on optimistix, with attenfit's
Levenberg-Marquardt (`_solvers`), data-derived starts (`_guess`), constrained parameters
(`_reparam`), compiled solves cached in memory (`_compiled`) and on disk (`_compile_cache`).

Imports the curves stage (a model is a `Model`: a `Family` or an `AreaModel`) and nothing
above it.
"""

from ._api import fit as fit
from ._api import fit_dataset as fit_dataset
from ._api import fit_many as fit_many
from ._compile_cache import enable_persistent_cache as enable_persistent_cache
from ._compiled import reuse_results as reuse_results

# For the report stage's combined fit of many families in one solve.
from ._reparam import to_internal as to_internal
from ._reparam import to_param as to_param
from ._result import FitResult as FitResult
from ._result import FitResults as FitResults
from ._validate import LOSSES as LOSSES


def __getattr__(name: str):
    """`SOLVERS`, on first use: the solvers' module imports optimistix, which a fit whose
    result is read from the cache never needs (0.15 s of a warm `attenfit scene`)."""
    if name == "SOLVERS":
        from ._solvers import SOLVERS

        return SOLVERS
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
