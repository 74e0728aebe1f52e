"""Strict JAX for every test: float64 available, no implicit rank or dtype promotion."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")

import jax
import pytest
from hypothesis import HealthCheck, settings

jax.config.update("jax_enable_x64", True)
jax.config.update("jax_numpy_rank_promotion", "raise")
jax.config.update("jax_numpy_dtype_promotion", "strict")

# The test suite draws the same hypothesis examples every run (derandomize), so that a red
# run is reproducible and CI does not turn red by chance; a hunt
# (`ATTENFIT_FUZZ_SCALE=10 pytest tests/test_fuzz.py`, or HYPOTHESIS_PROFILE=hunt) draws
# fresh random examples each time. What a hunt finds becomes a named regression test.
settings.register_profile(
    "default",
    deadline=None,
    max_examples=60,
    derandomize=True,
    suppress_health_check=[HealthCheck.too_slow],
)
settings.register_profile(
    "hunt", deadline=None, max_examples=60, suppress_health_check=[HealthCheck.too_slow]
)
_HUNT = int(os.environ.get("ATTENFIT_FUZZ_SCALE", "1")) > 1
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "hunt" if _HUNT else "default"))


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(config, items):
    """With pytest-xdist (`-n 2 --dist loadgroup`): keep each test module on one worker, so
    its module-scoped fixtures are built once; the docs' pages are independent of each other
    and are spread over the workers. First among the hooks: xdist reads the groups in its own
    `pytest_collection_modifyitems`, and one run after it saw none (every module's tests went
    to both workers, each building the module's fixtures: tests/test_architecture.py checks
    the grouping)."""
    for item in items:
        if item.module.__name__ != "test_docs":
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))
