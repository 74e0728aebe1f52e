"""The layout of a solve's packed outputs: one vector per problem (one transfer), read back
by name. Apart from the solve itself (`_problem`), so that reading a cached result needs
neither optimistix nor the solve's code."""

from __future__ import annotations

import functools
import math

import numpy as np


def finish_layout(k: int) -> list[tuple[str, tuple[int, ...]]]:
    """Name and per-problem shape of each output `finish` packs, `k` free values."""
    return [
        ("pvec", (k,)),
        ("jtj", (k, k)),
        ("at_bound", (k,)),
        ("loss", ()),
        ("max_rel", ()),
        ("rms_rel", ()),
        ("grad_ok", ()),
    ]


#: ...and of those packed from the solve alone, after them.
SOLVE_LAYOUT = [("result", ()), ("steps", ()), ("start_finite", ()), ("start_loss", ())]


def packed_layout(k: int) -> list[tuple[str, tuple[int, ...]]]:
    """Name and per-problem shape of every packed output, in order."""
    return finish_layout(k) + SOLVE_LAYOUT


@functools.cache
def packed_slices(k: int) -> dict[str, slice]:
    """Where each output of `packed_layout(k)` lies along the packed axis."""
    out, i = {}, 0
    for name, shape in packed_layout(k):
        out[name] = slice(i, i + math.prod(shape))
        i += math.prod(shape)
    return out


def unpack_columns(flat: np.ndarray, k: int) -> dict[str, np.ndarray]:
    """The packed outputs of a batch, by name, each with the batch axis first."""
    out = {}
    for name, shape in packed_layout(k):
        piece = flat[:, packed_slices(k)[name]].reshape((len(flat), *shape))
        if name in ("result", "steps"):
            piece = piece.astype(np.int64)
        elif name in ("start_finite", "at_bound", "grad_ok"):
            piece = piece.astype(bool)
        out[name] = piece
    return out
