"""Compiled solves, cached by everything they depend on: jit with XLA's CPU fast math,
chunked `vmap` for a batch, and the packed inputs of a single fit.

A solve of attenfit's own models is also kept on disk across processes (`_Persistent`):
its traced and lowered program (`jax.export`) in attenfit's cache, its compiled executable
in JAX's persistent compilation cache, so that a later process neither traces nor compiles
it. Tracing a solve costs 0.5-2 s; loading it back, about 0.1-0.3 s.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Iterator
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np
from jaxtyping import Array

from .. import _cache, _progress
from ._layout import packed_slices
from ._spec import Spec, free_kinds


class _OnHost:
    """A jitted packed solve, returning its outputs as one numpy array (`packed_layout` along
    the last axis, after any batch axis).

    A float32 solve is traced and run with JAX's x64 mode off, as JAX runs float32 by
    default, whatever the caller's mode: with it on, optimistix's dogleg mixes float64 into
    a float32 solve and fails to trace (its `newton_norm` and `cauchy_norm` state).
    """

    def __init__(self, fn: Callable, dtype: np.dtype, key: str | None = None):
        self.fn, self.x64, self.key = fn, np.dtype(dtype).itemsize == 8, key

    def __call__(self, *args) -> np.ndarray:
        if not _REUSE or self.key is None:
            return self._solve(*args)
        ident = _cache.fingerprint(self.key, jax.config.jax_enable_x64, args)
        out = _cache.read_array("result", ident)
        if out is None or out.ndim not in (1, 2):
            out = self._solve(*args)
            _cache.write_array("result", ident, out)
        return out

    def _solve(self, *args) -> np.ndarray:
        if self.x64:
            out = self.fn(*args)
        else:
            with jax.enable_x64(False):
                out = self.fn(*args)
        # + 0.0 turns -0.0 into 0.0: the solve's fast math (`_COMPILER_OPTIONS`) may drop
        # the sign of a zero, so a parameter on its bound could come back as -0.0
        return np.asarray(out) + 0.0


#: Whether solves of attenfit's own models reuse the outputs cached for the same inputs
#: (`reuse_results`); not a list when off.
_REUSE: list[bool] = []


@contextlib.contextmanager
def reuse_results() -> Iterator[None]:
    """Within this context, a solve of attenfit's own models (a family or area model defined
    in attenfit, or a function with a `cache_key()`) whose exact inputs this code version
    solved before, in any process, returns the outputs cached then, and caches those it
    computes (`attenfit._cache`, kind "result"). A command that asks the same question
    again (an unchanged scene) then runs no solve; any changed input (a receiver, a start,
    an option) is another key, and solved. Off by default: a benchmark or a test of the
    solve itself must run it."""
    _REUSE.append(True)
    try:
        yield
    finally:
        _REUSE.pop()


#: Problems per vmapped chunk in `fit_many`: chunks run one after another (`lax.map`), and
#: each stops when its own slowest problem does, so one straggler holds up its chunk only.
#: Every operation of a step has a fixed cost per chunk, so small chunks pay it many times:
#: 1,000 polynomial fits (4 steps each), median wall time: 26.5 ms in chunks of 64, 24.2 ms
#: of 128, 24.1 ms of 256, 25.9 ms of 512 (two chunks), 19.6 ms in one. (With optimistix's
#: own Gauss-Newton state, 64 was best: its steps cost four times more per problem.)
_CHUNK = 1024


def _by_batch_size(large: Callable, small: Callable) -> Callable:
    """`large` for a batch of at least `_ROUNDS_MIN_BATCH` problems, else `small`."""

    def run(*args):
        batch = jax.tree_util.tree_leaves(args)[0].shape[0]
        return (large if batch >= _ROUNDS_MIN_BATCH else small)(*args)

    return run


def _chunked(vfn: Callable, chunk: int) -> Callable:
    """`vfn` (vmapped over axis 0) applied chunk by chunk with `lax.map`; pads the batch."""

    def run(*args):
        batch = jax.tree_util.tree_leaves(args)[0].shape[0]
        if batch <= chunk:
            return vfn(*args)
        n_chunks = -(-batch // chunk)
        pad = n_chunks * chunk - batch

        def split(x):
            x = jnp.concatenate([x, jnp.repeat(x[:1], pad, axis=0)]) if pad else x
            return x.reshape((n_chunks, chunk, *x.shape[1:]))

        out = jax.lax.map(lambda a: vfn(*a), jax.tree_util.tree_map(split, args))
        return out.reshape((n_chunks * chunk, *out.shape[2:]))[:batch]

    return run


#: A batch of at least `_ROUNDS_MIN_BATCH` problems is solved in two rounds: every problem
#: with at most `_FIRST_ROUND` steps, then those it left unfinished again from their start
#: with every step allowed, `_REST_SHARE` of the batch at a time. A vmapped solve steps
#: every problem until its slowest one has finished, so one straggler costs the whole batch
#: its steps: 1,000 `cryengine_linear` fits took median 0 steps and 36 at most, `madams_tan`
#: 18 and 71 (`python -m benchmarks fit`). The second round repeats the stragglers' first
#: steps, and each problem takes the path it takes alone (as `fit`'s), so results are the
#: same as in one round.
_FIRST_ROUND = 16
_ROUNDS_MIN_BATCH = 256
_REST_SHARE = 8


def _in_rounds(first: Callable, rest: Callable, status_col: int, max_steps_code: int) -> Callable:
    """`rest` (the full solve, packed outputs) as `first` (the same, fewer steps allowed),
    then `rest` again on the problems whose status column reads `max_steps_code`."""

    def run(*args):
        out = first(*args)
        batch = out.shape[0]
        share = batch // _REST_SHARE
        unfinished = out[:, status_col] == max_steps_code
        count = jnp.sum(unfinished)
        order = jnp.argsort(jnp.invert(unfinished), stable=True)  # unfinished first
        order = jnp.concatenate([order, order[:share]])  # slices never run past the end

        def body(i, out):
            pos = i * share + jnp.arange(share)
            idx = jax.lax.dynamic_slice(order, (i * share,), (share,))
            res = rest(*jax.tree_util.tree_map(lambda x: x[idx], args))
            return out.at[idx].set(jnp.where((pos < count)[:, None], res, out[idx]))

        return jax.lax.fori_loop(0, (count + share - 1) // share, body, out)

    return run


_COMPILED: dict[Any, Callable] = {}


class _Persistent:
    """A jitted solve whose traced and lowered program is kept on disk per input shapes
    (`jax.export`, in attenfit's cache under `key`), so that a later process skips tracing.

    `key` names everything the program computes; None keeps nothing on disk (a user's own
    family or function, whose code attenfit's cache cannot vouch for).
    """

    def __init__(self, build: Callable[[], Callable], key: str | None):
        self.build, self.key = build, key
        self.by_shapes: dict[Any, Callable] = {}
        self._jitted: Callable | None = None

    @property
    def jitted(self) -> Callable:
        """The jitted solve, built on first use: a program read back from the cache needs
        neither it nor optimistix (whose import is 0.15 s of a warm `attenfit scene`)."""
        if self._jitted is None:
            self._jitted = self.build()
        return self._jitted

    def __call__(self, *args):
        shapes = (
            jax.tree_util.tree_structure(args),
            tuple((np.shape(x), np.result_type(x).str) for x in jax.tree_util.tree_leaves(args)),
        )
        fn = self.by_shapes.get(shapes)
        if fn is None:
            fn = self.by_shapes[shapes] = self._program(args, shapes)
        return fn(*args)

    def _program(self, args, shapes) -> Callable:
        if self.key is None:
            return self.jitted
        # an exported program runs only on the platform it was exported for (a cache shared
        # by a GPU and a CPU process must keep both)
        key = (
            f"{self.key}|{shapes[0]}|{shapes[1]}|x64={jax.config.jax_enable_x64}"
            f"|{jax.default_backend()}"
        )
        blob = _cache.read("solve", key)
        if blob is not None:
            try:
                return _jit_exported(jax.export.deserialize(bytearray(blob)))
            except Exception:  # written by a library version the checksum cannot tell apart
                _cache.notice("ignoring a cache entry this JAX cannot read; it will be rebuilt")
        _progress.note("compiling (first run only: later runs load it from the cache)")
        try:
            exported = jax.export.export(self.jitted)(*args)
        except ValueError:  # e.g. LAPACK custom calls (optimistix's QR): not exportable
            return self.jitted
        _cache.write("solve", key, exported.serialize())
        return _jit_exported(exported)


def _jit_exported(exported: Any) -> Callable:
    """The exported program, jitted as every solve is (its compiled executable then comes
    from JAX's persistent compilation cache when an earlier process compiled it)."""
    return jax.jit(exported.call, compiler_options=_COMPILER_OPTIONS)


def _persistent_key(spec: Spec, solver: Any) -> str | None:
    """What a solve computes, as text, when attenfit can vouch for it across processes: a
    family defined in attenfit, or a function whose `cache_key()` returns a text; a solver
    by name."""
    if not isinstance(solver, str):
        return None
    kind, detail = spec.key
    if isinstance(kind, type):  # a model class and its pytree structure
        if not _cache.covers(kind):
            return None
        return f"family:{kind.__module__}.{kind.__qualname__}:{detail}"
    cache_key = getattr(kind, "cache_key", None)  # a (fn, params) model
    text = None if cache_key is None else cache_key()
    return None if text is None else f"fn:{text}:{detail}"


#: XLA options of every compiled solve: the CPU backend's fast math less what XLA keeps
#: exact by default (NaN and infinity semantics, division, math functions), which leaves
#: reassociation, contraction into FMAs, and ignoring the sign of zero (outputs are made
#: +0.0 in `_OnHost`). Reassociation lets LLVM vectorise the sums over the samples (a
#: strict reduction is a chain of scalar adds): the compiled solve of 1,000 polynomial
#: fits of 256 samples took 4.4-5.0 ms instead of 8.4-10.3. Results move within the
#: tolerances: the 19 parameterised families fitted to their own curves over d from 1e-3
#: to 1e3 and 1e12 times a scale of 1e-6, 1 or 1e6, float32 and float64 (227 fits),
#: converge as with a strict compilation, parameters within 2e-6 relative of its
#: (`tests/test_fit.py::test_compiled_solve_options_keep_the_answer`). An exact fit's
#: residuals are rounding noise rather than exact zeros (f / t - 1 is one FMA), which the
#: solver's rounding-level loss (`exact_loss`) ends at once.
_COMPILER_OPTIONS = {"xla_cpu_enable_fast_math": True}


def _read_in_order(flat: Array) -> Array:
    """`flat` as every kernel of a single fit reads it: after one reduction over it.

    XLA's CPU runtime runs a compiled computation as a graph of small kernels, and hands
    half of the ready ones to another thread whenever more than eight are ready at once.
    A single fit is a few hundred kernels of microseconds each, so such a hand-off costs
    more than the work it shares: one per call, at the start, where some fifteen kernels
    read the inputs independently (slices, reciprocals, the candidates' setup), cost the
    benchmark's polynomial fit 0.13 ms of its 0.19 ms compiled solve (measured with the
    solve run inline, `jax_cpu_enable_async_dispatch=False`; 0.23 -> 0.19 ms dispatched as
    by default). Reading the inputs through one reduction makes every reader wait for it,
    so they become ready a few at a time. The same concern keeps the solve's other
    independent pieces few and wide: the candidates are evaluated as one batch, the end
    point's outputs picked in one selection, the constraints mapped as one vector.

    The inputs are validated finite, so the selection never changes them (a non-finite
    one would make every input NaN).
    """
    return jnp.where(jnp.max(jnp.abs(flat)) < jnp.inf, flat, jnp.nan)


def _unflatten_inputs(
    spec: Spec, flat: Array, weighted: bool
) -> tuple[dict[str, Array], Array, Array, Array]:
    """Start values, d, target and weights from `fit`'s one input vector (their concatenation;
    without weights when not `weighted`: None, all 1)."""
    values, off = {}, 0
    for name, shape in zip(spec.names, spec.shapes, strict=True):
        size = math.prod(shape)
        values[name] = flat[off : off + size].reshape(shape)
        off += size
    rows = max(spec.inputs, 1)  # an area model's d is `inputs` rows of n
    n = (flat.shape[0] - off) // (rows + (2 if weighted else 1))
    d = flat[off : off + rows * n]
    d = d.reshape(rows, n) if spec.inputs else d
    off += rows * n
    target = flat[off : off + n]
    return values, d, target, flat[off + n :] if weighted else None


def compiled_solve(
    spec, free, loss, solver, max_steps, rtol, atol, guess, batched, dtype, weighted
):
    """The jitted solve for this configuration, from the cache (jit re-specialises on shapes).

    Called as `fn(flat)` for one problem (`_unflatten_inputs`), and as `fn(values, d,
    target, weights)` (or without `weights` when not `weighted`) for a batch.
    """
    key = (
        dtype,
        weighted,
        spec.key,
        spec.names,
        spec.shapes,
        free,
        loss,
        solver,
        max_steps,
        rtol,
        atol,
        guess,
        batched,
    )
    fn = _COMPILED.get(key)
    if fn is None:
        options = (spec, free, loss, solver, max_steps, rtol, atol, guess, batched, dtype, weighted)
        persistent = _persistent_key(spec, solver)
        if persistent is not None:
            persistent = f"{persistent}|{key[3:]}|{np.dtype(dtype).name}|weighted={weighted}"
        fn = _OnHost(_Persistent(lambda: _jitted_solve(*options), persistent), dtype, persistent)
        _COMPILED[key] = fn
    return fn


def _jitted_solve(
    spec, free, loss, solver, max_steps, rtol, atol, guess, batched, dtype, weighted
) -> Callable:
    """The jitted solve of `compiled_solve`'s configuration (traced on its first call)."""
    from ._problem import build_problem
    from ._result import max_steps_code
    from ._solvers import make_solver

    reflected = tuple(kind == "nonnegative" for kind in free_kinds(spec, free))
    solver_obj = (
        make_solver(solver, rtol, atol, float(np.finfo(dtype).eps), batched, reflected)
        if isinstance(solver, str)
        else solver
    )
    run = build_problem(spec, free, loss, solver_obj, max_steps, guess, rtol, atol, batched)
    if batched:
        if max_steps > 2 * _FIRST_ROUND:
            first = build_problem(
                spec, free, loss, solver_obj, _FIRST_ROUND, guess, rtol, atol, batched
            )
            rounds = _in_rounds(
                first,
                run,
                packed_slices(len(free_kinds(spec, free)))["result"].start,
                max_steps_code(),
            )
            run = _by_batch_size(rounds, run)
        fn = jax.jit(_chunked(run, _CHUNK), compiler_options=_COMPILER_OPTIONS)
    else:
        fn = jax.jit(
            lambda flat: run(*_unflatten_inputs(spec, _read_in_order(flat), weighted)),
            compiler_options=_COMPILER_OPTIONS,
        )
    return fn
