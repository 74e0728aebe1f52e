"""A compiled solve read from the cache is one exported for the platform that runs it.

Found on a GPU machine: a solve exported for CUDA and cached was read back by a CPU process
(`JAX_PLATFORMS=cpu`), which JAX refuses ("exported for platforms ('cuda',) but it is used
on ('cpu',)"). The cache key names the platform.
"""

import jax
import numpy as np
import pytest

import attenfit as af
from attenfit import _cache
from attenfit._fit import _compiled


class _Read(Exception):
    """Raised by the stand-in cache instead of reading (nothing is read or written)."""


def test_the_cache_key_names_the_platform(monkeypatch):
    keys: list[str] = []

    def read(kind, key):
        keys.append(key)
        raise _Read

    monkeypatch.setattr(_cache, "read", read)
    d = np.geomspace(0.1, 10.0, 16)
    target = 1.0 / (d * d + 0.01)
    for backend in ("cpu", "cuda"):
        monkeypatch.setattr(_compiled, "_COMPILED", {})
        monkeypatch.setattr(jax, "default_backend", lambda b=backend: b)
        with pytest.raises(_Read):
            af.fit(af.Yuksel(), d, target)
    assert len(keys) == 2 and keys[0] != keys[1]
    assert keys[0].endswith("|cpu") and keys[1].endswith("|cuda")
