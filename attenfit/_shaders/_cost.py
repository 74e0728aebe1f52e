"""What each attenuation curve costs: measured throughput, shader operation counts, Pareto front.

Three views of the same question, so that a ranking never rests on a noisy clock alone:

* **Measured throughput** (`measure_throughput`): each family jitted (float32, parameters
  baked in as a shader would have them), evaluated on a large array; nanoseconds per
  evaluation as the median of interleaved repeats, and the ratio to `inverse_square`
  measured in the same run.
* **Operation counts** (`count_ops`): the scalar program `attenfit._shaders._trace.trace` reads from
  the jaxpr of `family(d)` (the expression JAX evaluates; the same one `attenfit.export`
  prints), counted by category. Only work that depends on `d` is counted per evaluation;
  work on the parameters alone (a shader compiler folds it, or it is done once per draw) is
  reported as `uniform`.
* **Shader cost** (`shader_cost`): one weighted number, in units of one full-rate FP32 ALU
  instruction (add, mul or fused multiply-add), with the weights of `SHADER_WEIGHTS`.

`family_cost(family)` and `cost_table(families)` return `Cost` records; `pareto_front`,
`cheapest_within` and `plot_cost_vs_error` put them against each family's error; `rank_key`
is the tie-break of every verdict (cost, then error, then name; see its docstring).

Notes
-----
The weights of `SHADER_WEIGHTS` follow NVIDIA's *CUDA C++ Programming Guide*, section
"Arithmetic Instructions", table "Throughput of Native Arithmetic Instructions": FP32 add,
multiply and multiply-add run at 64 to 128 results per clock per multiprocessor, while the
special-function unit's reciprocal, reciprocal square root, base-2 logarithm, base-2
exponential, sine and cosine run at 16, a ratio of 1:4 (Turing) to 1:8 (Ampere). AMD's
GCN/RDNA ISAs likewise issue `v_rcp_f32`, `v_rsq_f32`, `v_sqrt_f32`, `v_exp_f32`,
`v_log_f32`, `v_sin_f32`, `v_cos_f32` at quarter rate. We charge 4 per special-function
op (the conservative end). How composite operations expand is an assumption stated next
to each weight: a division is a reciprocal and a multiply (fast-math shader division),
`sqrt` a reciprocal square root and a multiply, `exp`/`log` a scaling multiply and an
`ex2`/`lg2`, `pow(x, y)` is `ex2(y * lg2(x))`, `tan` a sine, a cosine and a division, and
`atan`/`atan2` (no hardware instruction) about 16 ALU operations of a minimax polynomial
plus a reciprocal. Compare, select, min and max are full rate; `abs` and negation are free
source modifiers; a multiply whose only use is an add fuses into one FMA.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import time
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from .._curves import Family, float32_family, list_families
from .._errors import BadValueError
from .._ir import Call, Expr, ShaderForm, reads
from ._model import as_family
from ._program import Program, Var
from ._trace import trace

#: Operation categories reported by `count_ops`, in display order.
CATEGORIES = (
    "add",  # add, sub
    "mul",  # mul (including those of integer powers)
    "fma",  # mul+add pairs a compiler fuses (counted in add and mul too)
    "div",
    "sqrt",  # sqrt, rsqrt
    "transcendental",  # tan, pow, exp, log, atan2, ...
    "select",  # select, min, max, clamp, sign, floor, ...
    "compare",  # <, <=, ==, logical and/or/not, is_finite
    "convert",  # int <-> float conversions
    "free",  # abs, neg: source modifiers
    "uniform",  # operations on the parameters alone (folded or hoisted; not per evaluation)
)

_CATEGORY = {
    "add": "add", "sub": "add", "mul": "mul", "div": "div", "rem": "div",
    "sqrt": "sqrt", "rsqrt": "sqrt",
    **dict.fromkeys(
        ["tan", "sin", "cos", "atan", "atan2", "exp", "exp2", "log", "expm1", "log1p", "pow",
         "tanh", "logistic", "cbrt"], "transcendental"),
    **dict.fromkeys(["select_n", "max", "min", "clamp", "sign", "floor", "ceil", "round"], "select"),
    **dict.fromkeys(["lt", "le", "gt", "ge", "eq", "ne", "and", "or", "not", "is_finite"], "compare"),
    "convert": "convert", "abs": "free", "neg": "free",
}  # fmt: skip

#: Weight of each scalar primitive in full-rate FP32 ALU instructions (see the module Notes).
SHADER_WEIGHTS: Mapping[str, float] = {
    "add": 1, "sub": 1, "mul": 1,
    "div": 5,  # rcp (4) + mul
    "rem": 7,  # div + trunc + fma
    "sqrt": 5,  # rsq (4) + mul
    "rsqrt": 4,  # rsq
    "exp": 5, "log": 5,  # ex2 / lg2 (4) + a scaling mul
    "exp2": 4,
    "expm1": 8, "log1p": 8,  # exp/log plus a cancellation guard (assumption)
    "pow": 9,  # lg2 + mul + ex2
    "sin": 5, "cos": 5,  # range-reduction mul + sin/cos (4)
    "tan": 14,  # sin + cos + div
    "tanh": 10,  # ex2 + rcp + 2 ALU (assumption)
    "logistic": 10,  # ex2 + rcp + 2 ALU (assumption)
    "atan": 20, "atan2": 20,  # ~16-ALU polynomial + rcp (assumption; no hardware atan)
    "cbrt": 14,  # lg2 + mul + ex2 + Newton step (assumption)
    "select_n": 1, "max": 1, "min": 1, "clamp": 2, "sign": 2,
    "floor": 1, "ceil": 1, "round": 1,
    "lt": 1, "le": 1, "gt": 1, "ge": 1, "eq": 1, "ne": 1,
    "and": 1, "or": 1, "not": 1, "is_finite": 2,
    "convert": 4,  # int <-> float conversions run at quarter rate (CUDA guide, same table)
    "abs": 0, "neg": 0,
}  # fmt: skip


@dataclasses.dataclass(frozen=True)
class Cost:
    """The cost of one family (at given parameters).

    `ns_per_eval` is the median measured time per evaluation (float32, jitted, on this
    machine's default JAX device), `ns_iqr` its interquartile range, and
    `ratio_to_inverse_square` its ratio to `inverse_square` measured in the same run (None
    when not measured). `ops` counts the per-evaluation scalar operations by category
    (`CATEGORIES`), `shader_cost` weighs them (`SHADER_WEIGHTS`).
    """

    family: str
    ns_per_eval: float | None
    ratio_to_inverse_square: float | None
    ops: Mapping[str, int]
    shader_cost: float
    ns_iqr: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """A JSON-friendly dict."""
        out = dataclasses.asdict(self)
        out["ops"] = dict(self.ops)
        return out


# ----------------------------------------------------------------------------- op counts
def _fma_pairs(prog: Program, per_eval: set[int]) -> int:
    """Multiplies whose single use is an add or subtract, each add fusing at most one."""
    uses: dict[int, int] = {}
    for op in prog.ops:
        for a in op.args:
            if isinstance(a, Var):
                uses[a.id] = uses.get(a.id, 0) + 1
    if isinstance(prog.output, Var):
        uses[prog.output.id] = uses.get(prog.output.id, 0) + 1
    muls = {
        op.out.id
        for op in prog.ops
        if op.prim == "mul" and op.out.dtype == "f32" and op.out.id in per_eval
    }
    fused: set[int] = set()
    pairs = 0
    for op in prog.ops:
        if op.prim not in ("add", "sub") or op.out.id not in per_eval:
            continue
        for a in op.args:
            if isinstance(a, Var) and a.id in muls and uses.get(a.id) == 1 and a.id not in fused:
                fused.add(a.id)
                pairs += 1
                break
    return pairs


def form_cost(form: ShaderForm) -> float:
    """The weighted cost of a shader form (`SHADER_WEIGHTS`): its operations that read an
    input (those on the parameters alone are folded or hoisted), as `shader_cost` counts a
    traced program (no fusing)."""
    uniform = form.uniform_lets()
    names = {"saturate": "clamp", "select": "select_n"}

    def walk(e: Expr) -> float:
        if not isinstance(e, Call):
            return 0.0
        here = SHADER_WEIGHTS.get(names.get(e.op, e.op), 1) if reads(e, {"d"}, uniform) else 0
        return here + sum(walk(a) for a in e.args)

    return float(sum(walk(e) for n, e in form.lets if n not in uniform) + walk(form.result))


def _as_program(family: Family | type[Family] | str | Program) -> Program:
    return family if isinstance(family, Program) else trace(family)


def count_ops(family: Family | type[Family] | str | Program) -> dict[str, int]:
    """Per-evaluation scalar operation counts of `family(d)` by category (`CATEGORIES`).

    Counted on the traced computation (`jax.make_jaxpr`, sub-jaxprs inlined, integer
    powers expanded into XLA's multiplications, common subexpressions merged and dead code
    removed, as XLA and shader compilers do). Operations on the
    parameters alone are counted under "uniform", not in the other categories.
    """
    prog = _as_program(family)
    per_eval = prog.depends_on_d()
    counts = dict.fromkeys(CATEGORIES, 0)
    for op in prog.ops:
        if op.out.id in per_eval:
            counts[_CATEGORY[op.prim]] += 1
        else:
            counts["uniform"] += 1
    counts["fma"] = _fma_pairs(prog, per_eval)
    return counts


def shader_cost(family: Family | type[Family] | str | Program) -> float:
    """The weighted per-evaluation cost of `family(d)` in full-rate ALU instructions.

    The sum of `SHADER_WEIGHTS` over the operations that depend on `d`, less one for each
    multiply fused into an add (see the module Notes for the sources of the weights).
    """
    prog = _as_program(family)
    per_eval = prog.depends_on_d()
    total = sum(SHADER_WEIGHTS[op.prim] for op in prog.ops if op.out.id in per_eval)
    return float(total - _fma_pairs(prog, per_eval))


# ----------------------------------------------------------------------------- throughput
def measure_throughput(
    families: Iterable[Family | type[Family] | str],
    *,
    n: int = 1 << 18,
    repeats: int = 11,
    min_time: float = 1e-2,
    d_range: tuple[float, float] = (1e-3, 1e3),
) -> dict[str, tuple[float, float]]:
    """Nanoseconds per evaluation of each family: `{name: (median, interquartile range)}`.

    Each family is cast to float32, jitted with its parameters as compile-time constants
    (as a shader with baked parameters), and evaluated on `n` log-spaced distances in
    `d_range` on JAX's default device. Every repeat times each family in turn, in a new
    random order (interleaved, so drifts of the machine's load hit all alike); a repeat is the fastest of as many
    calls as last `min_time` seconds (so that another process's burst does not count), and
    the median over `repeats` is reported. Names must be distinct.
    """
    fams = [as_family(f) for f in families]
    names = [f.name for f in fams]
    if len(set(names)) != len(names):
        raise BadValueError(f"measure_throughput needs distinct family names, got {names}")
    if not (isinstance(n, int) and n >= 1024):
        raise BadValueError(f"n must be an integer >= 1024, got {n!r}")
    if not (isinstance(repeats, int) and repeats >= 1):
        raise BadValueError(f"repeats must be a positive integer, got {repeats!r}")
    lo, hi = d_range
    if not (0 < lo < hi < np.inf):
        raise BadValueError(f"d_range must be (lo, hi) with 0 < lo < hi, got {d_range!r}")
    d = jax.device_put(jnp.asarray(np.geomspace(lo, hi, n), jnp.float32))
    fns = []
    for fam in fams:
        fam32 = float32_family(fam)
        fn = jax.jit(lambda x, fam32=fam32: fam32(x))
        fn(d).block_until_ready()  # compile
        start = time.perf_counter()
        fn(d).block_until_ready()
        once = max(time.perf_counter() - start, 1e-7)
        fns.append((fn, max(1, int(np.ceil(min_time / once)))))
    samples: list[list[float]] = [[] for _ in fams]
    rng = np.random.default_rng(0)
    for _ in range(repeats):
        for k in rng.permutation(len(fns)):  # no family is always first after a slow one
            fn, inner = fns[k]
            best = np.inf
            for _ in range(inner):
                start = time.perf_counter()
                fn(d).block_until_ready()
                best = min(best, time.perf_counter() - start)
            samples[k].append(best / n * 1e9)
    result = {}
    for name, s in zip(names, samples, strict=True):
        q1, _, q3 = statistics.quantiles(s, n=4) if len(s) > 1 else (s[0], s[0], s[0])
        result[name] = (float(statistics.median(s)), float(q3 - q1))
    return result


# ----------------------------------------------------------------------------- cost records
def cost_table(
    families: Iterable[Family | type[Family] | str] | None = None,
    *,
    measure: bool = True,
    n: int = 1 << 18,
    repeats: int = 11,
) -> dict[str, Cost]:
    """`Cost` of each family (default: every registered family), by name.

    With `measure=False` only the deterministic counts are computed (`ns_per_eval` None),
    which takes milliseconds; with `measure=True` `inverse_square` is timed in the same run
    as the reference of `ratio_to_inverse_square`.
    """
    fams = [as_family(f) for f in (list_families() if families is None else families)]
    costs: dict[str, Cost] = {}
    timings: dict[str, tuple[float, float]] = {}
    if measure:
        ref = as_family("inverse_square")
        timed = fams if any(f.name == ref.name for f in fams) else [ref, *fams]
        timings = measure_throughput(timed, n=n, repeats=repeats)
    for fam in fams:
        prog = trace(fam)
        ns, iqr = timings.get(fam.name, (None, None))
        ratio = None
        if ns is not None:
            ratio = ns / timings["inverse_square"][0]
        costs[fam.name] = Cost(
            family=fam.name,
            ns_per_eval=ns,
            ratio_to_inverse_square=ratio,
            ops=count_ops(prog),
            shader_cost=shader_cost(prog),
            ns_iqr=iqr,
        )
    return costs


def family_cost(
    family: Family | type[Family] | str,
    *,
    measure: bool = True,
    n: int = 1 << 18,
    repeats: int = 11,
) -> Cost:
    """The `Cost` of one family (timed against `inverse_square` in the same run if `measure`)."""
    fam = as_family(family)
    return cost_table([fam], measure=measure, n=n, repeats=repeats)[fam.name]


# ----------------------------------------------------------------------------- Pareto front
@dataclasses.dataclass(frozen=True)
class ParetoFront:
    """The families no other family beats on both cost and error.

    `front` lists them by increasing cost (so by decreasing error); `dominated` maps every
    other family to the cheapest front member that is at least as cheap and at least as
    accurate (and strictly better in one); `cost` and `error` are the values used.
    """

    front: tuple[str, ...]
    dominated: Mapping[str, str]
    cost: Mapping[str, float]
    error: Mapping[str, float]

    def table(self) -> list[dict[str, Any]]:
        """One row per family, by cost: name, cost, error, on_front, dominated_by."""
        return [
            {
                "family": name,
                "cost": self.cost[name],
                "error": self.error[name],
                "on_front": name in self.front,
                "dominated_by": self.dominated.get(name),
            }
            for name in sorted(self.cost, key=lambda k: rank_key(self.cost[k], self.error[k], k))
        ]


def _cost_value(value: Any, by: str) -> float:
    if isinstance(value, Cost):
        v = getattr(value, by)
        if v is None:
            raise BadValueError(f"cost {by!r} of {value.family!r} was not measured")
        return float(v)
    return float(value)


def pareto_front(
    errors: Mapping[str, float],
    costs: Mapping[str, float | Cost],
    *,
    by: str = "shader_cost",
) -> ParetoFront:
    """The error-against-cost Pareto front of the families in both `errors` and `costs`.

    `errors`: family -> error (e.g. max relative error for one configuration; NaN counts
    as infinitely bad). `costs`: family -> a number or a `Cost`, from which the attribute
    `by` is used ("shader_cost", "ns_per_eval" or "ratio_to_inverse_square"). A family
    dominates another when it is no worse on both and strictly better on one.
    """
    if by not in ("shader_cost", "ns_per_eval", "ratio_to_inverse_square"):
        raise BadValueError(
            f"by must be 'shader_cost', 'ns_per_eval' or 'ratio_to_inverse_square', got {by!r}"
        )
    missing = sorted(set(errors) ^ set(costs))
    if missing:
        raise BadValueError(f"families {missing} have an error or a cost but not both")
    if not errors:
        raise BadValueError("pareto_front needs at least one family")
    cost = {k: _cost_value(v, by) for k, v in costs.items()}
    err = {}
    for k, v in errors.items():
        e = float(v)
        err[k] = np.inf if np.isnan(e) else e
        if err[k] < 0 or not np.isfinite(cost[k]) or cost[k] < 0:
            raise BadValueError(
                f"family {k!r}: error {v!r} must be >= 0 and cost {cost[k]!r} finite and >= 0"
            )
    order = sorted(cost, key=lambda k: rank_key(cost[k], err[k], k))

    def dominates(a: str, b: str) -> bool:
        return cost[a] <= cost[b] and err[a] <= err[b] and (cost[a] < cost[b] or err[a] < err[b])

    front = tuple(k for k in order if not any(dominates(o, k) for o in order if o != k))
    dominated = {k: next(f for f in front if dominates(f, k)) for k in order if k not in front}
    return ParetoFront(front=front, dominated=dominated, cost=cost, error=err)


def cheapest_within(
    errors: Mapping[str, float],
    costs: Mapping[str, float | Cost],
    tolerance: float,
    *,
    by: str = "shader_cost",
    params: Mapping[str, int] | None = None,
) -> list[str]:
    """The families whose error is at most `tolerance`, cheapest first.

    Ordered by `rank_key`, the tie-break of every verdict attenfit gives: at equal cost the
    smaller error, then the name; with `params` (family -> its number of parameters; 0 where
    not given), errors equal to 3 significant digits go to the family with fewer, as in the
    report and `attenfit scene`. NaN errors never qualify. The first entry is the
    recommendation, the second the runner-up; an empty list means no family meets the
    tolerance. `by` is as in `pareto_front`.
    """
    if not (isinstance(tolerance, int | float) and tolerance >= 0):
        raise BadValueError(f"tolerance must be a number >= 0, got {tolerance!r}")
    missing = sorted(set(errors) - set(costs))
    if missing:
        raise BadValueError(f"families {missing} have an error but no cost")
    counts = dict(params or {})
    for k, n in counts.items():
        if isinstance(n, bool) or not isinstance(n, int) or n < 0:
            raise BadValueError(f"params[{k!r}] must be an integer >= 0, got {n!r}")
    ok = [k for k, e in errors.items() if float(e) <= tolerance]
    return sorted(
        ok,
        key=lambda k: rank_key(_cost_value(costs[k], by), float(errors[k]), k, counts.get(k, 0)),
    )


# ----------------------------------------------------------------------------- the tie-break
def _shown(x: float) -> float:
    """`x` to 3 significant digits, as every table of attenfit prints an error."""
    return float(f"{x:.3g}")


def rank_key(
    cost: float | None, error: float | None, name: str, params: int = 0
) -> tuple[float, float, int, float, str]:
    """The order of every "cheapest model within the tolerance" attenfit names.

    One tie-break, for every verdict (`cheapest_within`, the report's decision table, a
    scene's recommendation and its per-light answers, the area models it escalates to;
    `attenfit._judge.rank` applies it):

    1. the smaller `cost` (None or NaN: after every known cost);
    2. the smaller `error` to 3 significant digits, as the tables print it (None or NaN:
       after every number);
    3. fewer `params`, the number of parameters the model takes: between two models that
       cost the same and whose errors agree to 3 digits the simpler one wins (a family
       whose extra parameter was fitted to 0 compiles to the simpler family's shader:
       `disk_facing` with r = 0 is `inverse_square`, off by rounding);
    4. the smaller `error` itself;
    5. `name` (a fitted variant is named `"<model> (fitted)"`, so at a full tie the model
       as published or shipped, whose name is a prefix of it, comes first).

    When every model has the same `params`, this is cost, then error, then name.
    """

    def number(x: float | None) -> float:
        return math.inf if x is None or math.isnan(x) else float(x)

    e = number(error)
    return (number(cost), _shown(e), int(params), e, name)


def _format_table(costs: Mapping[str, Cost], columns: Sequence[str] = CATEGORIES) -> str:
    """A plain-text table of `costs` (used by the benchmark)."""
    head = ["family", "ns/eval", "x inv-sq", "shader", *columns]
    rows = [head]
    for name, c in costs.items():
        rows.append(
            [
                name,
                "-" if c.ns_per_eval is None else f"{c.ns_per_eval:.3f}",
                "-" if c.ratio_to_inverse_square is None else f"{c.ratio_to_inverse_square:.2f}",
                f"{c.shader_cost:g}",
                *(str(c.ops[k]) for k in columns),
            ]
        )
    widths = [max(len(r[i]) for r in rows) for i in range(len(head))]
    return "\n".join(
        "  ".join(
            cell.ljust(w) if i == 0 else cell.rjust(w)
            for i, (cell, w) in enumerate(zip(r, widths, strict=True))
        )
        for r in rows
    )
