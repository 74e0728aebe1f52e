"""JAX's persistent compilation cache, in attenfit's cache folder (`attenfit._cache`), `jax/`.

A fresh process re-compiles every solve (about 1-3 s each); with the cache on disk a later
process loads the compiled executables instead. See JAX's "Persistent compilation cache".

Two settings differ from JAX's defaults:

* every program is kept, however quick its compile (`jax_persistent_cache_min_compile_time_secs`
  0; JAX's default is 1 s): a scene runs about 50 small programs (shading, the truth,
  conversions) whose compiles add up to more than loading them (docs/performance.md has the
  measurement);
* XLA's own GPU caches stay off (`jax_persistent_cache_enable_xla_caches` "none"): JAX turns
  one on by default, and its folder, an absolute path under the cache folder, then enters
  every program's cache key, so a cache copied or moved elsewhere (a CI cache, another home
  folder) matched nothing and everything was compiled again. attenfit runs on the CPU, where
  those caches do nothing.
"""

from __future__ import annotations

import os
from pathlib import Path

import jax

from .. import _cache

__all__ = ["enable_persistent_cache"]

_ENABLED: list[str] = []
#: Programs whose compile took less are not kept (0: every one; see the module docstring).
MIN_COMPILE_SECONDS = 0.0


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
    try:  # keys free of `folder` (a JAX without the option has no such caches either)
        jax.config.update("jax_persistent_cache_enable_xla_caches", "none")
    except AttributeError:
        pass
    jax.config.update("jax_persistent_cache_min_compile_time_secs", MIN_COMPILE_SECONDS)
    jax.config.update("jax_persistent_cache_min_entry_size_bytes", 0)
    _ENABLED.append(str(folder))
    return folder
