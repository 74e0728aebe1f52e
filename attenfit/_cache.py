"""attenfit's cache on disk: where it lives, which code its entries belong to, safe reads.

The cache holds work a later process need not repeat: JAX's compiled executables (`jax/`,
JAX's own persistent compilation cache) and attenfit's entries (`entries/`): traced and
lowered solves (`jax.export`), the families' descriptions. The folder is
`$ATTENFIT_CACHE_DIR` if set, else `$XDG_CACHE_HOME/attenfit`, else `~/.cache/attenfit`.

Every entry belongs to one **code version**: a hash of attenfit's own source files and of
the versions of the libraries that shape what is cached (Python, JAX, jaxlib, equinox,
optimistix, numpy). Entries of another version (another attenfit, another jaxlib) live in
another folder and are never read: a stale cache is ignored and rebuilt, never trusted.
Each entry carries a checksum of its payload; one that does not match (a truncated or
corrupt file) is ignored with a one-line notice and rebuilt. A cache that cannot be written
(a read-only folder) is only read. Nothing here ever raises into a caller: a cache is an
optimisation.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import sys
import tempfile
from pathlib import Path

__all__ = ["clear", "code_version", "folder", "info", "notice", "read", "write"]

_MAGIC = b"attenfit-cache-1\n"
_LIBRARIES = ("jax", "jaxlib", "equinox", "optimistix", "numpy")
_NOTICED: set[str] = set()


def folder() -> Path:
    """The cache's root folder (it may not exist yet)."""
    env = os.environ.get("ATTENFIT_CACHE_DIR")
    if env:
        return Path(env)
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "attenfit"


@functools.cache
def code_version() -> str:
    """A hash of attenfit's source files and of the library versions it runs with."""
    from importlib import metadata

    h = hashlib.sha256()
    package = Path(__file__).resolve().parent
    for path in sorted(package.rglob("*.py")):
        h.update(str(path.relative_to(package)).encode())
        h.update(path.read_bytes())
    h.update(sys.version.encode())
    for name in _LIBRARIES:
        try:
            h.update(f"{name}={metadata.version(name)}".encode())
        except metadata.PackageNotFoundError:
            h.update(f"{name}=none".encode())
    return h.hexdigest()[:20]


def _entry(kind: str, key: str) -> Path:
    digest = hashlib.sha256(key.encode()).hexdigest()[:32]
    return folder() / "entries" / code_version() / kind / f"{digest}.bin"


def notice(message: str) -> None:
    """Say `message` on stderr, once per process."""
    if message not in _NOTICED:
        _NOTICED.add(message)
        print(f"attenfit: {message}", file=sys.stderr, flush=True)


def read(kind: str, key: str) -> bytes | None:
    """The payload cached under (`kind`, `key`) for this code version, or None.

    A missing entry is None; an unreadable or corrupt one too, after a one-line notice.
    """
    path = _entry(kind, key)
    try:
        data = path.read_bytes()
    except OSError:
        return None
    start = len(_MAGIC)
    checksum, payload = data[start : start + 64], data[start + 65 :]
    if data.startswith(_MAGIC) and hashlib.sha256(payload).hexdigest().encode() == checksum:
        return payload
    notice(f"ignoring a corrupt cache entry ({path}); it will be rebuilt")
    return None


def write(kind: str, key: str, payload: bytes) -> bool:
    """Cache `payload` under (`kind`, `key`) atomically; False (silently) if it cannot be."""
    path = _entry(kind, key)
    data = _MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".bin")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    except OSError:
        return False
    return True


def _size(path: Path) -> tuple[int, int]:
    files = [p for p in path.rglob("*") if p.is_file()] if path.is_dir() else []
    return len(files), sum(p.stat().st_size for p in files)


def info() -> dict:
    """What the cache holds: its folder, this code version's entries by kind, stale
    versions, and JAX's compilation cache (files, bytes)."""
    root = folder()
    entries = root / "entries"
    current = entries / code_version()
    kinds = {}
    if current.is_dir():
        kinds = {k.name: _size(k) for k in sorted(current.iterdir()) if k.is_dir()}
    stale = {}
    if entries.is_dir():
        stale = {v.name: _size(v) for v in sorted(entries.iterdir()) if v != current}
    return {
        "folder": str(root),
        "code_version": code_version(),
        "entries": kinds,
        "stale_versions": stale,
        "jax_compilation_cache": _size(root / "jax"),
    }


def clear() -> tuple[int, int]:
    """Delete the cache (every version's entries and JAX's compilation cache); return the
    (files, bytes) removed."""
    root = folder()
    removed = (0, 0)
    for sub in ("entries", "jax"):
        path = root / sub
        n, size = _size(path)
        shutil.rmtree(path, ignore_errors=True)
        removed = (removed[0] + n, removed[1] + size)
    return removed
