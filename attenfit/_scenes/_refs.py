"""Files a scene references (glTF buffers and images; USD layers and assets), resolved inside
the scene's folder or refused.

A scene file names other files: a glTF's `buffers[k].uri` and `images[k].uri`, a USD layer's
sublayers and references. A hostile scene can name anything: `/etc/passwd`,
`../../secret.txt`, `/proc/self/environ`, `file:///home/me/.ssh/id_rsa`, a FIFO that blocks
the reader, `/dev/zero` that never ends, or one 250 MB file forty times. `SceneFolder` is the
one place that decides what a reference may name:

* the **scene's folder** is the folder holding the root file, symbolic links resolved
  (a scene reached through a link reads beside its real file);
* a reference is a path (`buffers/room.bin`, `a/../b.bin`; relative to the scene's folder)
  or a `file:` URI; as a URI (glTF) it is percent-decoded (`my%20room.bin`); a query, a
  fragment, another scheme (`http:`, `C:`) or a NUL byte is refused;
* it must resolve, symbolic links followed, to a path **inside** the scene's folder (an
  absolute path or `file:` URI may name one there): `..` that climbs out, an absolute path
  elsewhere, or a link inside the folder pointing out are refused with one line naming the
  reference;
* the file is checked before it is opened (`check`): a regular file (not a FIFO, device,
  socket or folder: opened without blocking), at most its kind's size limit; each distinct
  file is counted once (`total`, for the memory budget) and read once (`read`);
* a `data:` URI (`data_bytes`) is decoded with the same size limit, refused before decoding
  when its text says it would be larger.

Messages say which reference ("buffers[2].uri '../../etc/passwd'") and why.
"""

from __future__ import annotations

import base64
import binascii
import os
import re
from pathlib import Path
from urllib.parse import unquote, unquote_to_bytes, urlsplit

from .._errors import DataFileError
from .._input import check_file, read_bytes

__all__ = ["SceneFolder", "data_bytes", "data_size", "is_data_uri"]

_SCHEME = re.compile(r"^([A-Za-z][A-Za-z0-9+.-]*):")


def _show(ref: str, n: int = 80) -> str:
    """`ref` quoted for a one-line message, cut at `n` characters."""
    return repr(ref if len(ref) <= n else ref[:n] + "...")


def is_data_uri(uri: str) -> bool:
    """Whether `uri` is a `data:` URI (RFC 2397)."""
    return uri[:5].lower() == "data:"


def _split_data(uri: str, where: str) -> tuple[str, bool, str]:
    head, comma, payload = uri[5:].partition(",")
    if not comma:
        raise DataFileError(f"{where}: a data: URI without a ',' before its data")
    params = head.split(";")
    return params[0], params[-1].lower() == "base64", payload


def data_size(uri: str, where: str) -> int:
    """The bytes the `data:` URI `uri` decodes to (at most), from its text alone."""
    _, b64, payload = _split_data(uri, where)
    if not b64:
        return len(payload)
    return max((len(payload) * 3) // 4 - len(payload[-2:]) + len(payload[-2:].rstrip("=")), 0)


def data_bytes(uri: str, where: str, limit: int) -> bytes:
    """The bytes of the `data:` URI `uri` (base64 or percent-encoded), at most `limit` of
    them: refused before decoding when its text is longer than that allows."""
    _, b64, payload = _split_data(uri, where)
    if data_size(uri, where) > limit:
        raise DataFileError(
            f"{where}: a data: URI of {data_size(uri, where):,} bytes, over the {limit:,} an "
            "input of its kind may be"
        )
    if not b64:
        return unquote_to_bytes(payload)
    try:
        return base64.b64decode(payload.encode("ascii"), validate=True)
    except (binascii.Error, UnicodeEncodeError, ValueError):
        raise DataFileError(f"{where}: a data: URI whose base64 is malformed") from None


class SceneFolder:
    """The folder of the scene file `root`, and the files its references name.

    `what` names the scene in messages (its file name). `resolve` turns a reference into a
    path inside the folder (or refuses it); `check` also checks the file and counts its size;
    `read` reads a checked file (each distinct file once).
    """

    def __init__(self, root: str | os.PathLike, what: str):
        self.root = Path(root)
        self.what = what
        self.folder = Path(os.path.realpath(self.root)).parent
        self._sizes: dict[Path, int] = {}
        self._data: dict[Path, bytes] = {}

    def resolve(self, ref: str, where: str, *, uri: bool = True) -> Path:
        """The real path that `ref` (a relative path or `file:` URI; percent-encoded when
        `uri`) names, inside the scene's folder; a one-line `DataFileError` naming `where`
        and `ref` otherwise."""
        head = f"{self.what}: {where} {_show(ref)}"
        if not isinstance(ref, str) or not ref:
            raise DataFileError(f"{self.what}: {where}: must be a non-empty path, got {ref!r}")
        text = ref
        m = _SCHEME.match(text)
        scheme = m.group(1).lower() if m else None
        if scheme == "file":
            parts = urlsplit(text)
            if parts.netloc not in ("", "localhost"):
                raise DataFileError(f"{head}: names a file on another host ({parts.netloc!r})")
            if parts.query or parts.fragment:
                raise DataFileError(f"{head}: a file: URI with a query or fragment")
            text, uri = parts.path, True
        elif scheme is not None and len(scheme) == 1:
            raise DataFileError(f"{head}: a Windows path; use a path relative to the scene")
        elif scheme is not None:
            raise DataFileError(
                f"{head}: a {scheme}: URI; a scene may reference files in its own folder only"
            )
        elif uri and ("?" in text or "#" in text):
            raise DataFileError(f"{head}: a URI with a query or fragment; percent-encode '?', '#'")
        if uri:
            try:
                text = unquote(text, errors="strict")
            except UnicodeDecodeError:
                raise DataFileError(f"{head}: percent-encodes bytes that are not UTF-8") from None
        if "\x00" in text:
            raise DataFileError(f"{head}: holds a NUL character")
        try:
            os.fsencode(text)
        except UnicodeEncodeError:
            raise DataFileError(f"{head}: not a file name this system can open") from None
        real = Path(os.path.realpath(self.folder / text))
        if real == self.folder:
            raise DataFileError(f"{head}: names the scene's folder, not a file in it")
        if self.folder not in real.parents:
            raise DataFileError(
                f"{head}: resolves to {str(real)!r}, outside the scene's folder "
                f"{str(self.folder)!r}; a scene may reference files in its own folder only"
            )
        return real

    def check(self, ref: str, where: str, limit: int, *, uri: bool = True) -> Path:
        """`resolve(ref)`, then the file checked before it is opened: a regular file (not a
        FIFO, device, socket or folder; opened without blocking) of at most `limit` bytes.
        Each distinct file is counted once in `total()`."""
        real = self.resolve(ref, where, uri=uri)
        if real not in self._sizes:
            what = f"{self.what}: {where} {_show(ref)}"
            self._sizes[real] = check_file(real, what, limit)
        return real

    def total(self) -> int:
        """The bytes of the distinct files checked so far (each read at most once)."""
        return sum(self._sizes.values())

    def read(self, real: Path, ref: str, where: str, limit: int) -> bytes:
        """The bytes of `real`, a path `check` returned (read once, however many references
        name it)."""
        if real not in self._sizes:
            raise DataFileError(f"{self.what}: {where} {_show(ref)}: not checked before reading")
        if real not in self._data:
            self._data[real] = read_bytes(real, f"{self.what}: {where} {_show(ref)}", limit)
        return self._data[real]
