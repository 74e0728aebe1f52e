"""A family as a straight-line scalar program: variables, constants and one equation per
scalar operation (`Program`), and its evaluation with numpy float32 ufuncs."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from .._errors import BadValueError

__all__ = ["Atom", "Const", "Op", "Program", "UnsupportedPrimitiveError", "Var"]


class UnsupportedPrimitiveError(BadValueError):
    """The family uses a JAX primitive that has no straight-line scalar translation."""


@dataclasses.dataclass(frozen=True)
class Var:
    """A scalar variable of the program; `dtype` is "f32", "i32" or "bool"."""

    id: int
    dtype: str


@dataclasses.dataclass(frozen=True)
class Const:
    """A scalar literal (a Python float, int or bool)."""

    value: Any
    dtype: str


Atom = Var | Const


@dataclasses.dataclass(frozen=True)
class Op:
    """One scalar equation `out = prim(*args)` (prim names are listed in `PRIMITIVES`)."""

    prim: str
    args: tuple[Atom, ...]
    out: Var
    params: tuple[tuple[str, Any], ...] = ()


@dataclasses.dataclass(frozen=True)
class Program:
    """`family(d)` as scalar equations, in evaluation order, dead code removed.

    `d` is the input variable; `params` maps each parameter name to its input variables
    (one for a scalar parameter, one per element, flattened C-order, for an array) and
    `values` to their float32 values; `output` is the result atom.
    """

    family: str
    d: Var
    params: Mapping[str, tuple[Var, ...]]
    values: Mapping[str, tuple[float, ...]]
    shapes: Mapping[str, tuple[int, ...]]
    ops: tuple[Op, ...]
    output: Atom

    def depends_on_d(self) -> set[int]:
        """The ids of the variables whose value depends on `d` (per-pixel work)."""
        dep = {self.d.id}
        for op in self.ops:
            if any(isinstance(a, Var) and a.id in dep for a in op.args):
                dep.add(op.out.id)
        return dep

    def evaluate_numpy(self, d: np.ndarray, values: Mapping[str, Any] | None = None) -> np.ndarray:
        """Evaluate the program with numpy float32 ufuncs, element-wise over the array `d`."""
        env: dict[int, Any] = {self.d.id: np.asarray(d, np.float32)}
        vals = dict(self.values) if values is None else dict(values)
        for name, vars_ in self.params.items():
            flat = np.asarray(vals[name], np.float32).reshape(-1)
            for var, x in zip(vars_, flat, strict=True):
                env[var.id] = np.float32(x)

        def get(a: Atom):
            if isinstance(a, Const):
                return _NP_DTYPES[a.dtype](a.value)
            return env[a.id]

        with np.errstate(all="ignore"):
            for op in self.ops:
                env[op.out.id] = _numpy_op(op, [get(a) for a in op.args])
            out = get(self.output)
        return np.broadcast_to(np.asarray(out, np.float32), np.shape(d)).copy()


_NP_DTYPES: dict[str, Callable[[Any], Any]] = {"f32": np.float32, "i32": np.int32, "bool": np.bool_}


# ----------------------------------------------------------------------------- numpy semantics
def _select_n(pred: Any, *cases: Any) -> Any:
    if len(cases) == 2 and np.asarray(pred).dtype == np.bool_:
        return np.where(pred, cases[1], cases[0])
    return np.choose(np.asarray(pred, np.int32), np.broadcast_arrays(*cases))


def _sign(x: Any) -> Any:
    return np.sign(x)


_NUMPY: dict[str, Callable[..., Any]] = {
    "add": np.add,
    "sub": np.subtract,
    "mul": np.multiply,
    "div": np.divide,
    "max": np.maximum,
    "min": np.minimum,
    "pow": np.power,
    "atan2": np.arctan2,
    "rem": np.fmod,
    "lt": np.less,
    "le": np.less_equal,
    "gt": np.greater,
    "ge": np.greater_equal,
    "eq": np.equal,
    "ne": np.not_equal,
    "and": np.logical_and,
    "or": np.logical_or,
    "not": np.logical_not,
    "neg": np.negative,
    "abs": np.abs,
    "sign": _sign,
    "sqrt": np.sqrt,
    "rsqrt": lambda x: np.float32(1) / np.sqrt(x),
    "cbrt": np.cbrt,
    "exp": np.exp,
    "exp2": np.exp2,
    "log": np.log,
    "expm1": np.expm1,
    "log1p": np.log1p,
    "tan": np.tan,
    "sin": np.sin,
    "cos": np.cos,
    "atan": np.arctan,
    "tanh": np.tanh,
    "logistic": lambda x: np.float32(1) / (np.float32(1) + np.exp(-x)),
    "floor": np.floor,
    "ceil": np.ceil,
    "round": np.round,
    "is_finite": np.isfinite,
    "clamp": lambda lo, x, hi: np.minimum(np.maximum(x, lo), hi),
    "select_n": _select_n,
}


def _numpy_op(op: Op, args: list[Any]) -> Any:
    if op.prim == "convert":
        return np.asarray(args[0]).astype(
            {"f32": np.float32, "i32": np.int32, "bool": np.bool_}[op.out.dtype]
        )
    if op.prim == "div" and op.out.dtype == "i32":  # XLA truncates towards zero, as C does
        a, b = (np.asarray(x, np.int64) for x in args)
        return (np.sign(a) * np.sign(b) * (np.abs(a) // np.abs(b))).astype(np.int32)
    if op.prim in ("and", "or", "not") and op.out.dtype == "i32":
        fn = {"and": np.bitwise_and, "or": np.bitwise_or, "not": np.invert}[op.prim]
        return fn(*args)
    return _NUMPY[op.prim](*args)
