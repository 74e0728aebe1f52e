"""Exact Jacobians in numpy, for scipy's side of the fitting benchmark.

A family's float64 scalar program (`attenfit._shaders.trace(family, float64=True)`: the
operations its JAX code performs, constants in float64) is evaluated with numpy ufuncs on
dual numbers: each value carries its derivatives with respect to the free parameters
(forward mode), by the rules JAX differentiates with (`max` and `min` split a tie, `abs` has
slope `sign`), so the result is JAX's Jacobian at numpy's speed, with no JAX dispatch.

`DualProgram(family, free).bind(d, values)` evaluates, once per problem, every operation that
depends on `d` and the fixed parameters only; each call then evaluates the rest:
`value(p)` (no derivatives, as scipy's trial points need) and `value_and_jacobian(p)`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from attenfit._curves import Family
from attenfit._shaders import trace
from attenfit._shaders._program import Const, Var

__all__ = ["DualProgram"]


def _tangent(prim: str, a: list[str], t: list[str | None], out: str) -> str | None:
    """Source of the tangent of `out = prim(*a)` from the arguments' tangents `t` (names, None
    for zero), by JAX's differentiation rules; None where the tangent is 0."""
    if all(x is None for x in t):
        return None
    ta = t[0]
    tb = t[1] if len(t) > 1 else None
    x = a[0]
    y = a[1] if len(a) > 1 else None

    def zero(name: str | None) -> str:
        return "0.0" if name is None else name

    if prim == "add":
        return ta if tb is None else tb if ta is None else f"{ta} + {tb}"
    if prim == "sub":
        return ta if tb is None else f"-{tb}" if ta is None else f"{ta} - {tb}"
    if prim == "neg":
        return f"-{ta}"
    if prim == "mul":
        if tb is None:
            return f"{ta} * {y}"
        return f"{x} * {tb}" if ta is None else f"{ta} * {y} + {x} * {tb}"
    if prim == "div":
        if tb is None:
            return f"{ta} / {y}"
        return f"(-{out} * {tb}) / {y}" if ta is None else f"({ta} - {out} * {tb}) / {y}"
    if prim in ("max", "min"):  # a tie splits the tangent, as JAX's
        wins = f"{x} > {y}" if prim == "max" else f"{x} < {y}"
        ta, tb = zero(ta), zero(tb)
        return f"where({wins}, {ta}, where({x} == {y}, 0.5 * ({ta} + {tb}), {tb}))"
    if prim == "abs":
        return f"sign({x}) * {ta}"
    if prim == "convert":
        return ta
    if prim == "select_n":
        cases = [zero(c) for c in t[1:]]
        if len(cases) == 2:
            return f"where({x}, {cases[1]}, {cases[0]})"
        return f"choose({x}.astype(int64), broadcast_arrays({', '.join(cases)}))"
    if prim == "pow":
        parts = []
        if ta is not None:
            parts.append(f"{y} * power({x}, {y} - 1) * {ta}")
        if tb is not None:
            parts.append(f"log(where({x} > 0, {x}, 1.0)) * {out} * {tb}")
        return " + ".join(parts)
    if prim == "atan2":
        return f"({zero(ta)} * {y} - {x} * {zero(tb)}) / ({x} * {x} + {y} * {y})"
    if prim == "rem":
        return f"{zero(ta)} - trunc({x} / {y}) * {zero(tb)}"
    if prim == "clamp":  # clamp(lo, x, hi)
        lo, v, hi = a
        tlo, tv, thi = (zero(c) for c in t)
        return (
            f"where(({v} > {lo}) & ({v} < {hi}), {tv}, 0.0) + where({v} < {lo}, {tlo}, 0.0)"
            f" + where({v} > {hi}, {thi}, 0.0)"
        )
    slope = _SLOPES.get(prim)
    if slope is None:  # comparisons, logic, sign, floor, ceil, round, is_finite
        return None
    return f"({slope.format(x=x, out=out)}) * {ta}"


#: d out / d x of the one-argument primitives, as source in `x` and `out`.
_SLOPES = {
    "sqrt": "0.5 / {out}", "rsqrt": "-0.5 * {out} / {x}", "cbrt": "{out} / (3 * {x})",
    "exp": "{out}", "exp2": "0.6931471805599453 * {out}", "expm1": "{out} + 1",
    "log": "1 / {x}", "log1p": "1 / (1 + {x})", "tan": "1 + {out} * {out}",
    "sin": "cos({x})", "cos": "-sin({x})", "atan": "1 / (1 + {x} * {x})",
    "tanh": "1 - {out} * {out}", "logistic": "{out} * (1 - {out})",
}  # fmt: skip

#: The value of each primitive, as source in its arguments.
_VALUES = {
    "add": "{0} + {1}", "sub": "{0} - {1}", "mul": "{0} * {1}", "div": "{0} / {1}",
    "max": "maximum({0}, {1})", "min": "minimum({0}, {1})", "pow": "power({0}, {1})",
    "atan2": "arctan2({0}, {1})", "rem": "fmod({0}, {1})", "lt": "{0} < {1}",
    "le": "{0} <= {1}", "gt": "{0} > {1}", "ge": "{0} >= {1}", "eq": "{0} == {1}",
    "ne": "{0} != {1}", "and": "{0} & {1}", "or": "{0} | {1}", "not": "~{0}",
    "neg": "-{0}", "abs": "abs({0})", "sign": "sign({0})", "sqrt": "sqrt({0})",
    "rsqrt": "1 / sqrt({0})", "cbrt": "cbrt({0})", "exp": "exp({0})", "exp2": "exp2({0})",
    "log": "log({0})", "expm1": "expm1({0})", "log1p": "log1p({0})", "tan": "tan({0})",
    "sin": "sin({0})", "cos": "cos({0})", "atan": "arctan({0})", "tanh": "tanh({0})",
    "logistic": "1 / (1 + exp(-{0}))", "floor": "floor({0})", "ceil": "ceil({0})",
    "round": "round({0})", "is_finite": "isfinite({0})",
    "clamp": "minimum(maximum({1}, {0}), {2})",
}  # fmt: skip

_DTYPES = {"f32": "float64", "i32": "int64", "bool": "bool_"}


def _value(prim: str, dtype: str, a: list[str]) -> str:
    if prim == "select_n":
        if len(a) == 3:
            return f"where({a[0]}, {a[2]}, {a[1]})"
        return f"choose({a[0]}.astype(int64), broadcast_arrays({', '.join(a[1:])}))"
    if prim == "convert":
        return f"asarray({a[0]}).astype({_DTYPES[dtype]})"
    return _VALUES[prim].format(*a)


_NAMESPACE = {
    name: getattr(np, name)
    for name in (
        "where", "maximum", "minimum", "power", "arctan2", "fmod", "sign", "sqrt", "cbrt",
        "exp", "exp2", "log", "expm1", "log1p", "tan", "sin", "cos", "arctan", "tanh",
        "floor", "ceil", "round", "isfinite", "choose", "broadcast_arrays", "asarray",
        "trunc", "int64", "float64", "bool_", "abs", "full", "zeros",
    )
}  # fmt: skip


class DualProgram:
    """`family(d)` in float64 numpy, with exact derivatives with respect to `free` parameters.

    The operations that depend on the free parameters become two Python functions of numpy
    code (generated once): values only, and values with tangents. A parameter-only value has
    shape (1,) and its tangent (k, 1), so that everything broadcasts against the (n,)
    samples and their (k, n) tangents.
    """

    def __init__(self, family: Family, free: Sequence[str]):
        self.program = prog = trace(family, float64=True)
        self.free = tuple(free)
        # (parameter, flat index) of each fitted value, in `free` order
        self.slots = [(p, i) for p in self.free for i in range(len(prog.params[p]))]
        self.k = len(self.slots)
        free_ids = [prog.params[p][i].id for p, i in self.slots]
        live = set(free_ids)
        self.live_ops, self.fixed_ops = [], []
        for op in prog.ops:
            if any(isinstance(a, Var) and a.id in live for a in op.args):
                live.add(op.out.id)
                self.live_ops.append(op)
            else:
                self.fixed_ops.append(op)
        # the fixed values the live operations read (computed per problem by `bind`)
        self.inputs = sorted(
            {a.id for op in self.live_ops for a in op.args if isinstance(a, Var)} - live
        )
        out = prog.output
        if isinstance(out, Var) and out.id not in live:
            self.inputs = sorted({*self.inputs, out.id})
        self.consts: list[Any] = []
        self._value_fn = self._compile(free_ids, tangents=False)
        self._dual_fn = self._compile(free_ids, tangents=True)

    def _atom(self, a: Any) -> str:
        if isinstance(a, Const):
            self.consts.append(np.dtype(_DTYPES[a.dtype]).type(a.value))
            return f"C[{len(self.consts) - 1}]"
        return f"v{a.id}"

    def _compile(self, free_ids: list[int], tangents: bool):
        lines = ["def run(P, F, C, n):", f"    ({', '.join(f'v{i}' for i in self.inputs)},) = F"]
        if not self.inputs:
            lines.pop()
        tan: dict[int, str] = {}
        for j, vid in enumerate(free_ids):
            lines.append(f"    v{vid} = P[{j}:{j + 1}]")
            if tangents:
                lines.append(f"    t{vid} = zeros(({self.k}, 1)); t{vid}[{j}, 0] = 1.0")
                tan[vid] = f"t{vid}"
        for op in self.live_ops:
            args = [self._atom(a) for a in op.args]
            out = f"v{op.out.id}"
            lines.append(f"    {out} = {_value(op.prim, op.out.dtype, args)}")
            if tangents and op.out.dtype == "f32":
                ts = [tan.get(a.id) if isinstance(a, Var) else None for a in op.args]
                t = _tangent(op.prim, args, ts, out)
                if t is not None:
                    lines.append(f"    t{op.out.id} = {t}")
                    tan[op.out.id] = f"t{op.out.id}"
        res = self._atom(self.program.output)
        if not tangents:
            lines.append(f"    return {res} + zeros(n)")
        else:
            t = tan.get(self.program.output.id) if isinstance(self.program.output, Var) else None
            jac = f"{t} + zeros(({self.k}, n))" if t else f"zeros(({self.k}, n))"
            lines.append(f"    return {res} + zeros(n), {jac}")
        namespace = dict(_NAMESPACE)
        self.source = "\n".join(lines)  # the last function compiled, for reading
        exec(self.source, namespace)
        return namespace["run"]

    def bind(self, d: np.ndarray, values: Mapping[str, Any]) -> _Bound:
        """The program for one problem: samples `d` and the fixed parameters' `values`."""
        prog = self.program
        env: dict[int, Any] = {prog.d.id: np.asarray(d, np.float64)}
        for name, vars_ in prog.params.items():
            if name in self.free:
                continue
            flat = np.asarray(values[name], np.float64).reshape(-1)
            for var, x in zip(vars_, flat, strict=True):
                env[var.id] = np.full(1, x)

        def get(a: Any) -> Any:
            if isinstance(a, Const):
                return np.dtype(_DTYPES[a.dtype]).type(a.value)
            return env[a.id]

        namespace = dict(_NAMESPACE)
        with np.errstate(all="ignore"):
            for op in self.fixed_ops:
                names = [f"a{i}" for i in range(len(op.args))]
                code = _value(op.prim, op.out.dtype, names)
                local = dict(zip(names, map(get, op.args), strict=True))
                env[op.out.id] = eval(code, namespace, local)
        return _Bound(self, tuple(env[i] for i in self.inputs), len(d))


class _Bound:
    """A `DualProgram` bound to one problem's samples and fixed parameters."""

    def __init__(self, dual: DualProgram, fixed: tuple, n: int):
        self.dual, self.fixed, self.n = dual, fixed, n

    def value(self, p: np.ndarray) -> np.ndarray:
        """f(d) at the free parameters' values `p` (flat, in `free` order)."""
        return self.dual._value_fn(p, self.fixed, self.dual.consts, self.n)

    def value_and_jacobian(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """f(d) and df/dp, shape (k, n), at `p`."""
        return self.dual._dual_fn(p, self.fixed, self.dual.consts, self.n)
