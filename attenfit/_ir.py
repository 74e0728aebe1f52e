"""A small expression language for the shader forms: one expression per family, printed in
every target language (`_print`), counted (`_compile`) and evaluated in float16, float32 and
float64 (`evaluate`), so that what is measured is what is printed.

Nodes: `Num` (a literal), `Ref` (the distance `d`, a parameter or a named temporary), `Call`
(an operation of `OPS`). A `ShaderForm` is a list of let-bound named temporaries and a
result expression. Python operators build nodes: `2.0 / (d2 + r * r)`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from jaxtyping import Float

from ._errors import BadValueError

__all__ = [
    "OPS",
    "Call",
    "Expr",
    "Lets",
    "Num",
    "Ref",
    "ShaderForm",
    "evaluate_form",
    "fn",
    "reads",
]

#: Every operation: name -> number of arguments.
OPS: Mapping[str, int] = {
    **dict.fromkeys(["add", "sub", "mul", "div", "min", "max", "pow"], 2),
    **dict.fromkeys(["lt", "le", "gt", "ge"], 2),
    **dict.fromkeys(["neg", "sqrt", "rsqrt", "exp", "log", "tan", "cos", "saturate"], 1),
    **dict.fromkeys(["abs", "atan", "acos"], 1),
    "atan2": 2,  # atan2(y, x)
    "clamp": 3,  # clamp(x, lo, hi)
    "select": 3,  # select(condition, if_true, if_false)
}


class Expr:
    """A scalar expression; arithmetic operators build `Call` nodes."""

    def __add__(self, o: Any) -> Call:
        return Call("add", (self, _lift(o)))

    def __radd__(self, o: Any) -> Call:
        return Call("add", (_lift(o), self))

    def __sub__(self, o: Any) -> Call:
        return Call("sub", (self, _lift(o)))

    def __rsub__(self, o: Any) -> Call:
        return Call("sub", (_lift(o), self))

    def __mul__(self, o: Any) -> Call:
        return Call("mul", (self, _lift(o)))

    def __rmul__(self, o: Any) -> Call:
        return Call("mul", (_lift(o), self))

    def __truediv__(self, o: Any) -> Call:
        return Call("div", (self, _lift(o)))

    def __rtruediv__(self, o: Any) -> Call:
        return Call("div", (_lift(o), self))

    def __neg__(self) -> Call:
        return Call("neg", (self,))

    def __lt__(self, o: Any) -> Call:  # type: ignore[override]
        return Call("lt", (self, _lift(o)))

    def __gt__(self, o: Any) -> Call:  # type: ignore[override]
        return Call("gt", (self, _lift(o)))


@dataclasses.dataclass(frozen=True, eq=False)
class Num(Expr):
    """A literal (printed as the shortest decimal that reads back as the same float32)."""

    value: float


@dataclasses.dataclass(frozen=True, eq=False)
class Ref(Expr):
    """A per-receiver input (kind "d": the distance `d`, or an area model's `cos_r`, ...), a
    parameter ("param") or a named temporary ("let")."""

    name: str
    kind: str


@dataclasses.dataclass(frozen=True, eq=False)
class Call(Expr):
    """An operation of `OPS` applied to its arguments."""

    op: str
    args: tuple[Expr, ...]

    def __post_init__(self) -> None:
        if OPS.get(self.op) != len(self.args):
            raise BadValueError(f"operation {self.op!r} with {len(self.args)} arguments")


def _lift(x: Any) -> Expr:
    if isinstance(x, Expr):
        return x
    if isinstance(x, int | float) and not isinstance(x, bool):
        return Num(float(x))
    raise BadValueError(f"cannot use {x!r} in a shader expression")


def fn(op: str, *args: Any) -> Call:
    """`op(*args)`, e.g. `fn("max", d, r)`, `fn("select", d < r, a, b)`."""
    return Call(op, tuple(_lift(a) for a in args))


class Lets:
    """Collects the named temporaries of a form in order: `let(name, expr)` returns a `Ref`."""

    def __init__(self) -> None:
        self.items: list[tuple[str, Expr]] = []

    def __call__(self, name: str, expr: Expr) -> "Ref":
        self.items.append((name, expr))
        return Ref(name, "let")


@dataclasses.dataclass(frozen=True)
class ShaderForm:
    """The expression an engine ships (or a person would write) for one family.

    `lets` are the named temporaries in order, `result` the returned expression, `params` the
    family's parameters it reads. `source` cites the engine's file and function (or the
    textbook equation) it transcribes, `engine` says whether it is an engine's own code, and
    `note` says where it parts from the JAX reference form. `inputs` are the per-receiver
    arguments (`d` for a family; an area model's `d, cos_r, cos_e, cos_n, g`).
    """

    family: str
    params: tuple[str, ...]
    lets: tuple[tuple[str, Expr], ...]
    result: Expr
    source: str
    engine: bool
    note: str = ""
    inputs: tuple[str, ...] = ("d",)

    def uniform_lets(self) -> set[str]:
        """The temporaries that read parameters only (a compiler folds them when baked)."""
        out: set[str] = set()
        for name, expr in self.lets:
            if not reads(expr, {"d"}, out):
                out.add(name)
        return out

    def depth(self) -> int:
        """The number of operations that depend on `d` (the size of the per-pixel work)."""
        uniform = self.uniform_lets()
        return sum(_count(e, uniform) for n, e in self.lets if n not in uniform) + _count(
            self.result, uniform
        )


def reads(expr: Expr, kinds: set[str], uniform: set[str]) -> bool:
    """Whether `expr` reads `d` (directly or through a temporary that does)."""
    if isinstance(expr, Ref):
        return expr.kind in kinds or (expr.kind == "let" and expr.name not in uniform)
    if isinstance(expr, Call):
        return any(reads(a, kinds, uniform) for a in expr.args)
    return False


def _count(expr: Expr, uniform: set[str]) -> int:
    if isinstance(expr, Call):
        here = 1 if reads(expr, {"d"}, uniform) else 0
        return here + sum(_count(a, uniform) for a in expr.args)
    return 0


# ----------------------------------------------------------------------------- numerics
_NUMPY: Mapping[str, Callable[..., Any]] = {
    "add": np.add,
    "sub": np.subtract,
    "mul": np.multiply,
    "div": np.divide,
    "min": np.minimum,
    "max": np.maximum,
    "pow": np.power,
    "lt": np.less,
    "le": np.less_equal,
    "gt": np.greater,
    "ge": np.greater_equal,
    "neg": np.negative,
    "sqrt": np.sqrt,
    "exp": np.exp,
    "log": np.log,
    "tan": np.tan,
    "cos": np.cos,
    "abs": np.abs,
    "atan": np.arctan,
    "acos": np.arccos,
    "atan2": np.arctan2,
}


def evaluate_form(
    form: ShaderForm,
    d: Float[np.ndarray, "*shape"] | Mapping[str, Float[np.ndarray, "*shape"]],
    params: Mapping[str, float],
    dtype: Any = np.float32,
) -> Float[np.ndarray, "*shape"]:
    """The form at distances `d`, every operation rounded to `dtype` (float16, 32 or 64).

    A form of several inputs (`form.inputs`, an area model's) takes `d` as a mapping from
    each input's name to its values (broadcast together).

    Parameters and literals are rounded to float32 first (what a shader bakes in), then to
    `dtype`. Temporaries that read parameters only are computed in float32 or wider (a
    compiler folds them, or the CPU computes them once per draw) and then rounded to `dtype`.
    """
    dt = np.dtype(dtype)
    wide = np.promote_types(dt, np.float32)
    uniform = form.uniform_lets()
    given = d if isinstance(d, Mapping) else {"d": d}
    arrays = np.broadcast_arrays(*(np.asarray(given[k], np.float64) for k in form.inputs))
    env: dict[str, Any] = {k: a.astype(dt) for k, a in zip(form.inputs, arrays, strict=True)}
    for p in form.params:
        env[p] = np.float32(params[p])
    with np.errstate(all="ignore"):
        for name, expr in form.lets:
            if name in uniform:
                env[name] = _eval(expr, env, wide).astype(dt)
            else:
                env[name] = _eval(expr, env, dt)
        for p in form.params:
            env[p] = np.asarray(env[p]).astype(dt)
        out = _eval(form.result, env, dt)
    return np.broadcast_to(out, arrays[0].shape).astype(dt)


def _eval(expr: Expr, env: Mapping[str, Any], dt: np.dtype) -> np.ndarray:
    if isinstance(expr, Num):
        return np.asarray(np.float32(expr.value)).astype(dt)
    if isinstance(expr, Ref):
        return np.asarray(env[expr.name]).astype(dt) if expr.kind != "let" else env[expr.name]
    assert isinstance(expr, Call)
    a = [_eval(x, env, dt) for x in expr.args]
    one, zero = np.asarray(1, dt), np.asarray(0, dt)
    if expr.op == "rsqrt":
        return (one / np.sqrt(a[0])).astype(dt)
    if expr.op == "saturate":
        return np.minimum(np.maximum(a[0], zero), one)
    if expr.op == "clamp":
        return np.minimum(np.maximum(a[0], a[1]), a[2])
    if expr.op == "select":
        return np.where(a[0], a[1], a[2]).astype(dt)
    out = _NUMPY[expr.op](*a)
    return out if out.dtype == np.bool_ else out.astype(dt)
