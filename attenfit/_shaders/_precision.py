"""How precise the shader forms are in float32 and float16: where they overflow, flush to
zero, leave the normal range, or lose relative accuracy, and the distances where they stay
within 1% of their own float64 value.

The form is evaluated by `_ir.evaluate_form` with every operation rounded to the precision
(numpy's float16 arithmetic: each operation computed exactly enough and rounded to float16,
as IEEE half-precision hardware does for add, multiply, divide and sqrt). How faithful that
is to a GPU: NVIDIA and AMD half-precision add, multiply and fma round correctly like this
model; their reciprocal, rsqrt, log2 and exp2 in half precision are approximations within
about 1 ulp, so pow and divisions may differ from this model in the last bit; subnormal
halves are kept by NVIDIA but may be flushed to 0 elsewhere (which is why leaving the
normal range is reported); GLSL `mediump` only promises at least this precision: desktop
GPUs evaluate it in float32.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np
from jaxtyping import Float

from .._curves import Family
from .._ir import evaluate_form
from ._export import scalar_params

__all__ = ["PRECISIONS", "Precision", "precision", "shade_in"]

#: The precisions a shader is evaluated in.
PRECISIONS = ("float16", "float32")


def default_grid(family: Family, dtype: str) -> np.ndarray:
    """0, 100 log-spaced distances a decade from 1e-30 m to 1e25 m (or the dtype's largest),
    and 400 more approaching the family's range (R (1 - u), u from 0.5 down to 1e-7)."""
    top = min(1e25, float(np.finfo(np.dtype(dtype)).max) / 2)
    parts = [[0.0], np.geomspace(1e-30, top, int(100 * (np.log10(top) + 30)) + 1)]
    rng = family.range_distance()
    if rng is not None:
        parts.append(float(rng) * (1 - np.geomspace(1e-7, 0.5, 400)))
    return np.unique(np.concatenate(parts))


@dataclasses.dataclass(frozen=True)
class Precision:
    """The shader form of one family in one precision (`dtype`), against its float64 value.

    `band` is the widest interval of distances (m) in which it stays within `tol` (1%) of
    float64 (None if nowhere); the other fields give the interval of distances where each
    failure happens (None where it does not): `overflow` (inf where float64 is finite),
    `zero` (0 where float64 is not), `subnormal` (the value leaves the normal range, flushed
    to 0 by hardware that flushes), `inaccurate` (finite, non-zero, off by more than `tol`).
    """

    family: str
    dtype: str
    band: tuple[float, float] | None
    overflow: tuple[float, float] | None
    zero: tuple[float, float] | None
    subnormal: tuple[float, float] | None
    inaccurate: tuple[float, float] | None
    tol: float = 0.01

    def describe(self) -> str:
        """One line: what fails where (or that nothing does on the grid)."""
        parts = []
        for what, span in (
            ("inf", self.overflow),
            ("0", self.zero),
            ("subnormal", self.subnormal),
            (f"> {self.tol:.0%} off", self.inaccurate),
        ):
            if span is not None:
                parts.append(f"{what} for d in [{_g(span[0])}, {_g(span[1])}]")
        return "; ".join(parts) or "nothing fails"

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        return {**dataclasses.asdict(self), "describe": self.describe()}


def _g(x: float) -> str:
    return f"{x:.3g}"


def shade_in(
    family: Family, d: Float[np.ndarray, " n"], dtype: str
) -> Float[np.ndarray, " n"] | None:
    """The shader form of `family` at `d`, evaluated in `dtype` (None: it has no form)."""
    sf = family.shader_form()
    if sf is None:
        return None
    return evaluate_form(sf, np.asarray(d, np.float64), scalar_params(family), dtype)


def _span(d: np.ndarray, mask: np.ndarray) -> tuple[float, float] | None:
    if not mask.any():
        return None
    return float(d[mask].min()), float(d[mask].max())


def precision(
    family: Family, dtype: str, *, tol: float = 0.01, d: np.ndarray | None = None
) -> Precision | None:
    """The `Precision` of `family`'s shader form in `dtype` (None: the family has no form).

    Evaluated on `d` (default `default_grid(family, dtype)`), rounded to `dtype` first: the error of
    rounding the distance itself is not the form's.
    """
    grid = default_grid(family, dtype) if d is None else np.asarray(d, np.float64)
    grid = np.unique(grid.astype(dtype).astype(np.float64))
    low = shade_in(family, grid, dtype)
    if low is None:
        return None
    ref = shade_in(family, grid, "float64")
    assert ref is not None
    v = low.astype(np.float64)
    tiny = float(np.finfo(np.dtype(dtype)).tiny)
    with np.errstate(all="ignore"):
        rel = np.abs(v - ref) / np.abs(ref)
    finite_ref = np.isfinite(ref)
    overflow = np.isinf(v) & finite_ref
    zero = (v == 0) & (ref != 0) & finite_ref
    subnormal = (np.abs(v) < tiny) & (v != 0) & finite_ref
    ok = np.where(ref == 0, v == 0, np.where(np.isinf(ref), v == ref, rel <= tol))
    inaccurate = finite_ref & ~ok & ~overflow & ~zero
    lit = (grid > 0) & (ref != 0)  # the band is where the light reaches
    return Precision(
        family=family.name,
        dtype=np.dtype(dtype).name,
        band=_widest_run(grid[lit], ok[lit]),
        overflow=_span(grid, overflow),
        zero=_span(grid, zero),
        subnormal=_span(grid, subnormal),
        inaccurate=_span(grid, inaccurate),
        tol=tol,
    )


def _widest_run(d: np.ndarray, ok: np.ndarray) -> tuple[float, float] | None:
    """The [first, last] distance of the longest run of consecutive `ok` points."""
    best: tuple[int, int] | None = None
    start = None
    for i, good in enumerate([*ok.tolist(), False]):
        if good and start is None:
            start = i
        elif not good and start is not None:
            if best is None or i - start > best[1] - best[0] + 1:
                best = (start, i - 1)
            start = None
    return None if best is None else (float(d[best[0]]), float(d[best[1]]))


def precision_table(
    families: Mapping[str, Family], dtypes: tuple[str, ...] = PRECISIONS
) -> dict[str, dict[str, Precision | None]]:
    """`precision` of each family (by name) in each dtype."""
    return {name: {dt: precision(fam, dt) for dt in dtypes} for name, fam in families.items()}
