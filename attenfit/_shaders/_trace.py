"""A family as a straight-line scalar program, read from the jaxpr JAX itself evaluates.

`trace(family)` calls `jax.make_jaxpr` on `family(d)` for a float32 scalar `d`, with every
parameter as an input (a scalar, or one input per element of an array parameter), inlines
sub-jaxprs (`jit`/`pjit`, `custom_jvp_call`, `custom_vjp_call`, ...), expands `integer_pow`
and `square` into the multiplications XLA performs (JAX's `_integer_pow` lowering: binary
exponentiation, then one division for a negative exponent), drops no-op conversions, folds
static array plumbing (slice, squeeze, reshape, broadcast, concatenate, constant gathers),
and removes dead code. The result, a `Program`, is what `_export` prints as shader
code and what `_cost` counts: both see the very expression the JAX code evaluates.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable
from typing import Any

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np

from .._curves import Family, float32_family
from .._errors import BadTypeError, BadValueError
from ._model import as_family
from ._program import Atom, Const, Op, Program, UnsupportedPrimitiveError, Var

__all__ = ["PRIMITIVES", "trace"]

#: Element-wise primitives kept as they are: name -> number of arguments (None: any).
PRIMITIVES: dict[str, int | None] = {
    **dict.fromkeys(["add", "sub", "mul", "div", "max", "min", "pow", "atan2", "rem"], 2),
    **dict.fromkeys(["lt", "le", "gt", "ge", "eq", "ne", "and", "or"], 2),
    **dict.fromkeys(
        [
            "neg",
            "abs",
            "sign",
            "sqrt",
            "rsqrt",
            "cbrt",
            "exp",
            "exp2",
            "log",
            "expm1",
            "log1p",
            "tan",
            "sin",
            "cos",
            "atan",
            "tanh",
            "logistic",
            "floor",
            "ceil",
            "round",
            "is_finite",
            "not",
            "convert",
        ],
        1,
    ),
    "clamp": 3,
    "select_n": None,
}

# JAX primitive -> our name, where they differ.
_RENAME = {
    "convert_element_type": "convert",
    # total-order comparisons (searchsorted): equal to the plain ones except for -0.0 and NaN
    "lt_to": "lt",
    "le_to": "le",
    "gt_to": "gt",
    "ge_to": "ge",
    "eq_to": "eq",
}
# Primitives that return their (single) argument unchanged.
_IDENTITY = {"stop_gradient", "copy", "copy_p", "optimization_barrier", "reduce_precision"}
# Call-like primitives whose sub-jaxpr is inlined, and its parameter names.
_CALLS = {
    "pjit", "jit", "closed_call", "core_call", "remat", "checkpoint", "custom_jvp_call",
    "custom_vjp_call", "custom_vjp_call_jaxpr", "custom_lin",
}  # fmt: skip
_SUBJAXPR_KEYS = ("jaxpr", "call_jaxpr", "fun_jaxpr")


def _dtype_code(dtype: Any) -> str:
    dt = np.dtype(dtype)
    if dt == np.bool_:
        return "bool"
    if np.issubdtype(dt, np.floating):
        if dt.itemsize < 4:
            raise BadTypeError(
                f"cannot translate {dt} arithmetic; families must compute in float32"
            )
        return "f32"  # float64 appears only with x64 on; shaders compute in float32
    if np.issubdtype(dt, np.integer):
        return "i32"
    raise BadTypeError(f"cannot translate values of dtype {dt}")


def _plain_value(value: Any, dtype: str, float64: bool = False) -> Any:
    arr = np.asarray(value)
    if dtype == "f32":
        return float(arr) if float64 else float(np.float32(arr))
    if dtype == "i32":
        return int(arr)
    return bool(arr)


class _Builder:
    """Collects scalar ops while walking a jaxpr; values are object arrays of atoms."""

    def __init__(self, float64: bool = False) -> None:
        self.float64 = float64  # constants kept in float64 (else rounded to float32)
        self.ops: list[Op] = []
        self._ids = itertools.count()
        self._seen: dict[tuple, Atom] = {}

    def new_var(self, dtype: str) -> Var:
        return Var(next(self._ids), dtype)

    def emit(self, prim: str, args: list[Atom], dtype: str, **params: Any) -> Atom:
        """Append `prim(*args)`, reusing an identical earlier op (common subexpressions)."""
        if prim == "select_n" and all(_key(a) == _key(args[1]) for a in args[1:]):
            return args[1]
        key = (prim, tuple(_key(a) for a in args), dtype, tuple(sorted(params.items())))
        if key in self._seen:
            return self._seen[key]
        out = self.new_var(dtype)
        self.ops.append(Op(prim, tuple(args), out, tuple(sorted(params.items()))))
        self._seen[key] = out
        return out

    # -- element-wise helpers on scalar atoms
    def mul(self, a: Atom, b: Atom) -> Atom:
        return self.emit("mul", [a, b], a.dtype)

    def integer_pow(self, x: Atom, y: int) -> Atom:
        """JAX's `_integer_pow` (jax/_src/lax/lax.py): binary exponentiation, then 1/acc."""
        if y == 0:
            return Const(1.0 if x.dtype == "f32" else 1, x.dtype)
        reciprocal, y = y < 0, abs(y)
        acc: Atom | None = None
        while y > 0:
            if y & 1:
                acc = x if acc is None else self.mul(acc, x)
            y >>= 1
            if y > 0:
                x = self.mul(x, x)
        assert acc is not None
        if reciprocal:
            return self.emit("div", [Const(1.0, acc.dtype), acc], acc.dtype)
        return acc


def _key(a: Atom) -> Any:
    """A hashable identity of an atom that tells 0.0 from -0.0 (and never merges NaNs)."""
    if isinstance(a, Const) and a.dtype == "f32":
        return ("f32", int(np.float64(a.value).view(np.uint64)), a.value != a.value or None)
    return a


def _as_obj(value: Any) -> np.ndarray:
    arr = np.empty((), dtype=object)
    arr[()] = value
    return arr


def _const_array(b: _Builder, value: Any) -> np.ndarray:
    arr = np.asarray(value)
    code = _dtype_code(arr.dtype)
    out = np.empty(arr.shape, dtype=object)
    for idx in np.ndindex(arr.shape):
        out[idx] = Const(_plain_value(arr[idx], code, b.float64), code)
    return out


def _walk(b: _Builder, jaxpr: Any, consts: list[Any], args: list[np.ndarray]) -> list[np.ndarray]:
    """Translate `jaxpr` applied to `args` (object arrays of atoms); return its outputs."""
    env: dict[Any, np.ndarray] = {}

    def read(atom: Any) -> np.ndarray:
        if hasattr(atom, "val"):  # a Literal
            return _const_array(b, atom.val)
        return env[atom]

    for var, val in zip(jaxpr.constvars, consts, strict=True):
        env[var] = _const_array(b, val)
    for var, val in zip(jaxpr.invars, args, strict=True):
        env[var] = val
    for eqn in jaxpr.eqns:
        ins = [read(v) for v in eqn.invars]
        outs = _translate(b, eqn, ins)
        for var, val in zip(eqn.outvars, outs, strict=True):
            env[var] = val
    return [read(v) for v in jaxpr.outvars]


def _open(sub: Any) -> tuple[Any, list[Any]]:
    if hasattr(sub, "jaxpr") and hasattr(sub, "consts"):  # ClosedJaxpr
        return sub.jaxpr, list(sub.consts)
    return sub, []


def _sub_jaxpr(eqn: Any) -> tuple[Any, list[Any]] | None:
    if eqn.primitive.name not in _CALLS:
        return None
    for key in _SUBJAXPR_KEYS:
        sub = eqn.params.get(key)
        if sub is not None and (hasattr(sub, "eqns") or hasattr(sub, "jaxpr")):
            return _open(sub)
    return None


def _scan(b: _Builder, eqn: Any, ins: list[np.ndarray]) -> list[np.ndarray]:
    """`lax.scan`, unrolled: `length` copies of the body, carries threaded through."""
    p = eqn.params
    jaxpr, consts = _open(p["jaxpr"])
    n_consts, n_carry, length = p["num_consts"], p["num_carry"], int(p["length"])
    const_in, carry, xs = (
        ins[:n_consts],
        list(ins[n_consts : n_consts + n_carry]),
        ins[n_consts + n_carry :],
    )
    ys: list[list[np.ndarray]] = []
    steps = range(length - 1, -1, -1) if p.get("reverse") else range(length)
    for i in steps:
        outs = _walk(b, jaxpr, consts, [*const_in, *carry, *(x[i] for x in xs)])
        carry, y = outs[:n_carry], outs[n_carry:]
        ys.append(y)
    if p.get("reverse"):
        ys = ys[::-1]
    n_ys = len(eqn.outvars) - n_carry
    stacked = [
        np.stack([step[k] for step in ys]) if ys else np.empty((0,), dtype=object)
        for k in range(n_ys)
    ]
    return [*carry, *stacked]


def _cond(b: _Builder, eqn: Any, ins: list[np.ndarray]) -> list[np.ndarray]:
    """`lax.cond`/`switch` as every branch evaluated, then a select (as a shader would)."""
    index, ops = ins[0], ins[1:]
    results = [_walk(b, *_open(br), ops) for br in eqn.params["branches"]]
    outs = []
    for k in range(len(eqn.outvars)):
        shape = results[0][k].shape
        out = np.empty(shape, dtype=object)
        for idx in np.ndindex(shape):
            cases = [r[k][idx] for r in results]
            i = index[()]
            if isinstance(i, Const):
                out[idx] = cases[min(max(int(i.value), 0), len(cases) - 1)]
            else:
                out[idx] = b.emit("select_n", [i, *cases], cases[0].dtype)
        outs.append(out)
    return outs


def _translate(b: _Builder, eqn: Any, ins: list[np.ndarray]) -> list[np.ndarray]:
    name = eqn.primitive.name
    sub = _sub_jaxpr(eqn)
    if sub is not None:
        jaxpr, consts = sub
        n_extra = len(ins) - len(jaxpr.invars)
        return _walk(b, jaxpr, consts, ins[n_extra:] if n_extra > 0 else ins)
    if name in _IDENTITY:
        return ins[: len(eqn.outvars)]
    if name == "scan":
        return _scan(b, eqn, ins)
    if name == "cond":
        return _cond(b, eqn, ins)
    moved = _plumbing(b, eqn, ins)
    return [moved if moved is not None else _elementwise(b, eqn, ins)]


def _plumbing(b: _Builder, eqn: Any, ins: list[np.ndarray]) -> np.ndarray | None:
    """Static array plumbing (numpy on object arrays), or None for another primitive."""
    name, params = eqn.primitive.name, eqn.params
    if name == "slice":
        strides = params.get("strides") or (1,) * ins[0].ndim
        sl = tuple(
            slice(s, e, st)
            for s, e, st in zip(
                params["start_indices"], params["limit_indices"], strides, strict=True
            )
        )
        return ins[0][sl]
    if name == "squeeze":
        return np.squeeze(ins[0], axis=tuple(params["dimensions"]))
    if name == "reshape":
        return ins[0].reshape(params["new_sizes"])
    if name == "expand_dims":
        return np.expand_dims(ins[0], tuple(params["dimensions"]))
    if name == "broadcast_in_dim":
        shape, dims = tuple(params["shape"]), tuple(params["broadcast_dimensions"])
        src = ins[0]
        view_shape = [1] * len(shape)
        for i, dim in enumerate(dims):
            view_shape[dim] = src.shape[i]
        return np.broadcast_to(src.reshape(view_shape), shape).copy()
    if name == "concatenate":
        return np.concatenate(ins, axis=params["dimension"])
    if name == "transpose":
        return np.transpose(ins[0], params["permutation"])
    if name == "rev":
        return np.flip(ins[0], axis=tuple(params["dimensions"]))
    if name == "iota":
        aval = eqn.outvars[0].aval
        idx = np.indices(aval.shape)[params["dimension"]]
        return _const_array(b, idx.astype(np.dtype(aval.dtype)))
    if name in ("dynamic_slice", "gather", "dynamic_update_slice", "scatter"):
        return _static_index(b, eqn, ins)
    if name in ("reduce_sum", "reduce_max", "reduce_min", "reduce_prod", "reduce_and", "reduce_or"):
        return _reduce(b, name, ins[0], tuple(params["axes"]))
    return None


def _elementwise(b: _Builder, eqn: Any, ins: list[np.ndarray]) -> np.ndarray:
    """Element-wise arithmetic, one scalar operation per element."""
    name, params = eqn.primitive.name, eqn.params
    if name == "integer_pow":
        return _map(lambda x: b.integer_pow(x, int(params["y"])), ins[0])
    if name == "square":
        return _map(lambda x: b.mul(x, x), ins[0])
    if name == "convert_element_type":
        to = _dtype_code(params["new_dtype"])

        def convert(x: Atom) -> Atom:
            if x.dtype == to:
                return x
            if isinstance(x, Const):
                value = np.asarray(x.value).astype(params["new_dtype"])
                return Const(_plain_value(value, to, b.float64), to)
            return b.emit("convert", [x], to)

        return _map(convert, ins[0])
    prim = _RENAME.get(name, name)
    if prim in PRIMITIVES:
        arity = PRIMITIVES[prim]
        if arity is not None and len(ins) != arity:
            raise UnsupportedPrimitiveError(f"primitive {name!r} with {len(ins)} arguments")
        aval = eqn.outvars[0].aval
        out_code = _dtype_code(aval.dtype)
        shape = tuple(aval.shape)
        arrays = [np.broadcast_to(x, shape) for x in ins]
        out = np.empty(shape, dtype=object)
        for idx in np.ndindex(shape):
            out[idx] = b.emit(prim, [a[idx] for a in arrays], out_code)
        return out
    raise UnsupportedPrimitiveError(
        f"cannot translate JAX primitive {name!r} (in {eqn}); supported: "
        f"{', '.join(sorted([*PRIMITIVES, 'integer_pow', 'square', 'jit/pjit', 'custom_jvp_call', 'custom_vjp_call', 'scan (unrolled)', 'cond', 'slice', 'gather', 'dynamic_slice', 'reduce_*']))}"
    )


def _map(fn: Callable[[Atom], Atom], arr: np.ndarray) -> np.ndarray:
    out = np.empty(arr.shape, dtype=object)
    for idx in np.ndindex(arr.shape):
        out[idx] = fn(arr[idx])
    return out


def _reduce(b: _Builder, name: str, arr: np.ndarray, axes: tuple[int, ...]) -> np.ndarray:
    prim = {"reduce_sum": "add", "reduce_max": "max", "reduce_min": "min", "reduce_prod": "mul",
            "reduce_and": "and", "reduce_or": "or"}[name]  # fmt: skip
    moved = np.moveaxis(arr, axes, tuple(range(len(axes))))
    flat = moved.reshape((-1, *moved.shape[len(axes) :]))
    out = np.empty(flat.shape[1:], dtype=object)
    for idx in np.ndindex(out.shape):
        acc = flat[(0, *idx)]
        for k in range(1, flat.shape[0]):
            item = flat[(k, *idx)]
            acc = b.emit(prim, [acc, item], acc.dtype)
        out[idx] = acc
    return out


def _static_index(b: _Builder, eqn: Any, ins: list[np.ndarray]) -> np.ndarray:
    """XLA gather / dynamic_slice on object arrays; a traced start index becomes selects.

    Start indices are clamped into range (XLA's dynamic_slice semantics and JAX's "clip"
    and "promise_in_bounds" gather modes).
    """
    name = eqn.primitive.name
    params = eqn.params
    operand = ins[0]
    if name == "dynamic_slice":
        sizes = tuple(params["slice_sizes"])
        starts = [s[()] for s in ins[1:]]
        out = np.empty(sizes, dtype=object)
        his = [dim - size for dim, size in zip(operand.shape, sizes, strict=True)]
        for o in np.ndindex(sizes):
            out[o] = _gather_element(b, operand, starts, list(o), his)
        return out
    if name == "gather":
        indices = ins[1]
        dn = params["dimension_numbers"]
        sizes = tuple(params["slice_sizes"])
        fill_mode = "FILL" in str(params.get("mode", "")).upper()
        out_code = _dtype_code(eqn.outvars[0].aval.dtype)
        fill = _fill_value(params.get("fill_value"), eqn.outvars[0].aval.dtype, out_code)
        offset_dims = tuple(dn.offset_dims)
        collapsed = tuple(dn.collapsed_slice_dims)
        op_batch = tuple(getattr(dn, "operand_batching_dims", ()))
        idx_batch = tuple(getattr(dn, "start_indices_batching_dims", ()))
        start_map = tuple(dn.start_index_map)
        out_shape = tuple(eqn.outvars[0].aval.shape)
        offset_operand_dims = [
            d for d in range(operand.ndim) if d not in collapsed and d not in op_batch
        ]
        his = [dim - size for dim, size in zip(operand.shape, sizes, strict=True)]
        out = np.empty(out_shape, dtype=object)
        for o in np.ndindex(out_shape):
            batch = [o[i] for i in range(len(out_shape)) if i not in offset_dims]
            offs = [o[i] for i in offset_dims]
            starts: list[Any] = [0] * operand.ndim
            for k, d in enumerate(start_map):
                starts[d] = indices[(*batch, k)]
            for od, idim in zip(op_batch, idx_batch, strict=True):
                starts[od] = batch[idim]
            offsets = [0] * operand.ndim
            for d, off in zip(offset_operand_dims, offs, strict=True):
                offsets[d] = off
            value = _gather_element(b, operand, starts, offsets, his)
            if fill_mode:  # an out-of-range start index gives the fill value instead
                value = _fill_if_out_of_range(
                    b, value, [(starts[d], his[d]) for d in start_map], fill
                )
            out[o] = value
        return out
    raise UnsupportedPrimitiveError(
        f"cannot translate JAX primitive {name!r} (in {eqn}); only gathers and dynamic slices "
        "that read an array are supported, not scatters"
    )


def _fill_value(value: Any, dtype: Any, code: str) -> Const:
    """JAX's gather fill value: NaN for floats, the most negative int, True for bools."""
    if value is None:
        dt = np.dtype(dtype)
        if code == "f32":
            value = float("nan")
        elif code == "bool":
            value = True
        else:
            value = int(
                np.iinfo(dt).min if np.issubdtype(dt, np.signedinteger) else np.iinfo(dt).max
            )
    return Const(_plain_value(value, code) if code != "f32" else float(value), code)


def _fill_if_out_of_range(
    b: _Builder, value: Atom, starts: list[tuple[Any, int]], fill: Const
) -> Atom:
    bad: Atom | None = None
    for s, hi in starts:
        if isinstance(s, Const):
            s = int(s.value)
        if isinstance(s, int | np.integer):
            if not 0 <= int(s) <= hi:
                return fill
            continue
        below = b.emit("lt", [s, Const(0, s.dtype)], "bool")
        above = b.emit("gt", [s, Const(hi, s.dtype)], "bool")
        either = b.emit("or", [below, above], "bool")
        bad = either if bad is None else b.emit("or", [bad, either], "bool")
    if bad is None:
        return value
    return b.emit("select_n", [bad, value, fill], value.dtype)


def _gather_element(
    b: _Builder, operand: np.ndarray, starts: list[Any], offsets: list[int], his: list[int]
) -> Atom:
    """operand[clamp(starts, 0, his) + offsets]; a traced start becomes a chain of selects."""

    def rec(prefix: tuple[int, ...], dim: int) -> Atom:
        if dim == operand.ndim:
            return operand[prefix]
        s = starts[dim]
        if isinstance(s, Const):
            s = int(s.value)
        if isinstance(s, int | np.integer):
            k = min(max(int(s), 0), his[dim])
            return rec((*prefix, k + offsets[dim]), dim + 1)
        cands = [rec((*prefix, k + offsets[dim]), dim + 1) for k in range(his[dim] + 1)]
        acc = cands[-1]
        for k in range(len(cands) - 2, -1, -1):
            if _key(cands[k]) == _key(acc):
                continue
            pred = b.emit("le", [s, Const(k, s.dtype)], "bool")
            acc = b.emit("select_n", [pred, acc, cands[k]], acc.dtype)
        return acc

    return rec((), 0)


def trace(family: Family, *, float64: bool = False) -> Program:
    """The scalar program of `family(d)` for a float32 scalar `d` (see the module docstring).

    `float64=True`: the program of its float64 computation instead (JAX's x64 mode must be
    on), its constants and `values` kept in float64, for evaluating it in float64 on the host
    (`Program.evaluate_numpy` and shader code are float32).
    """
    family = as_family(family)
    if float64 and not jax.config.jax_enable_x64:
        raise BadValueError("trace(float64=True) needs JAX's x64 mode (jax_enable_x64)")
    dtype = np.float64 if float64 else np.float32
    names = family.param_names()
    values = {n: np.asarray(getattr(family, n), dtype) for n in names}
    for n, v in values.items():
        if not np.all(np.isfinite(v)):
            raise BadValueError(f"parameter {n}={v.tolist()} of {family.name!r} is not finite")
    fam = family if float64 else float32_family(family)

    def fn(d, *ps):
        model = eqx.tree_at(lambda m: [getattr(m, n) for n in names], fam, list(ps))
        return model(d)

    args = [jnp.zeros((), dtype), *(jnp.asarray(values[n]) for n in names)]
    closed = jax.make_jaxpr(fn)(*args)
    out_aval = closed.out_avals[0]
    if tuple(out_aval.shape) != ():
        shapes = {n: values[n].shape for n in names if values[n].shape}
        raise BadValueError(
            f"family {family.name!r} returns shape {tuple(out_aval.shape)} for a scalar d "
            f"(parameter shapes {shapes}); export and cost take one set of parameters, "
            "not a batch: pick one problem"
        )
    b = _Builder(float64)
    d = b.new_var("f32")
    param_vars: dict[str, tuple[Var, ...]] = {}
    in_arrays = [_as_obj(d)]
    for n in names:
        shape = values[n].shape
        vars_ = tuple(b.new_var("f32") for _ in range(int(np.prod(shape, dtype=int))))
        param_vars[n] = vars_
        arr = np.empty(shape, dtype=object)
        for var, idx in zip(vars_, np.ndindex(shape), strict=True):
            arr[idx] = var
        in_arrays.append(arr)
    (out,) = _walk(b, closed.jaxpr, list(closed.consts), in_arrays)
    output = out[()]
    if output.dtype != "f32":
        output = b.emit("convert", [output], "f32")
    ops = _dead_code_eliminated(b.ops, output)
    return Program(
        family=family.name,
        d=d,
        params=param_vars,
        values={n: tuple(float(x) for x in values[n].reshape(-1)) for n in names},
        shapes={n: values[n].shape for n in names},
        ops=tuple(ops),
        output=output,
    )


def _dead_code_eliminated(ops: list[Op], output: Atom) -> list[Op]:
    live = {output.id} if isinstance(output, Var) else set()
    kept = []
    for op in reversed(ops):
        if op.out.id in live:
            kept.append(op)
            live.update(a.id for a in op.args if isinstance(a, Var))
    return kept[::-1]
