"""JAX's persistent compilation cache, under ``~/.cache/attenfit/jax`` (the CLI turns it on).

A fresh process re-compiles every solve (about 1-3 s each); with the cache on disk a
second `attenfit fit` run loads the compiled executables instead. The folder is
``$ATTENFIT_CACHE_DIR`` if set, else ``$XDG_CACHE_HOME/attenfit/jax``, else
``~/.cache/attenfit/jax``. See JAX's "Persistent compilation cache" documentation.
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

__all__ = ["enable_persistent_cache"]

_ENABLED: list[str] = []


def enable_persistent_cache(path: str | os.PathLike | None = None) -> Path | None:
    """Turn on JAX's persistent compilation cache (idempotent); return its folder or None.

    Silently does nothing (returns None) when the folder cannot be created: a cache is an
    optimisation, never a reason to fail.
    """
    if _ENABLED:
        return Path(_ENABLED[0])
    if path is None:
        env = os.environ.get("ATTENFIT_CACHE_DIR")
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        path = env or str(Path(base) / "attenfit" / "jax")
    folder = Path(path)
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
