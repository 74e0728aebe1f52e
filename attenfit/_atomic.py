"""Atomic output: nothing attenfit writes is ever half-written or silently overwritten.

Every file goes to a temporary name in its destination folder and is renamed into place
when complete (`os.replace` is atomic on one filesystem); a folder is built under a
temporary name and moved into place the same way.
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

from . import _input
from ._errors import BadValueError, OutputExistsError

__all__ = [
    "atomic_dir",
    "atomic_write",
    "check_distinct",
    "check_output_path",
    "check_own_output",
]

_TMP_MARK = ".attenfit-tmp"


class Interrupted(KeyboardInterrupt):
    """SIGINT or SIGTERM arrived (raised by the CLI's handlers, and again at a commit point)."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


#: Signals the CLI's handlers received. Once one has, nothing more is committed: an
#: exception raised by a handler inside a callback (e.g. a garbage-collection hook) is
#: swallowed by Python, so every rename into place checks this first.
PENDING: list[int] = []


class _Signals:
    """What the CLI's SIGINT/SIGTERM handler may do now, for one command (`cli.main`).

    * `active`: the command is running inside `main`'s handling of `Interrupted`; outside it
      (before, after) a signal is only recorded.
    * `raised`: one `Interrupted` is on its way up; further signals (a storm of Ctrl-C) are
      only recorded, so none can land in the clean-up or in the one-line message and escape
      as a traceback. Python swallowing the one raised (in a callback) re-arms it (`rearm`).
    * `final`: the command has begun committing one of its declared outputs (`outputs`, the
      real paths of `--out` and `--write-back`): from there on it completes, so that outputs
      are all or nothing, and signals are only recorded.
    """

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.active = self.raised = self.final = False
        self.outputs: frozenset[str] = frozenset()
        PENDING.clear()


SIGNALS = _Signals()


def on_signal(signum: int) -> None:
    """The CLI's SIGINT and SIGTERM handler: record the signal, and raise `Interrupted` if
    the command may still stop (see `_Signals`)."""
    PENDING.append(signum)
    state = SIGNALS
    if state.active and not state.raised and not state.final:
        state.raised = True
        raise Interrupted(signum)


def rearm() -> None:
    """Python swallowed the `Interrupted` a handler raised: let the next signal raise."""
    SIGNALS.raised = False


def declare_outputs(paths: Iterable[str | os.PathLike]) -> None:
    """The running command's outputs: committing any of them is the point of no return."""
    SIGNALS.outputs = frozenset(os.path.realpath(p) for p in paths)


def check_pending() -> None:
    """Raise `Interrupted` if a SIGINT or SIGTERM arrived (see `PENDING`), unless the command
    is already committing its outputs."""
    if PENDING and not SIGNALS.final:
        SIGNALS.raised = True
        raise Interrupted(PENDING[0])


def _commit_point(path: Path) -> None:
    """Right before the rename that puts `path` in place: stop if a signal arrived; if
    `path` is one of the command's outputs, pass the point of no return (a signal from now
    on is recorded, not raised, and the command completes: all its outputs, or, had the
    signal come a moment earlier, none)."""
    check_pending()
    if SIGNALS.outputs and os.path.realpath(path) in SIGNALS.outputs:
        SIGNALS.final = True


def _umask() -> int:
    """The process's umask (read by setting and restoring it)."""
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def check_output_path(
    path: str | os.PathLike,
    *,
    force: bool = False,
    folder: bool = False,
    inputs: Iterable[str | os.PathLike] = (),
) -> Path:
    """Validate an output path before any work starts; return it as a `Path`.

    Refuses (with `OutputExistsError`) an existing file, or an existing non-empty folder
    when `folder=True`, unless `force`; refuses (with `BadValueError`) a path whose
    parent is missing, is a file, or is not writable, and one that is, holds or lies
    inside an input: a file the running command has read (`attenfit._input.inputs()`) or
    one of `inputs`.
    """
    path = Path(path)
    if path.is_symlink():  # write through the link to what it names (and never replace it)
        path = Path(os.path.realpath(path))
    _check_not_input(path, folder, inputs)
    parent = path.parent if str(path.parent) else Path(".")
    for ancestor in [parent, *parent.parents]:
        if ancestor.exists() and not ancestor.is_dir():
            raise BadValueError(
                f"output path {str(path)!r} sits under {str(ancestor)!r}, which is a file"
            )
    if not parent.exists():
        if not folder:
            raise BadValueError(f"output folder {str(parent)!r} does not exist (for {str(path)!r})")
        # a report folder's parents are created on commit: the first that exists must let us
        base = next((a for a in parent.parents if a.exists()), Path("."))
        if not os.access(base, os.W_OK | os.X_OK):
            raise BadValueError(f"output folder {str(base)!r} is not writable (for {str(path)!r})")
        return path
    if not os.access(parent, os.W_OK):
        raise BadValueError(f"output folder {str(parent)!r} is not writable")
    if path.exists():
        if folder:
            if not path.is_dir():
                raise BadValueError(f"output {str(path)!r} exists and is a file, not a folder")
            if any(path.iterdir()) and not force:
                raise OutputExistsError(f"output folder {str(path)!r} exists and is not empty")
        else:
            if path.is_dir():
                raise BadValueError(f"output {str(path)!r} is a folder, not a file")
            if not force:
                raise OutputExistsError(f"output file {str(path)!r} exists", "overwrite it")
    return path


def _check_not_input(path: Path, folder: bool, extra: Iterable[str | os.PathLike] = ()) -> None:
    """Refuse an output that is, holds or lies inside a file this command reads (its real
    path, or the same file under another name: a hard link), with or without `force`."""
    out = os.path.realpath(path)
    srcs = _input.inputs() | {os.path.realpath(p) for p in extra}
    inside = out.rstrip(os.sep) + os.sep
    try:
        same = os.stat(out) if os.path.lexists(out) else None
    except OSError:
        same = None
    for src in sorted(srcs):
        if src == out:
            what = "is"
        elif src.startswith(inside):
            what = "holds"
        elif out.startswith(src.rstrip(os.sep) + os.sep):
            what = "lies inside"
        elif same is not None and not folder and _same_file(same, src):
            what = "is (a hard link to)"
        else:
            continue
        raise BadValueError(
            f"output {str(path)!r} {what} an input of this command ({src!r}); "
            "write the output elsewhere"
        )


def _same_file(st: os.stat_result, src: str) -> bool:
    try:
        other = os.stat(src)
    except OSError:
        return False
    return (st.st_dev, st.st_ino) == (other.st_dev, other.st_ino)


def check_own_output(
    path: str | os.PathLike, *, folder: bool = False, marks: Iterable[str | bytes] = ()
) -> None:
    """Refuse (before `force` replaces it) an existing output that attenfit did not write:
    a non-empty folder holding none of the files `marks` names, or a file (a regular one)
    containing none of the byte strings `marks`. Missing outputs and empty folders pass."""
    path = Path(os.path.realpath(path))
    marks = list(marks)
    if folder:
        if not path.is_dir() or not any(path.iterdir()):
            return
        if any((path / str(m)).is_file() for m in marks):
            return
        raise BadValueError(
            f"output folder {str(path)!r} was not written by attenfit (it holds none of "
            f"{', '.join(map(str, marks))}); --force replaces only attenfit's own outputs"
        )
    if not os.path.lexists(path):
        return
    want = [m.encode() if isinstance(m, str) else m for m in marks]
    if not _holds_mark(path, want):
        raise BadValueError(
            f"output file {str(path)!r} was not written by attenfit; --force replaces only "
            "attenfit's own outputs"
        )


#: How much of an existing output `check_own_output` reads looking for attenfit's mark.
_MARK_SCAN = 1 << 30


def _holds_mark(path: Path, marks: list[bytes]) -> bool:
    """Whether the regular file `path` contains one of `marks` in its first `_MARK_SCAN`
    bytes (read without blocking, in chunks; a FIFO, device or folder holds none)."""
    import stat

    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError:
        return False
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            return False
        keep, tail, left = max((len(m) for m in marks), default=1), b"", _MARK_SCAN
        while left > 0 and (chunk := os.read(fd, min(1 << 20, left))):
            left -= len(chunk)
            data = tail + chunk
            if any(m in data for m in marks):
                return True
            tail = data[-keep:]
        return False
    finally:
        os.close(fd)


def check_distinct(outputs: dict[str, str | os.PathLike | None]) -> None:
    """Refuse two outputs of one command (`{"--out": DIR, "--write-back": FILE}`) that name
    the same path or where one lies inside the other: the second would replace the first."""
    given = [(k, str(v), os.path.realpath(v)) for k, v in outputs.items() if v is not None]
    for i, (k1, v1, r1) in enumerate(given):
        for k2, v2, r2 in given[i + 1 :]:
            if r1 == r2:
                raise BadValueError(
                    f"{k1} {v1!r} and {k2} {v2!r} name the same path; give each its own"
                )
            for (ka, va, ra), (kb, vb, rb) in (((k1, v1, r1), (k2, v2, r2)), ((k2, v2, r2), (k1, v1, r1))):  # fmt: skip
                if ra.startswith(rb.rstrip(os.sep) + os.sep):
                    raise BadValueError(
                        f"{ka} {va!r} lies inside {kb} {vb!r}, which is written as a whole; "
                        "give it a path outside"
                    )


def atomic_write(
    path: str | os.PathLike,
    data: bytes | str | Callable[[Path], None],
    *,
    force: bool = False,
) -> Path:
    """Write `data` to `path` atomically.

    `data` is bytes, text, or a callable that writes the file at the temporary path it is
    given (e.g. `lambda p: np.savez(p, ...)`; the temporary name keeps `path`'s suffix).
    Refuses to replace an existing file unless `force`.
    """
    path = check_output_path(path, force=force)
    tmp_path = None
    try:
        with _signals_deferred():  # a signal as the file is made must find it to remove
            fd, tmp = tempfile.mkstemp(
                prefix=f".{path.name}.", suffix=f"{_TMP_MARK}{path.suffix}", dir=path.parent or "."
            )
            tmp_path = Path(tmp)
            os.close(fd)
        os.chmod(tmp_path, 0o666 & ~_umask())  # mkstemp makes 0600; outputs get the usual mode
        if callable(data):
            data(tmp_path)
        elif isinstance(data, str):
            tmp_path.write_text(data, encoding="utf-8")
        else:
            tmp_path.write_bytes(data)
        with open(tmp_path, "rb+") as fh:
            os.fsync(fh.fileno())
        _commit_point(path)
        if force:
            os.replace(tmp_path, path)
        else:  # a link fails if the name exists: nothing that appeared meanwhile is replaced
            try:
                os.link(tmp_path, path)
            except FileExistsError:
                raise OutputExistsError(
                    f"output file {str(path)!r} appeared while writing; not overwritten"
                ) from None
            except OSError:  # a filesystem without hard links: check, then rename
                if path.exists():
                    raise OutputExistsError(
                        f"output file {str(path)!r} appeared while writing; not overwritten"
                    ) from None
                os.replace(tmp_path, path)
    finally:
        if tmp_path is not None:
            with contextlib.suppress(FileNotFoundError):
                tmp_path.unlink()
    return path


@contextlib.contextmanager
def _signals_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back (main thread) until the block is done, then deliver them.

    A handler that records the signal stands in during the block (a thread signal mask
    would not do: JAX's threads would take the signal).
    """
    import signal
    import threading

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    saved = {
        s: signal.signal(s, lambda signum, frame: got.append(signum))
        for s in (signal.SIGINT, signal.SIGTERM)
    }
    try:
        yield
    finally:
        for s, handler in saved.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        for s in dict.fromkeys(got):
            signal.raise_signal(s)


@contextlib.contextmanager
def atomic_dir(
    path: str | os.PathLike, *, force: bool = False, inputs: Iterable[str | os.PathLike] = ()
) -> Iterator[Path]:
    """Build a folder under a temporary name; move it to `path` only when the block succeeds.

    An existing non-empty `path` is refused unless `force`; with `force` it is replaced only
    after the new folder is complete, so an interrupted run leaves the previous one intact.
    A `path` that holds an input (a file the command read, or one of `inputs`) is refused.
    """
    inputs = tuple(inputs)
    path = check_output_path(path, force=force, folder=True, inputs=inputs)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = None
    try:
        with _signals_deferred():  # a signal as the folder is made must find it to remove
            tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.", suffix=_TMP_MARK, dir=path.parent))
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700; the folder gets the usual mode
        yield tmp
        check_output_path(path, force=force, folder=True, inputs=inputs)  # inputs read since
        old = None
        if path.exists():
            old = path.with_name(f".{path.name}.old{_TMP_MARK}")
            shutil.rmtree(old, ignore_errors=True)
        _commit_point(path)
        with _signals_deferred():  # Ctrl-C between the two renames would hide the old folder
            if old is not None:
                os.replace(path, old)
            try:  # a rename onto a folder that is not empty fails: a rival's report stays
                os.rename(tmp, path)
            except OSError as exc:
                if old is not None:
                    os.replace(old, path)
                if exc.errno in (errno.ENOTEMPTY, errno.EEXIST):
                    raise OutputExistsError(
                        f"output folder {str(path)!r} appeared while writing; not replaced"
                    ) from None
                raise
            if old is not None:
                shutil.rmtree(old, ignore_errors=True)
    finally:
        if tmp is not None:
            shutil.rmtree(tmp, ignore_errors=True)
