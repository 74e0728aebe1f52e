"""The `attenfit` command line: a thin layer over the Python API.

`get_parser()` builds the parser; `main(argv)` runs one verb and returns its exit code:
0 success, 2 bad input (one line on stderr, no traceback), 3 a fit that did not converge,
1 anything else. Each verb is one small function that calls the API.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import sys
import traceback
from collections.abc import Sequence

from . import _atomic, _input, _progress
from ._cli import (
    _cmd_cache,
    _cmd_export,
    _cmd_families,
    _cmd_fit,
    _cmd_report,
    _cmd_scene,
    _cmd_truth,
    _cmd_warm,
)
from ._cli._common import EXIT_BAD_INPUT, EXIT_ERROR, EXIT_NOT_CONVERGED, EXIT_OK
from ._errors import AttenfitError, BadTypeError, BadValueError, OutputExistsError
from ._version import __version__

#: Set (to anything) to print the traceback of an internal error, for a bug report.
TRACEBACK_ENV = "ATTENFIT_TRACEBACK"

__all__ = [
    "EXIT_BAD_INPUT",
    "EXIT_ERROR",
    "EXIT_NOT_CONVERGED",
    "EXIT_OK",
    "get_parser",
    "main",
    "run",
]


class _Parser(argparse.ArgumentParser):
    """An argparse parser whose errors are one line and exit 2."""

    def error(self, message: str) -> None:  # type: ignore[override]
        raise _UsageError(f"{self.prog}: {message} (see {self.prog} --help)")


class _UsageError(Exception):
    pass


# ----------------------------------------------------------------------------- entry point
def get_parser() -> argparse.ArgumentParser:
    """The `attenfit` argument parser."""
    parser = _Parser(
        prog="attenfit",
        description="How well does a cheap light-attenuation curve stand in for a real light?",
    )
    parser.add_argument("--version", action="version", version=f"attenfit {__version__}")
    sub = parser.add_subparsers(dest="verb", metavar="VERB", parser_class=_Parser)
    # what every verb takes: --quiet
    common = argparse.ArgumentParser(add_help=False)
    common.add_argument(
        "-q",
        "--quiet",
        action="store_true",
        help="say nothing on stderr but errors (no progress, no summary line)",
    )
    for verb in (
        _cmd_families,
        _cmd_truth,
        _cmd_fit,
        _cmd_report,
        _cmd_scene,
        _cmd_export,
        _cmd_cache,
        _cmd_warm,
    ):
        verb.add_parser(sub, [common])
    return parser


#: Signals that came before `main` installed its handlers (`run` records them).
_EARLY: list[int] = []


def _record_early(signum, frame) -> None:
    _EARLY.append(signum)


def _on_signal(signum, frame) -> None:
    """SIGINT and SIGTERM: note the signal (no output is committed after it) and unwind,
    once (`attenfit._atomic.on_signal`)."""
    _atomic.on_signal(signum)


def _quiet_interrupts(hook):
    """An unraisable-exception hook that drops interrupts raised inside callbacks.

    Python swallows (and prints) an exception raised in e.g. a garbage-collection callback;
    the interrupt is acted on at the next commit point instead (`attenfit._atomic.PENDING`),
    and the next signal may raise again.
    """

    def quiet(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            _atomic.rearm()
        else:
            hook(unraisable)

    return quiet


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with `argv` (default: `sys.argv[1:]`); return the exit code.

    SIGINT (Ctrl-C) and SIGTERM unwind through the verb's `finally` blocks, so temporary
    outputs are removed and previous outputs stay as they were; exit 130 and 143. A command
    that has begun committing its outputs completes (exit 0): outputs are all or nothing.
    However many signals arrive, one unwinds and the rest are only recorded.
    """
    import signal
    import threading

    state = _atomic.SIGNALS
    saved: dict = {}
    hook = sys.unraisablehook
    state.reset()
    try:
        if threading.current_thread() is threading.main_thread():
            for s in (signal.SIGINT, signal.SIGTERM):
                saved[s] = signal.signal(s, _on_signal)
            sys.unraisablehook = _quiet_interrupts(hook)
        _atomic.PENDING.extend(_EARLY)  # signals that came while the process started
        _EARLY.clear()
        state.active = True
        _atomic.check_pending()
        code = _main(argv)
    except KeyboardInterrupt as exc:
        state.active = False
        code = _interrupted(exc)
    finally:
        state.active = False
        for s, handler in saved.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        sys.unraisablehook = hook
    if state.final and _atomic.PENDING:
        with contextlib.suppress(OSError, ValueError):
            print(
                f"attenfit: {_signal_name(_atomic.PENDING[0])} arrived while the outputs were "
                "being committed; they are complete",
                file=sys.stderr,
            )
    state.reset()
    return code


def _signal_name(signum: int) -> str:
    import signal

    return "SIGTERM" if signum == signal.SIGTERM else "SIGINT"


def _interrupted(exc: KeyboardInterrupt) -> int:
    """The one line and the exit code (128 + the signal's number) of an interrupted command."""
    import signal

    signum = int(getattr(exc, "signum", signal.SIGINT))
    what = "terminated" if signum == signal.SIGTERM else "interrupted"
    with contextlib.suppress(OSError, ValueError):  # stderr closed: the code still says it
        print(f"attenfit: {what}; any previous output is unchanged", file=sys.stderr)
    return 128 + signum


def _main(argv: Sequence[str] | None) -> int:
    for stream in (sys.stdout, sys.stderr):  # a file name that is not UTF-8 prints escaped
        with contextlib.suppress(AttributeError, ValueError):
            stream.reconfigure(errors="backslashreplace")
    try:
        argv = list(sys.argv[1:] if argv is None else argv)
        _check_arguments(argv)
        parser = get_parser()
        args = parser.parse_args(argv)
        if not getattr(args, "run", None):
            parser.print_help(sys.stderr)
            return EXIT_BAD_INPUT
        _check_paths(args)
        _check_names_written(args)
        progress = _progress.Progress(f"attenfit {args.verb}", quiet=args.quiet)
        with _progress.active(progress), _input.tracking():  # outputs may not replace inputs
            _input.declare(_file_arguments(args))
            _atomic.declare_outputs(_output_arguments(args))
            return int(args.run(args))
    except _UsageError as exc:
        print(str(exc).replace("\n", " "), file=sys.stderr)
        return EXIT_BAD_INPUT
    except OutputExistsError as exc:
        print(f"attenfit: error: {exc.cli_message()}".replace("\n", " "), file=sys.stderr)
        return EXIT_BAD_INPUT
    except AttenfitError as exc:
        print(f"attenfit: error: {exc}".replace("\n", " "), file=sys.stderr)
        return EXIT_BAD_INPUT
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:
        if _atomic.PENDING and _atomic.SIGNALS.raised:
            # the interrupt, surfacing as another error (raised inside a C extension's import,
            # it becomes "ImportError: initialization failed"): an interrupt, not a bug
            raise _atomic.Interrupted(_atomic.PENDING[0]) from exc
        message = _environment_error(exc)
        if message is not None:  # the file system or the locale refused a name: not a bug
            print(f"attenfit: error: {message}".replace("\n", " "), file=sys.stderr)
            return EXIT_BAD_INPUT
        # a bug: say what, in one line; the traceback when asked
        if os.environ.get(TRACEBACK_ENV):
            traceback.print_exc()
        print(
            f"attenfit: internal error (a bug in attenfit, not in your input; please report it "
            f"with the command, and {TRACEBACK_ENV}=1 for the traceback): "
            f"{type(exc).__name__}: {exc}".replace("\n", " "),
            file=sys.stderr,
        )
        return EXIT_ERROR


# ----------------------------------------------------------------------------- arguments
#: The longest argument attenfit takes (characters): a path may be 4,095 bytes (PATH_MAX).
MAX_ARGUMENT = 4096
_PATH_MAX = 4096
#: The options that name files: dest -> (how the command line calls it, an output?).
_PATH_OPTIONS = {
    "out": ("--out", True),
    "write_back": ("--write-back", True),
    "data": ("--data", False),
    "mitsuba": ("--mitsuba", False),
    "side": ("--side", False),
    "file": ("FILE", False),
}
#: Room an output's name leaves for attenfit's temporary name beside it, besides the
#: name's suffix: `.NAME.XXXXXXXX.attenfit-tmp.SUFFIX`, `.NAME.old.attenfit-tmp`.
_TMP_ROOM = 24


def _shown(text: str, most: int = 40) -> str:
    """`text` quoted for a message, cut short when long."""
    if len(text) <= most:
        return repr(text)
    return f"{text[:most]!r}... ({len(text):,} characters)"


def _check_arguments(argv: list[str]) -> None:
    """Refuse an argument longer than `MAX_ARGUMENT` (or holding a NUL) before parsing."""
    for i, arg in enumerate(argv, 1):
        if not isinstance(arg, str):
            raise BadTypeError(f"argument {i} must be text, got {type(arg).__name__}")
        if len(arg) > MAX_ARGUMENT:
            raise BadValueError(
                f"argument {i} is {len(arg):,} characters long (starting {arg[:24]!r}); "
                f"attenfit takes at most {MAX_ARGUMENT:,}"
            )
        if "\0" in arg:
            raise BadValueError(f"argument {i} ({_shown(arg)}) holds a NUL character")


def _name_max(path: bytes) -> int:
    """The longest file name the file system under `path` takes (NAME_MAX; 255 if unknown)."""
    folder = os.path.dirname(os.path.abspath(path)) or b"/"
    while True:
        try:
            return int(os.pathconf(folder, "PC_NAME_MAX"))
        except (OSError, ValueError):
            parent = os.path.dirname(folder)
            if parent == folder:
                return 255
            folder = parent


def _check_paths(args: argparse.Namespace) -> None:
    """Refuse a file name the file system cannot hold (a part over NAME_MAX; for an output,
    less the room its temporary name needs) before any work."""
    for dest, (label, output) in _PATH_OPTIONS.items():
        value = getattr(args, dest, None)
        for text in value if isinstance(value, list) else [value]:
            if not isinstance(text, str):
                continue
            raw = os.fsencode(text)
            if len(raw) >= _PATH_MAX:
                raise BadValueError(
                    f"{label} {_shown(text)}: a path of {len(raw):,} bytes, over the "
                    f"{_PATH_MAX - 1:,} the file system allows (PATH_MAX)"
                )
            name_max = _name_max(raw)
            parts = raw.rstrip(b"/").split(b"/")
            for k, part in enumerate(parts):
                limit = name_max
                if output and k == len(parts) - 1:
                    limit -= _TMP_ROOM + len(os.path.splitext(part)[1])
                if len(part) > limit:
                    room = (
                        f"the file system's {name_max}, less room for attenfit's temporary name"
                        if limit < name_max
                        else "the file system's NAME_MAX"
                    )
                    raise BadValueError(
                        f"{label} {_shown(text)}: a file name of {len(part)} bytes, over the "
                        f"{limit} a name may have here ({room})"
                    )


_PUNCTUATION = "`'\"()[],:"


#: Verbs whose output files quote an input's file name: verb -> (the input, the outputs).
_NAMED_IN_OUTPUTS = {"scene": ("file", ("out", "write_back"))}


def _check_names_written(args: argparse.Namespace) -> None:
    """Refuse up front an input name that is not text here (bytes Python could not decode:
    an ASCII locale, or a name that is not UTF-8) when the command's output files would
    quote it: they are UTF-8, and the command would otherwise fail only once written."""
    if args.verb not in _NAMED_IN_OUTPUTS:
        return
    name, outputs = _NAMED_IN_OUTPUTS[args.verb]
    value = getattr(args, name, None)
    if not isinstance(value, str) or not any(getattr(args, o, None) for o in outputs):
        return
    if any("\udc80" <= c <= "\udcff" for c in os.path.basename(value)):  # its name is quoted
        raise BadValueError(_not_text(value))


def _not_text(name: str) -> str:
    return (
        f"the name {_shown(name, 60)} is not UTF-8 text here, and attenfit writes it into a "
        "UTF-8 file: rename it, or run under a UTF-8 locale (LC_ALL=C.UTF-8) or with "
        "PYTHONUTF8=1"
    )


def _environment_error(exc: Exception) -> str | None:
    """The one-line message for an error the environment, not attenfit, caused: a file name
    the file system refuses, a full or read-only disk; a name that is not text in this
    locale (an ASCII locale, or bytes that are not UTF-8). None for anything else."""
    import errno

    refused = (
        errno.ENAMETOOLONG, errno.ELOOP, errno.EACCES, errno.EPERM, errno.EROFS,
        errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.ENOTDIR, errno.EISDIR,
    )  # fmt: skip
    if isinstance(exc, OSError) and exc.errno in refused and isinstance(exc.filename, str | bytes):
        return f"{_shown(os.fsdecode(exc.filename), 60)}: {exc.strerror}"
    if isinstance(exc, UnicodeError) and isinstance(getattr(exc, "object", None), str):
        if any("\udc80" <= c <= "\udcff" for c in exc.object):
            word = next(
                (w for w in exc.object.split() if any("\udc80" <= c <= "\udcff" for c in w)),
                exc.object,
            ).strip(_PUNCTUATION)
            return _not_text(word)
    return None


def _output_arguments(args: argparse.Namespace) -> list[str]:
    """The command's outputs (`--out`, `--write-back`)."""
    return [
        v for v in (getattr(args, "out", None), getattr(args, "write_back", None)) if v is not None
    ]


def _file_arguments(args: argparse.Namespace) -> list[str]:
    """The command's arguments that name existing files, outputs aside: its inputs."""
    found = []
    for key, value in vars(args).items():
        if key in ("out", "write_back"):
            continue
        for v in value if isinstance(value, list) else [value]:
            if isinstance(v, str) and os.path.isfile(v):
                found.append(v)
    return found


def run() -> None:
    """The console entry point: `main()`, then exit with its code.

    SIGINT and SIGTERM are only recorded outside `main`: one that came while
    the process started stops the command as soon as `main` begins (exit 130/143); one that
    comes as it leaves cannot end it with a traceback or another code. (Only one in the first tenth of
    a second, while Python itself starts and imports this module, gets Python's default.)

    The process then leaves through `os._exit` once its output is flushed, whatever the
    code. Nothing is lost: every output was already committed or removed by the verb's own
    clean-up, every child process has ended, and the only threads that may still run are
    daemon threads a failed command left behind (the report's figures and witness), which
    Python's shutdown would not wait for either. Python's own shutdown
    (tearing down JAX's backends and some thousand modules) took 0.35-0.4 s of a warm
    `attenfit scene` of 2 s, and an interrupt that lands while XLA is compiling can
    crash it (a segfault instead of exit 130/143).
    """
    import os
    import signal

    for s in (signal.SIGINT, signal.SIGTERM):
        signal.signal(s, _record_early)
    code = main()  # its handlers put back: a signal from here on is only recorded
    for stream in (sys.stdout, sys.stderr):
        # a reader that left (`| head`) is not an error, as within `main`; closed: nothing
        with contextlib.suppress(OSError, ValueError):
            stream.flush()
    os._exit(code)


if __name__ == "__main__":
    run()
