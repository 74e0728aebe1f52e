"""What a long command is doing, said on stderr while it works.

The command line makes one `Progress` per verb and makes it current (`active`); the stages
below report to the current one through `stage` and `count`, and say nothing when there is
none (a program using the API). A stage is a line with the time elapsed
(`attenfit scene: [  2.1 s] fitting 20 families`), wherever stderr goes. On a terminal
countable work is a bar (tqdm: a well-kept library whose bars clean up after themselves and
cope with narrow terminals); when stderr is not a terminal (a pipe, a file, a CI log) it is
plain lines without carriage returns, the count so far at most once every `PLAIN_EVERY`
seconds (`attenfit report: [ 12.3 s] fitting 20 families: 7/20`). `note` remarks on the
work under way (that a first run compiles what later runs load): beside the bar, or once as
a plain line. `quiet` silences everything but errors.
"""

from __future__ import annotations

import contextlib
import contextvars
import sys
import time
from collections.abc import Callable, Iterator
from typing import Any, TextIO

from . import _atomic

__all__ = ["PLAIN_EVERY", "Progress", "active", "count", "done", "note", "stage"]

#: Off a terminal, a count's progress is a plain line at most once every so many seconds.
PLAIN_EVERY = 5.0


class Progress:
    """Stage lines, bars and a summary line for one command (`label`, e.g. "attenfit scene").

    `clock` (seconds, default `time.perf_counter`) times the stage lines and paces the plain
    count lines; tests pass their own.
    """

    def __init__(
        self,
        label: str,
        *,
        quiet: bool = False,
        stream: TextIO | None = None,
        clock: Callable[[], float] = time.perf_counter,
    ):
        self.label = label
        self.stream = sys.stderr if stream is None else stream
        self.quiet = quiet
        self.live = not quiet and _isatty(self.stream)
        self.clock = clock
        self.start = clock()
        self.noted: set[str] = set()  # remarks said as stage lines (`note`)

    def elapsed(self) -> float:
        return self.clock() - self.start

    def line(self, text: str) -> None:
        """One stage line (`label: [elapsed s] text`), unless quiet."""
        if not self.quiet:
            print(f"{self.label}: [{self.elapsed():5.1f} s] {text}", file=self.stream, flush=True)

    def stage(self, text: str) -> None:
        """Say what the command is doing now (a line, wherever stderr goes; none if quiet).

        Also a point where an interrupt that Python swallowed (one raised inside a callback
        that ignores exceptions, e.g. JAX's garbage-collection hook) is raised again, so the
        command stops at once instead of at its next output.
        """
        _atomic.check_pending()
        self.line(text)

    @contextlib.contextmanager
    def count(self, total: int, text: str) -> Iterator[Any]:
        """`total` units of work: a bar on a terminal, paced plain lines elsewhere, nothing
        if quiet; yields `.update(n=1)` and `.note(text)`."""
        if self.quiet:
            yield _NoBar()
            return
        if not self.live:
            self.stage(text)
            yield _PlainCount(self, total, text)
            return
        from tqdm import tqdm

        self.stage(text)
        with tqdm(
            total=total, desc=f"{self.label}: {text}", file=self.stream, leave=False, unit=""
        ) as bar:
            yield _Bar(bar)

    def done(self, text: str) -> None:
        """The summary line: what the command did (unless quiet), with the time it took."""
        if not self.quiet:
            print(f"{self.label}: {text} ({self.elapsed():.1f} s)", file=self.stream, flush=True)


class _NoBar:
    """Countable work with nothing to show (quiet, or no command): still an interrupt check
    point."""

    def update(self, n: int = 1) -> None:
        _atomic.check_pending()

    def note(self, text: str) -> None:
        pass


class _PlainCount(_NoBar):
    """Countable work off a terminal: `text: done/total` as a plain line, at most once every
    `PLAIN_EVERY` seconds; each distinct note once."""

    def __init__(self, progress: Progress, total: int, text: str):
        self.progress, self.total, self.text = progress, total, text
        self.n = 0
        self.last = progress.clock()
        self.notes: set[str] = set()

    def update(self, n: int = 1) -> None:
        super().update(n)
        self.n += n
        now = self.progress.clock()
        if now - self.last >= PLAIN_EVERY and self.n < self.total:
            self.last = now
            self.progress.line(f"{self.text}: {self.n}/{self.total}")

    def note(self, text: str) -> None:
        if text not in self.notes:
            self.notes.add(text)
            self.progress.line(text)


class _Bar(_NoBar):
    """A tqdm bar; `note` shows a remark beside it (e.g. that a first run compiles)."""

    def __init__(self, bar: Any):
        self.bar = bar

    def update(self, n: int = 1) -> None:
        super().update(n)
        self.bar.update(n)

    def note(self, text: str) -> None:
        self.bar.set_postfix_str(text, refresh=True)


def _isatty(stream: TextIO) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


_CURRENT: contextvars.ContextVar[Progress | None] = contextvars.ContextVar(
    "attenfit_progress", default=None
)
_BAR: contextvars.ContextVar[_NoBar | None] = contextvars.ContextVar("attenfit_bar", default=None)


@contextlib.contextmanager
def active(progress: Progress) -> Iterator[Progress]:
    """Make `progress` the one `stage` and `count` report to, inside the block."""
    token = _CURRENT.set(progress)
    try:
        yield progress
    finally:
        _CURRENT.reset(token)


def stage(text: str) -> None:
    """Tell the current command's `Progress`, if there is one, what is happening now."""
    progress = _CURRENT.get()
    if progress is not None:
        progress.stage(text)


def done(text: str) -> None:
    """The current command's summary line (see `Progress.done`), if there is a command."""
    progress = _CURRENT.get()
    if progress is not None:
        progress.done(text)


def note(text: str) -> None:
    """A remark on the work under way: beside the current bar, else as a stage line (each
    distinct remark once a command)."""
    bar = _BAR.get()
    if bar is not None:
        bar.note(text)
        return
    progress = _CURRENT.get()
    if progress is not None and text not in progress.noted:
        progress.noted.add(text)
        progress.stage(text)


@contextlib.contextmanager
def count(total: int, text: str, *, show: bool = True) -> Iterator[Any]:
    """A bar on the current command's `Progress` (a no-op without one, or with `show` off:
    then its `update` is only an interrupt check point); yields `.update()`."""
    progress = _CURRENT.get()
    if progress is None or not show:
        yield _NoBar()
        return
    with progress.count(total, text) as bar:
        token = _BAR.set(bar)
        try:
            yield bar
        finally:
            _BAR.reset(token)
