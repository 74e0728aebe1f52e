"""Input files read without hanging, exhausting memory or overflowing the stack.

Every file attenfit reads goes through `read_bytes`: it opens without blocking (a FIFO
would wait forever for a writer), accepts only a regular file (not `/dev/zero`, a socket or
a folder), and refuses one larger than the limit for its kind before reading a byte.
Parsed text is checked for nesting before it reaches a recursive parser: no scene, fit
file or header needs more than `MAX_DEPTH` levels, and TOML's dotted keys are bounded too
(`tomllib` takes quadratic time and memory in a key's length: 8,000 segments take 1 s).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import re
import stat
import tomllib
import zipfile
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ._errors import DataFileError

if TYPE_CHECKING:
    import numpy as np

__all__ = [
    "LIMITS",
    "MAX_DEPTH",
    "check_file",
    "declare",
    "inputs",
    "load_json",
    "load_toml",
    "read_bytes",
    "read_capped",
    "read_npz",
    "read_text",
    "text_name",
]

#: Size limits per kind of input (bytes). A real scene file is a few kB (a list of 4,096
#: receiver points, the most a scene takes, is about 200 kB); a fit file is a few kB a fit.
LIMITS = {
    "scene": 4 << 20,
    "fits": 64 << 20,
    "json": 64 << 20,
    "source": 1 << 20,
    # USD and glTF scenes with their meshes (and a glTF's .bin buffers), per file
    "mesh_scene": 256 << 20,
}
#: The deepest nesting of arrays and tables any attenfit input has is 4; 32 is generous.
MAX_DEPTH = 32


def _mib(n: int) -> str:
    return f"{n / (1 << 20):.3g} MiB" if n >= 1 << 20 else f"{n:,} bytes"


def text_name(path: str | os.PathLike) -> str:
    """`path` as text that any UTF-8 file can hold: its bytes decoded as UTF-8, those that are
    not as `\\xNN`. (Under an ASCII locale Python names `Küche.npz` 'K\\udcc3\\udcbcche.npz',
    which no UTF-8 file can hold; its bytes are UTF-8: `Küche.npz`.)"""
    return os.fsencode(path).decode("utf-8", "backslashreplace")


def read_capped(fd: int, limit: int) -> bytes:
    """At most `limit + 1` bytes from the open file `fd`, read a MiB at a time: more than
    `limit` of them says the file is (or grew) over it, and no more is read."""
    chunks, total = [], 0
    while total <= limit and (chunk := os.read(fd, min(1 << 20, limit + 1 - total))):
        chunks.append(chunk)
        total += len(chunk)
    return b"".join(chunks)


def read_bytes(path: str | os.PathLike, what: str, limit: int) -> bytes:
    """The bytes of the regular file `path`, at most `limit` of them.

    `what` names the file in messages (e.g. "scene file 'room.toml'"). Raises
    `DataFileError` for a missing, unreadable or special file (FIFO, device, folder) and
    for one over `limit`, before reading it.
    """
    fd = _open_regular(Path(path), what)
    try:
        _check_size(os.fstat(fd).st_size, what, limit)
        data = read_capped(fd, limit)
        if len(data) > limit:  # grew while read
            raise DataFileError(f"{what} grew past {_mib(limit)} while being read")
        return data
    except OSError as exc:
        raise DataFileError(f"{what} cannot be read: {exc.strerror}") from None
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike, what: str, limit: int) -> str:
    """`read_bytes` decoded as UTF-8 (a `DataFileError` if it is not)."""
    try:
        return read_bytes(path, what, limit).decode("utf-8")
    except UnicodeDecodeError:
        raise DataFileError(f"{what} is not UTF-8 text") from None


# Strings (JSON; TOML basic, literal and multi-line) and TOML comments, blanked before
# the structure is scanned so that brackets and dots inside them do not count.
_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"', re.S)
_TOML_STRING = re.compile(
    r'"""(?:[^\\]|\\.)*?"""|\'\'\'.*?\'\'\'|"(?:[^"\\\n]|\\.)*"|\'[^\'\n]*\'|#[^\n]*', re.S
)
_SEGMENT = r'(?:[A-Za-z0-9_-]+|"")'
_DOTTED = re.compile(rf"{_SEGMENT}(?:[ \t]*\.[ \t]*{_SEGMENT}){{{MAX_DEPTH},}}")


def _depth(structure: str) -> int:
    """The deepest nesting of `[`/`{` in `structure` (strings already blanked)."""
    import numpy as np  # here, not on import: the CLI's start (and its signal handlers) waits

    b = np.frombuffer(structure.encode("utf-8", "replace"), np.uint8)
    step = np.isin(b, (ord("["), ord("{"))).astype(np.int32) - np.isin(b, (ord("]"), ord("}")))
    return int(np.cumsum(step).max(initial=0))


def _check_depth(structure: str, what: str) -> None:
    depth = _depth(structure)
    if depth > MAX_DEPTH:
        raise DataFileError(
            f"{what} nests arrays or tables {depth} deep; attenfit reads at most {MAX_DEPTH}"
        )


def load_json(text: str, what: str) -> Any:
    """`json.loads(text)`, refusing nesting deeper than `MAX_DEPTH` before parsing."""
    _check_depth(_JSON_STRING.sub('""', text), what)
    try:
        return json.loads(text)
    except (json.JSONDecodeError, RecursionError) as exc:
        raise DataFileError(f"{what} is not valid JSON: {exc}") from None


def load_toml(text: str, what: str) -> dict[str, Any]:
    """`tomllib.loads(text)`, refusing nesting or dotted keys deeper than `MAX_DEPTH` first."""
    structure = _TOML_STRING.sub('""', text)
    _check_depth(structure, what)
    if m := _DOTTED.search(structure):
        raise DataFileError(
            f"{what} has a dotted key of {m.group().count('.') + 1} parts "
            f"(starting {m.group()[:20]!r}); attenfit reads at most {MAX_DEPTH}"
        )
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise DataFileError(f"{what}: TOML syntax error: {exc}") from None
    except RecursionError:
        raise DataFileError(f"{what} nests too deeply to read") from None


# ----------------------------------------------------------------------------- npz archives
#: The dtypes an attenfit archive holds: floats (either byte order) and the header's text.
_NPZ_KINDS = {"f": (4, 8), "U": None}
_NPY_HEADERS = {(1, 0): "read_array_header_1_0", (2, 0): "read_array_header_2_0"}


def _open_regular(path: Path, what: str) -> int:
    """A file descriptor of the regular file `path`, never blocking (a FIFO would), recorded
    in `inputs()`. Raises `DataFileError` for a missing, unreadable or special file."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise DataFileError(f"{what} does not exist") from None
    except IsADirectoryError:
        raise DataFileError(f"{what} is a folder, not a file") from None
    except OSError as exc:
        raise DataFileError(f"{what} cannot be read: {exc.strerror}") from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        if stat.S_ISDIR(st.st_mode):
            raise DataFileError(f"{what} is a folder, not a file")
        raise DataFileError(f"{what} is not a regular file (a pipe, device or socket)")
    if _INPUTS is not None:
        _INPUTS.add(os.path.realpath(path))
    return fd


#: The files the running command has read (real paths), inside `tracking()`; else None.
_INPUTS: set[str] | None = None


@contextlib.contextmanager
def tracking() -> Iterator[None]:
    """Record the files read inside the block: one command's inputs, which its outputs
    may not replace (`inputs()`; the CLI runs each verb inside one)."""
    global _INPUTS
    saved, _INPUTS = _INPUTS, set()
    try:
        yield
    finally:
        _INPUTS = saved


def declare(paths: Iterable[str | os.PathLike]) -> None:
    """Count `paths` as inputs of the running command before it reads them (the CLI declares
    its file arguments, so an output that would replace one is refused before any work)."""
    if _INPUTS is not None:
        _INPUTS.update(os.path.realpath(p) for p in paths)


def inputs() -> frozenset[str]:
    """The real paths of the files the running command has read (empty outside `tracking`)."""
    return frozenset(_INPUTS or ())


def check_file(path: str | os.PathLike, what: str, limit: int) -> int:
    """The size of the regular file `path`, checked as `read_bytes` checks it (missing,
    special or over `limit`: `DataFileError`), for a file a library then opens by name."""
    fd = _open_regular(Path(path), what)
    try:
        size = os.fstat(fd).st_size
    finally:
        os.close(fd)
    _check_size(size, what, limit)
    return size


def _check_size(size: int, what: str, limit: int) -> None:
    if size > limit:
        raise DataFileError(
            f"{what} is {_mib(size)}, over the {_mib(limit)} an input of its kind may be"
        )


def read_npz(
    path: str | os.PathLike,
    what: str,
    limit: int,
    noun: str = ".npz archive",
    names: tuple[str, ...] | None = None,
) -> dict[str, np.ndarray]:
    """The arrays of the `.npz` archive `path` (those in `names`, if given), checked before
    any is allocated.

    Accepts only float32/float64 arrays (converted to the machine's byte order) and text;
    refuses an archive whose members declare more than `limit` bytes in all, or whose
    arrays' headers disagree with their members' declared sizes (a zip bomb, a truncated or
    doctored member), with a `DataFileError` saying "`what` is not a readable `noun`".
    """
    fd = _open_regular(Path(path), what)
    with os.fdopen(fd, "rb") as fh:
        if fh.read(4) != b"PK\x03\x04":  # np.load would call other bytes a pickle
            raise DataFileError(f"{what} is not a readable {noun}: not a zip archive")
        fh.seek(0)
        try:
            archive = zipfile.ZipFile(fh)
        except (zipfile.BadZipFile, OSError, ValueError) as exc:
            raise DataFileError(f"{what} is not a readable {noun}: {exc}") from None
        with archive:
            members = archive.infolist()
            if names is not None:
                members = [m for m in members if m.filename.removesuffix(".npy") in names]
            total = sum(m.file_size for m in members)
            if total > limit:
                raise DataFileError(
                    f"{what} unpacks to {_mib(total)}, over the {_mib(limit)} allowed "
                    "(the memory budget, ATTENFIT_MEMORY_BUDGET)"
                )
            return {
                m.filename.removesuffix(".npy"): _read_member(
                    archive, m, f"{what}, member {m.filename!r}", noun
                )
                for m in members
            }


def _read_member(archive: zipfile.ZipFile, m: zipfile.ZipInfo, where: str, noun: str) -> np.ndarray:
    import numpy as np

    try:
        with archive.open(m) as f:
            version = np.lib.format.read_magic(f)
            if version not in _NPY_HEADERS:
                raise DataFileError(f"{where} has .npy format version {version}; reads 1.0, 2.0")
            shape, fortran, dtype = getattr(np.lib.format, _NPY_HEADERS[version])(f)
            if dtype.hasobject or dtype.kind not in _NPZ_KINDS:
                raise DataFileError(f"{where} holds {dtype} values; attenfit reads float arrays")
            sizes = _NPZ_KINDS[dtype.kind]
            if sizes is not None and dtype.itemsize not in sizes:
                raise DataFileError(f"{where} holds {dtype}; attenfit reads float32 and float64")
            count = math.prod(shape)
            if count * dtype.itemsize + f.tell() != m.file_size:
                raise DataFileError(
                    f"{where} declares {shape} {dtype} values, which do not fill its "
                    f"{m.file_size:,} bytes"
                )
            data = f.read(count * dtype.itemsize)
    except DataFileError:
        raise
    except Exception as exc:  # a damaged member raises anything (zlib.error, EOFError, ...)
        raise DataFileError(
            f"{where.split(', member')[0]} is not a readable {noun}: {type(exc).__name__}: {exc} "
            f"(member {m.filename!r})"
        ) from None
    if len(data) != count * dtype.itemsize:
        raise DataFileError(f"{where} is truncated")
    arr = np.frombuffer(data, dtype=dtype).reshape(shape, order="F" if fortran else "C")
    return arr.astype(dtype.newbyteorder("="), copy=False)
