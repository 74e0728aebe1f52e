"""JAX's persistent compilation cache, in attenfit's cache folder (`attenfit._cache`), `jax/`.

A fresh process re-compiles every solve (about 1-3 s each); with the cache on disk a later
process loads the compiled executables instead. See JAX's "Persistent compilation cache".
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

from .. import _cache

__all__ = ["enable_persistent_cache"]

_ENABLED: list[str] = []


def enable_persistent_cache(path: str | os.PathLike | None = None) -> Path | None:
    """Turn on JAX's persistent compilation cache (idempotent); return its folder or None.

    The folder is `path`, else `jax/` in attenfit's cache folder. Silently does nothing
    (returns None) when it cannot be created: a cache is an optimisation, never a reason to
    fail.
    """
    if _ENABLED:
        return Path(_ENABLED[0])
    folder = Path(path) if path is not None else _cache.folder() / "jax"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError:
        return None
    if not os.access(folder, os.W_OK):
        return None
    jax.config.update("jax_compilation_cache_dir", str(folder))
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 0.2)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    _ENABLED.append(str(folder))
    return folder
