"""One ranking for every verdict: which models are within a tolerance, cheapest first, and
which is the closest.

Every place attenfit names "the cheapest model within the tolerance" ranks through `rank`:
the report's decision table (distance curves, then area models), a scene's recommendation
and its per-light answers, the area models a scene escalates to, and the report's section
on what no distance curve can fix. They all break ties with `rank_key` (the shaders stage's,
so that `attenfit.cost.cheapest_within`, below this stage, keeps the same rule): the smaller
cost; then the smaller error to 3 significant digits; then fewer parameters; then the
smaller error; then the name. The closest is the same order with error first: the smallest
error to 3 digits, then the cheaper, and so on. A candidate is a name, an error and a cost,
whatever its model class (a distance curve, an area model, a spot falloff), so the closest
is chosen among every class a caller passes.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterable
from typing import Generic, TypeVar

from .._errors import BadTypeError, BadValueError
from .._shaders import rank_key

__all__ = ["Contender", "Ranking", "rank"]

T = TypeVar("T")


@dataclasses.dataclass(frozen=True)
class Contender(Generic[T]):
    """One model in a ranking.

    `name` identifies it (a fitted variant: `"<model> (fitted)"`); `error` is its error on
    the receivers judged (None or NaN: not judged, never within a tolerance); `cost` its
    shader cost (None or NaN: unknown, after every known cost); `params` how many parameters
    it takes (fewer wins a tie, `rank_key`); `allowed` False rules it out of `within`
    whatever its error (a broken constraint), though it can still be the closest; `item`
    is what the caller ranks (its own candidate record), carried through untouched.
    """

    name: str
    error: float | None
    cost: float | None
    params: int = 0
    allowed: bool = True
    item: T | None = dataclasses.field(default=None, compare=False, repr=False)

    def __post_init__(self) -> None:
        if not isinstance(self.name, str):
            raise BadTypeError(f"a contender's name must be a string, got {self.name!r}")
        if isinstance(self.params, bool) or not isinstance(self.params, int) or self.params < 0:
            raise BadValueError(
                f"contender {self.name!r}: params must be an integer >= 0, got {self.params!r}"
            )

    def key(self) -> tuple:
        """Its place among the cheapest: `rank_key` of its cost, error, name and params."""
        return rank_key(self.cost, self.error, self.name, self.params)

    def closeness(self) -> tuple:
        """Its place among the most accurate: `rank_key` with the error first."""
        cost, shown, *rest = self.key()
        return (shown, cost, *rest)

    @property
    def judged(self) -> bool:
        """Whether it has a finite error."""
        return self.error is not None and math.isfinite(self.error)


@dataclasses.dataclass(frozen=True)
class Ranking(Generic[T]):
    """The verdict on some contenders at one tolerance.

    `within`: the allowed contenders whose error is at most `tolerance`, cheapest first
    (`Contender.key`); `best` is its first (None when nothing is within). `outside`: every
    other contender, most accurate first (`Contender.closeness`), those with no finite error
    last. `closest`: the most accurate contender with a finite error, of every contender
    (within or not, allowed or not); None when none has one.
    """

    tolerance: float
    within: tuple[Contender[T], ...]
    outside: tuple[Contender[T], ...]
    closest: Contender[T] | None

    @property
    def best(self) -> Contender[T] | None:
        """The cheapest contender within the tolerance (None: none is)."""
        return self.within[0] if self.within else None

    def items(self) -> tuple[T | None, ...]:
        """The callers' items in order: within, then outside."""
        return tuple(c.item for c in (*self.within, *self.outside))


def rank(contenders: Iterable[Contender[T]], tolerance: float) -> Ranking[T]:
    """Rank `contenders` at `tolerance`: the ones within it cheapest first, and the closest.

    The order is `attenfit._shaders.rank_key` (cost; error to 3 significant digits; fewer
    parameters; error; name), the one tie-break of every verdict; the closest is the same
    order with the error first, among every contender with a finite error. Contenders of
    equal name and values keep their given order.
    """
    if isinstance(tolerance, bool) or not isinstance(tolerance, int | float):
        raise BadTypeError(f"tolerance must be a number, got {tolerance!r}")
    if not tolerance >= 0:  # NaN too
        raise BadValueError(f"tolerance must be a number >= 0, got {tolerance!r}")
    pool = list(contenders)
    for c in pool:
        if not isinstance(c, Contender):
            raise BadTypeError(f"rank takes Contender records, got {type(c).__name__}")
    inside = [c for c in pool if c.allowed and c.judged and c.error <= tolerance]  # type: ignore[operator]
    chosen = {id(c) for c in inside}
    rest = [c for c in pool if id(c) not in chosen]
    judged = [c for c in pool if c.judged]
    return Ranking(
        tolerance=float(tolerance),
        within=tuple(sorted(inside, key=Contender.key)),
        outside=tuple(sorted(rest, key=lambda c: (not c.judged, c.closeness()))),
        closest=min(judged, key=Contender.closeness) if judged else None,
    )
