"""Library calls that set the precision they need, whatever the caller's `jax_enable_x64`."""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import ParamSpec, TypeVar

__all__ = ["in_float64"]

P = ParamSpec("P")
R = TypeVar("R")


def in_float64(fn: Callable[P, R]) -> Callable[P, R]:
    """`fn` run with JAX's float64 enabled (thread-local), as `build_report` runs.

    The scene stage's answers are float64 computations (truth, fits, judging); a caller that
    never set `jax_enable_x64` gets the same answer as the command line, which sets it.
    """

    @functools.wraps(fn)
    def wrapper(*args: P.args, **kwargs: P.kwargs) -> R:
        import jax

        with jax.enable_x64(True):
            return fn(*args, **kwargs)

    return wrapper
