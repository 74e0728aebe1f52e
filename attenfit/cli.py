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

from . import _input, _progress
from ._cli import (
    _cmd_cache,
    _cmd_export,
    _cmd_families,
    _cmd_fit,
    _cmd_report,
    _cmd_scene,
    _cmd_truth,
)
from ._cli._common import EXIT_BAD_INPUT, EXIT_ERROR, EXIT_NOT_CONVERGED, EXIT_OK
from ._errors import AttenfitError, OutputExistsError
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
    ):
        verb.add_parser(sub, [common])
    return parser


def _on_signal(signum, frame) -> None:
    """SIGINT and SIGTERM: note the signal (no output is committed after it) and unwind."""
    from ._atomic import PENDING, Interrupted

    PENDING.append(signum)
    raise Interrupted(signum)


def _quiet_interrupts(hook):
    """An unraisable-exception hook that drops interrupts raised inside callbacks.

    Python swallows (and prints) an exception raised in e.g. a garbage-collection callback;
    the interrupt is acted on at the next commit point instead (`attenfit._atomic.PENDING`).
    """

    def quiet(unraisable) -> None:
        if not isinstance(unraisable.exc_value, KeyboardInterrupt):
            hook(unraisable)

    return quiet


def main(argv: Sequence[str] | None = None) -> int:
    """Run the CLI with `argv` (default: `sys.argv[1:]`); return the exit code.

    SIGINT (Ctrl-C) and SIGTERM unwind through the verb's `finally` blocks, so temporary
    outputs are removed and previous outputs stay as they were; exit 130 and 143.
    """
    import signal
    import threading

    from . import _atomic

    saved = {}
    hook = sys.unraisablehook
    if threading.current_thread() is threading.main_thread():
        saved = {s: signal.signal(s, _on_signal) for s in (signal.SIGINT, signal.SIGTERM)}
        sys.unraisablehook = _quiet_interrupts(hook)
    _atomic.PENDING.clear()
    try:
        return _main(argv)
    finally:
        for s, handler in saved.items():
            signal.signal(s, signal.SIG_DFL if handler is None else handler)
        sys.unraisablehook = hook
        _atomic.PENDING.clear()


def _main(argv: Sequence[str] | None) -> int:
    for stream in (sys.stdout, sys.stderr):  # a file name that is not UTF-8 prints escaped
        with contextlib.suppress(AttributeError, ValueError):
            stream.reconfigure(errors="backslashreplace")
    parser = get_parser()
    try:
        args = parser.parse_args(argv)
        if not getattr(args, "run", None):
            parser.print_help(sys.stderr)
            return EXIT_BAD_INPUT
        progress = _progress.Progress(f"attenfit {args.verb}", quiet=args.quiet)
        with _progress.active(progress), _input.tracking():  # outputs may not replace inputs
            _input.declare(_file_arguments(args))
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
    except KeyboardInterrupt as exc:
        import signal

        signum = getattr(exc, "signum", signal.SIGINT)
        what = "terminated" if signum == signal.SIGTERM else "interrupted"
        print(f"attenfit: {what}; any previous output is unchanged", file=sys.stderr)
        return 128 + int(signum)
    except BrokenPipeError:
        return EXIT_OK
    except Exception as exc:  # a bug: say what, in one line; the traceback when asked
        if os.environ.get(TRACEBACK_ENV):
            traceback.print_exc()
        print(
            f"attenfit: internal error (a bug in attenfit, not in your input; please report it "
            f"with the command, and {TRACEBACK_ENV}=1 for the traceback): "
            f"{type(exc).__name__}: {exc}",
            file=sys.stderr,
        )
        return EXIT_ERROR


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

    After Ctrl-C or SIGTERM the process leaves through `os._exit` once its output is
    flushed: an interrupt that lands while XLA is compiling can otherwise crash the
    interpreter's shutdown (a segfault instead of exit 130/143). Nothing is lost: every
    output was already committed or removed by the verb's own clean-up.
    """
    import os

    code = main()
    if code in (130, 143):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(code)
    sys.exit(code)


if __name__ == "__main__":
    run()
