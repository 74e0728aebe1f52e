"""attenfit's cache on disk: where it lives, which code its entries belong to, safe reads.

The cache holds work a later process need not repeat: JAX's compiled executables (`jax/`,
JAX's own persistent compilation cache) and attenfit's entries (`entries/`): traced and
lowered solves (`jax.export`), the families' descriptions. The folder is
`$ATTENFIT_CACHE_DIR` if set, else `$XDG_CACHE_HOME/attenfit`, else `~/.cache/attenfit`.

Every entry belongs to one **code version**: a hash of attenfit's own source files and of
the versions of the libraries that shape what is cached (Python, JAX, jaxlib, equinox,
optimistix, numpy). Entries of another version (another attenfit, another jaxlib) live in
another folder and are never read: a stale cache is ignored and rebuilt, never trusted.

**The cache is untrusted input.** Anything could sit where an entry should be, so an entry
is read only if it is a regular file (not a FIFO, device, socket, folder or symbolic link)
inside the cache folder (no linked subfolder leads out of it), no larger than its kind's
limit (`LIMITS`), with the right header and checksum, and, for the kinds that hold JSON,
of the shape its readers expect (`_SHAPES`). Anything else is ignored with a one-line
notice on stderr and rebuilt: the next write replaces it. A cache that cannot be written
(a read-only folder) is only read. Nothing here ever raises into a caller (an interrupt
aside): a cache is an optimisation.
"""

from __future__ import annotations

import base64
import contextlib
import errno
import functools
import hashlib
import json
import os
import shutil
import stat
import sys
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ._input import read_capped

__all__ = [
    "LIMITS",
    "cached_array",
    "clear",
    "code_version",
    "covers",
    "fingerprint",
    "folder",
    "info",
    "notice",
    "read",
    "read_array",
    "write",
    "write_array",
]

_MAGIC = b"attenfit-cache-1\n"
_LIBRARIES = ("jax", "jaxlib", "equinox", "optimistix", "numpy")
_NOTICED: set[str] = set()

#: The largest entry of each kind (bytes, header included); other kinds: `LIMITS[None]`.
#: Measured: the families' descriptions 9 kB, a compiler's counts 0.2 kB, the compilers'
#: versions 0.2 kB, a traced solve 50-80 kB, an export 1-3 kB, a report's figure (PNG) 40-400
#: kB, the witness section 60 kB, an engine's closest settings 0.3 kB.
LIMITS: dict[str | None, int] = {
    "families": 1 << 20,
    "compilers": 64 << 10,
    "compiled": 64 << 10,
    "worst": 16 << 10,
    "engine-search": 16 << 10,
    "export": 1 << 20,
    "figure": 16 << 20,
    "witness": 4 << 20,
    "result": 16 << 20,
    "values": 16 << 20,
    "solve": 64 << 20,
    None: 64 << 20,
}


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


def fingerprint(*parts: Any) -> str:
    """A hash of `parts`, to key an entry by the inputs of what it holds.

    Walks None, numbers, text, bytes, lists, tuples, dicts (in key order), dataclasses
    (equinox modules among them: type and fields) and arrays (anything with `__array__`:
    dtype, shape and bytes, exactly). Anything else counts by its type and `repr`.
    """
    h = hashlib.sha256()
    _feed(h, parts)
    return h.hexdigest()[:40]


def _feed(h, value: Any) -> None:
    import dataclasses

    if value is None or isinstance(value, bool | int | float | complex | str):
        h.update(f"{type(value).__name__}:{value!r};".encode("utf-8", "surrogatepass"))
    elif isinstance(value, bytes | bytearray):
        h.update(b"bytes:%d;" % len(value) + bytes(value))
    elif isinstance(value, dict):
        h.update(b"dict:%d{" % len(value))
        for k in sorted(value, key=repr):
            _feed(h, k)
            _feed(h, value[k])
        h.update(b"}")
    elif isinstance(value, list | tuple):
        h.update(b"%s:%d[" % (type(value).__name__.encode(), len(value)))
        for v in value:
            _feed(h, v)
        h.update(b"]")
    elif hasattr(value, "__array__"):
        import numpy as np

        a = np.ascontiguousarray(np.asarray(value))
        h.update(f"array:{a.dtype.str}:{a.shape};".encode())
        h.update(a.tobytes() if a.dtype != object else repr(a.tolist()).encode())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(f"{type(value).__module__}.{type(value).__qualname__}(".encode())
        for field in dataclasses.fields(value):
            h.update(field.name.encode() + b"=")
            _feed(h, getattr(value, field.name, None))
        h.update(b")")
    else:
        h.update(f"{type(value).__qualname__}:{value!r};".encode("utf-8", "surrogatepass"))


def _entry(kind: str, key: str) -> Path:
    digest = hashlib.sha256(key.encode("utf-8", "surrogatepass")).hexdigest()[:32]
    return folder() / "entries" / code_version() / kind / f"{digest}.bin"


def notice(message: str) -> None:
    """Say `message` on stderr, once per process (never failing: stderr may be closed)."""
    if message not in _NOTICED:
        _NOTICED.add(message)
        try:
            print(f"attenfit: {message}", file=sys.stderr, flush=True)
        except (OSError, ValueError):
            pass


class _Bad(Exception):
    """An entry that is there but may not be used: the message says why."""


def read(kind: str, key: str) -> bytes | None:
    """The payload cached under (`kind`, `key`) for this code version, or None.

    A missing entry is None; one that may not be used (see the module's docstring) too,
    after a one-line notice.
    """
    path = None
    try:
        path = _entry(kind, key)
        data = _read_entry(path, LIMITS.get(kind, LIMITS[None]))
        if data is None:
            return None
        start = len(_MAGIC)
        checksum, payload = data[start : start + 64], data[start + 65 :]
        if not (
            data.startswith(_MAGIC)
            and data[start + 64 : start + 65] == b"\n"
            and hashlib.sha256(payload).hexdigest().encode() == checksum
        ):
            notice(f"ignoring a corrupt cache entry ({path}); it will be rebuilt")
            return None
        shape = _SHAPES.get(kind)
        if shape is not None:
            why = _check_json(payload, shape)
            if why is not None:
                raise _Bad(f"holds {why}")
        return payload
    except _Bad as exc:
        notice(f"ignoring a cache entry that {exc} ({path}); it will be rebuilt")
    except Exception as exc:  # the cache is an optimisation: never a reason to fail
        notice(f"not using the cache ({type(exc).__name__}: {exc})")
    return None


def _inside(path: Path) -> bool:
    """Whether `path`'s folder is, with every link resolved, inside the cache's folder."""
    root = os.path.realpath(folder())
    return os.path.realpath(path.parent).startswith(root.rstrip(os.sep) + os.sep)


def _read_entry(path: Path, limit: int) -> bytes | None:
    """The bytes of the entry `path` (None if there is none); `_Bad` if it may not be read."""
    try:
        st = os.lstat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISLNK(st.st_mode):
        raise _Bad("is a symbolic link")
    if not stat.S_ISREG(st.st_mode):
        raise _Bad("is not a regular file (a folder, FIFO, device or socket)")
    if not _inside(path):
        raise _Bad("lies outside the cache folder (through a linked folder)")
    if st.st_size > limit:
        raise _Bad(f"is {st.st_size:,} bytes, over the {limit:,} an entry of its kind may be")
    flags = os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_NOFOLLOW", 0) | os.O_CLOEXEC
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        return None
    except OSError as exc:
        why = "is a symbolic link" if exc.errno == errno.ELOOP else "cannot be read"
        raise _Bad(f"{why} ({exc.strerror})") from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):  # replaced since the lstat
            raise _Bad("is not a regular file (a folder, FIFO, device or socket)")
        data = read_capped(fd, limit)
        if len(data) > limit:
            raise _Bad(f"grew past the {limit:,} bytes an entry of its kind may be")
        return data
    except OSError as exc:
        raise _Bad(f"cannot be read ({exc.strerror})") from None
    finally:
        os.close(fd)


def write(kind: str, key: str, payload: bytes) -> bool:
    """Cache `payload` under (`kind`, `key`) atomically; False (silently) if it cannot be.

    Whatever sits where the entry or its folders belong and is not what the cache made
    (a link, a FIFO, a file where a folder belongs) is replaced.
    """
    try:
        path = _entry(kind, key)
        data = _MAGIC + hashlib.sha256(payload).hexdigest().encode() + b"\n" + payload
        if len(data) > LIMITS.get(kind, LIMITS[None]):
            return False  # it could not be read back
        _make_folders(path.parent)
        if not _inside(path):
            return False
        with contextlib.suppress(OSError):  # a folder where the entry belongs
            if stat.S_ISDIR(os.lstat(path).st_mode):
                shutil.rmtree(path)
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=".bin")
        try:
            with os.fdopen(fd, "wb") as f:
                f.write(data)
            os.replace(tmp, path)  # replaces a link, FIFO or socket, never follows it
        finally:
            if os.path.lexists(tmp):
                os.unlink(tmp)
    except Exception:  # OSError (read-only, full, missing home), or anything else: skip it
        return False
    return True


def read_array(kind: str, key: str) -> Any:
    """The float array cached under (`kind`, `key`) as `.npy` bytes (`write_array`), or None;
    an entry that is no float array (read without pickles) is ignored with a notice."""
    import io

    import numpy as np

    payload = read(kind, key)
    if payload is None:
        return None
    try:
        value = np.load(io.BytesIO(payload), allow_pickle=False)
    except (ValueError, OSError, EOFError):
        value = None
    if not isinstance(value, np.ndarray) or value.dtype.kind != "f":
        notice(f"ignoring a cache entry that holds no float array ({kind}); it will be rebuilt")
        return None
    return value


def write_array(kind: str, key: str, value: Any) -> bool:
    """Cache the float array `value` under (`kind`, `key`) as `.npy` bytes (`read_array`)."""
    import io

    import numpy as np

    buf = io.BytesIO()
    np.save(buf, np.asarray(value), allow_pickle=False)
    return write(kind, key, buf.getvalue())


def covers(cls: type) -> bool:
    """Whether the code version covers `cls`: a class of attenfit's own. A user's class can
    change without changing the version, so what it computes is never cached."""
    return cls.__module__.startswith("attenfit.")


def cached_array(
    kind: str,
    parts: tuple[Any, ...],
    compute: Callable[[], Any],
    *,
    shape: tuple[int, ...] | None = None,
) -> Any:
    """The float array `compute()` returns, from the cache when this code version computed it
    for the same `parts` (its exact inputs: `fingerprint`) before; else computed and cached.
    For what is a function of its inputs alone (an exact irradiance at given receivers): an
    unchanged question asked again runs no program for it. An entry not of `shape` (when
    given) is ignored with a notice and rebuilt."""
    import numpy as np

    key = fingerprint(*parts)
    value = read_array(kind, key)
    if value is not None and shape is not None and value.shape != tuple(shape):
        notice(f"ignoring a cache entry of another shape ({kind}); it will be rebuilt")
        value = None
    if value is None:
        value = np.asarray(compute())
        if value.dtype.kind == "f":
            write_array(kind, key, value)
    return value


def _make_folders(target: Path) -> None:
    """Make `target` and the folders between it and the cache's root, replacing any link
    or other non-folder found among them (the root itself is the user's to choose)."""
    root = folder()
    root.mkdir(parents=True, exist_ok=True)
    current = root
    for part in target.relative_to(root).parts:
        current = current / part
        try:
            st = os.lstat(current)
        except FileNotFoundError:
            os.mkdir(current)
            continue
        if not stat.S_ISDIR(st.st_mode):  # a link (to anywhere), a file, a FIFO
            os.unlink(current)
            os.mkdir(current)


# ----------------------------------------------------------------------------- shapes
def _check_json(payload: bytes, shape: Callable[[Any], str | None]) -> str | None:
    """None if `payload` is JSON of the shape `shape` checks, else what is wrong."""
    try:
        value = json.loads(payload.decode("utf-8"))
    except (ValueError, RecursionError):
        return "no valid JSON"
    return shape(value)


def _number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool)


def _families_shape(listing: Any) -> str | None:
    """`attenfit families`' listing: `describe()` of each family and of each area model."""
    if not isinstance(listing, dict) or set(listing) != {"families", "area_models"}:
        return "no listing of families and area models"
    for kind, rows in listing.items():
        if not isinstance(rows, list) or (kind == "families" and not rows):
            return f"no list of {kind.replace('_', ' ')}"
        bad = next(filter(None, map(_model_row, rows)), None)
        if bad is not None:
            return bad
    return None


def _model_row(row: Any) -> str | None:
    """One model's `describe()`: name, formula and source as text, numeric defaults."""
    if not isinstance(row, dict):
        return "a model that is not a JSON object"
    for field in ("name", "formula", "source"):
        if not isinstance(row.get(field), str):
            return f"a model whose {field!r} is not text"
    params = row.get("params")
    if not isinstance(params, dict):
        return f"model {row['name'][:40]!r} without a 'params' object"
    for name, spec in params.items():
        default = spec.get("default") if isinstance(spec, dict) else None
        if not (_number(default) or (isinstance(default, list) and all(map(_number, default)))):
            return f"parameter {name[:40]!r} without a numeric default"
    return None


def _worst_shape(found: Any) -> str | None:
    """A decision table's worst case (`_report._verify.Found`): null, or its error and place."""
    if found is None:
        return None
    if not (
        isinstance(found, dict)
        and _number(found.get("error"))
        and found["error"] >= 0
        and isinstance(found.get("where"), str)
    ):
        return "no worst case"
    return None


def _engine_search_shape(found: Any) -> str | None:
    """An engine's closest settings: {"props": {name: number, bool or text}, "error": number}."""
    if not (isinstance(found, dict) and set(found) == {"props", "error"}):
        return "no engine settings"
    props = found["props"]
    if not isinstance(props, dict) or not all(
        isinstance(k, str) and (isinstance(v, bool | str) or _number(v)) for k, v in props.items()
    ):
        return "settings that are not named numbers"
    if not _number(found["error"]):
        return "an error that is not a number"
    return None


def _compilers_shape(versions: Any) -> str | None:
    """The compilers' versions: tool name -> version text or null."""
    if not isinstance(versions, dict) or not all(
        v is None or isinstance(v, str) for v in versions.values()
    ):
        return "no object of tool versions"
    return None


def _compiled_shape(counts: Any) -> str | None:
    """One compiled program's counts (`attenfit._shaders._compilers.Compiled.to_dict()`)."""
    if not isinstance(counts, dict) or not isinstance(counts.get("tool"), str):
        return "no compiled counts"
    total, classes = counts.get("total"), counts.get("classes")
    if not (isinstance(total, int) and not isinstance(total, bool) and total >= 0):
        return "no operation total"
    if not isinstance(classes, dict) or not all(
        isinstance(v, int) and not isinstance(v, bool) for v in classes.values()
    ):
        return "no operation classes"
    return None


def _export_shape(entry: Any) -> str | None:
    """`attenfit export`'s printed text (`_cli._cmd_export`)."""
    if not (isinstance(entry, dict) and set(entry) == {"text"} and isinstance(entry["text"], str)):
        return "no exported text"
    return None


def _witness_shape(entry: Any) -> str | None:
    """The report's Mitsuba witness (`_report._witness`): its numbers and its figure."""
    if not (isinstance(entry, dict) and isinstance(entry.get("png"), str)):
        return "no witness figure"
    data = entry.get("data")
    if not (
        isinstance(data, dict)
        and isinstance(data.get("variant"), str)
        and all(_number(data.get(k)) for k in ("spp", "seconds", "n", "median_abs_z"))
        and all(_number(data.get(k)) for k in ("max_abs_z", "expected_median_abs_z"))
        and isinstance(data.get("sets"), list)
        and all(map(_witness_set, data["sets"]))
    ):
        return "no witness numbers"
    try:
        base64.b64decode(entry["png"], validate=True)
    except ValueError:
        return "no witness figure"
    return None


def _witness_set(row: Any) -> bool:
    keys = ("n", "median_abs_z", "max_abs_z", "median_rel_stderr")
    return (
        isinstance(row, dict)
        and isinstance(row.get("label"), str)
        and all(_number(row.get(k)) for k in keys)
    )


#: The kinds of entry that hold JSON, and their shape. "solve" holds `jax.export` bytes,
#: which its reader deserialises and rebuilds when JAX cannot read them.
_SHAPES: dict[str, Callable[[Any], str | None]] = {
    "families": _families_shape,
    "compilers": _compilers_shape,
    "compiled": _compiled_shape,
    "worst": _worst_shape,
    "engine-search": _engine_search_shape,
    "export": _export_shape,
    "witness": _witness_shape,
}


# ----------------------------------------------------------------------------- attenfit cache
def _size(path: Path) -> tuple[int, int]:
    """The regular files under the folder `path` and their bytes; links are not followed."""
    files = size = 0
    if not _is_dir(path):
        return 0, 0
    for top, dirs, names in os.walk(path, onerror=lambda exc: None):
        for name in names + dirs:
            with contextlib.suppress(OSError):
                st = os.lstat(os.path.join(top, name))
                if stat.S_ISREG(st.st_mode):
                    files, size = files + 1, size + st.st_size
    return files, size


def _is_dir(path: Path) -> bool:
    """A folder, not a link to one."""
    try:
        return stat.S_ISDIR(os.lstat(path).st_mode)
    except OSError:
        return False


def _subfolders(path: Path) -> list[Path]:
    try:
        return [p for p in sorted(path.iterdir()) if _is_dir(p)] if _is_dir(path) else []
    except OSError:
        return []


def info() -> dict:
    """What the cache holds: its folder, this code version's entries by kind, stale
    versions, and JAX's compilation cache (files, bytes)."""
    root = folder()
    entries = root / "entries"
    current = entries / code_version()
    kinds = {k.name: _size(k) for k in _subfolders(current)}
    stale = {v.name: _size(v) for v in _subfolders(entries) if v != current}
    return {
        "folder": str(root),
        "code_version": code_version(),
        "entries": kinds,
        "stale_versions": stale,
        "jax_compilation_cache": _size(root / "jax"),
    }


def clear() -> tuple[int, int]:
    """Delete the cache (every version's entries and JAX's compilation cache); return the
    (files, bytes) removed. A link in their place is removed, never followed."""
    root = folder()
    removed = (0, 0)
    for sub in ("entries", "jax"):
        path = root / sub
        n, size = _size(path)
        if _is_dir(path):
            shutil.rmtree(path, ignore_errors=True)
        elif os.path.lexists(path):
            with contextlib.suppress(OSError):
                os.unlink(path)
        left, left_size = _size(path)
        removed = (removed[0] + n - left, removed[1] + size - left_size)
    return removed
