"""The memory budget: a command estimates what it will need from its sizes, and refuses up
front, naming the number and the knob, when that exceeds the budget.

The budget is `ATTENFIT_MEMORY_BUDGET` (bytes, or with a unit: `512M`, `8G`, `1.5GiB`) or,
by default, half the machine's physical memory. Estimates are peak resident memory above
the process's baseline, measured per unit of work (receiver, sample, pixel) with
`benchmarks/bench_memory.py` and rounded up; docs/errors.md lists them.
"""

from __future__ import annotations

import os
import re

from ._errors import BadValueError

__all__ = ["BudgetError", "budget", "check", "describe"]

ENV = "ATTENFIT_MEMORY_BUDGET"
_UNITS = {"": 1, "k": 1e3, "m": 1e6, "g": 1e9, "t": 1e12, "ki": 2**10, "mi": 2**20, "gi": 2**30}
_UNITS["ti"] = 2**40
_MOST = float(2**63)  # the largest budget: what a byte count in C may be


class BudgetError(BadValueError):
    """A command would need more memory than the budget allows."""


def _physical() -> int:
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # not on every platform
        return 8 << 30


def _shown(text: str) -> str:
    """`text` for a message: quoted, and cut short if it is long."""
    return repr(text) if len(text) <= 40 else f"{text[:40]!r}... ({len(text):,} characters)"


def parse(text: str) -> int:
    """Bytes from `4096`, `512M`, `8G`, `1.5GiB` (decimal k/M/G/T, binary Ki/Mi/Gi/Ti)."""
    m = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]*)?(?:[eE][0-9]+)?)\s*([kKmMgGtT]i?)?[bB]?\s*", text)
    if not m:
        raise BadValueError(f"{ENV} must be a size like 4096, 512M or 8G, got {_shown(text)}")
    value = float(m.group(1)) * _UNITS[(m.group(2) or "").lower()]
    if not value >= 1 << 20:
        raise BadValueError(f"{ENV} must be at least 1M, got {_shown(text)}")
    if not value < _MOST:  # 1e400 is a float infinity, which no integer holds
        raise BadValueError(f"{ENV} must be below 2^63 bytes (9.2 EB), got {_shown(text)}")
    return int(value)


def budget() -> int:
    """The memory budget in bytes (`ATTENFIT_MEMORY_BUDGET`, else half the physical memory)."""
    text = os.environ.get(ENV, "").strip()
    return parse(text) if text else _physical() // 2


def describe(n: float) -> str:
    """`n` bytes for people: `1.2 GB`, `350 MB`."""
    for unit, size in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= size:
            return f"{n / size:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def check(need: float, what: str, knob: str) -> None:
    """Refuse (`BudgetError`) when `need` bytes exceed the budget.

    `what` says what needs the memory ("a scene of 26,214,400 receivers"), `knob` what
    would make it smaller ("fewer receivers: a plane's resolution").
    """
    limit = budget()
    if need > limit:
        raise BudgetError(
            f"{what} needs about {describe(need)} of memory, over the budget of "
            f"{describe(limit)}; use {knob}, or raise {ENV}"
        )
