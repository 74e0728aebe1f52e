"""The comparison report: how each attenuation curve approximates real lights.

`build_report(...)` evaluates every family against the exact irradiance of each emitter, both
**as published** (parameters from the family's source, with the light's radius and a range
from a documented threshold, see `published_params`) and **fitted** (least squares with
`attenfit.fit_many`), and returns a `Report`; `Report.write(folder)` writes `report.md`,
`report.json` (every number), `results.csv` (one row per family x configuration x mode) and
the figures (PNG, and SVG when asked) into a folder that appears only when complete.
"""

from __future__ import annotations

import datetime as _dt
import re
import time
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .. import _budget, _progress
from .._curves import Family, get_family, list_families
from .._errors import BadTypeError, BadValueError, UnknownNameError
from .._truth import emitter_from_dict
from .._version import __version__
from . import _figures
from ._area_shapes import SHAPE_GRID, SHAPE_LIGHTS, shape_sweep, shapes_data, split_shapes
from ._configs import (
    PLANE_PX,
    PUBLISHED_CUTOFF,
    SWEEP_N,
    Config,
    check_dataset,
    dataset_config,
    default_emitters,
    emitter_config,
    emitter_kind,
)
from ._document import Report
from ._evaluate import evaluate_row, failed_row, family_costs, truth_interpolator
from ._findings import seed_findings
from ._fit_all import fit_all
from ._published import published_params, range_of, range_params, shape_free


# ============================================================================ building
def resolve_families(families: Sequence[str | type] | None) -> list[type]:

    if families is None:
        return [get_family(n) for n in list_families()]
    if isinstance(families, str):
        families = [families]
    out = []
    for f in families:
        if isinstance(f, str):
            out.append(get_family(f))
        elif isinstance(f, type) and issubclass(f, Family):
            out.append(f)
        else:
            raise BadTypeError(f"families must be names or Family subclasses, got {f!r}")
    if not out:
        raise BadValueError("families must name at least one family")
    return out


def resolve_emitters(emitters: Sequence[Any] | Mapping[str, Any] | None) -> dict[str, Any]:
    if emitters is None:
        return default_emitters()
    if isinstance(emitters, Mapping):
        return dict(emitters)
    if isinstance(emitters, str):
        emitters = [emitters]
    out: dict[str, Any] = {}
    defaults = None
    for e in emitters:
        if isinstance(e, str):
            defaults = defaults or default_emitters()
            if e not in defaults:
                raise UnknownNameError(
                    f"unknown emitter {e!r}; the report knows {', '.join(defaults)} (and "
                    f"{', '.join(SHAPE_LIGHTS)}, judged on planes beside them)"
                )
            out[e] = defaults[e]
        else:
            name = emitter_kind(e)
            k, i = name, 2
            while k in out:
                k, i = f"{name}{i}", i + 1
            out[k] = e
    return out


def _as_float64(ems: dict[str, Any]) -> dict[str, Any]:
    """The emitters rebuilt with float64 fields (the report computes in float64)."""

    return {k: emitter_from_dict(e.to_dict()) for k, e in ems.items()}


def _stack_params(starts: list[dict[str, Any]]) -> dict[str, np.ndarray]:
    return {k: np.stack([np.asarray(s[k], np.float64) for s in starts]) for k in starts[0]}


def build_report(
    families: Sequence[str | type] | None = None,
    emitters: Sequence[Any] | Mapping[str, Any] | None = None,
    datasets: Sequence[Any] | Mapping[str, Any] | None = None,
    *,
    fitted: bool = True,
    sweep_n: int = SWEEP_N,
    plane_px: int = PLANE_PX,
    cost: bool | str = True,
    figures_early: bool = False,
    ceiling: bool = False,
    shapes: Sequence[str] = (),
    shape_grid: int = SHAPE_GRID,
    progress: Callable[[str], None] | None = None,
) -> Report:
    """Compare `families` (default: every registered one) against `emitters` and `datasets`.

    Args:
        families: family names or classes.
        emitters: emitters or their names in `default_emitters()` ("sphere", "disk"); a mapping
            gives them names. Default: the sphere and the disk. "rect", "tube" go to `shapes`.
        datasets: `attenfit.Dataset`s (e.g. Mitsuba renders), or a mapping name -> dataset;
            each adds a configuration (see the module docstring).
        fitted: also fit every family (the "fitted" mode); False gives "published" only.
        sweep_n, plane_px: samples per sweep and pixels per plane side.
        cost: each family's cost: True, operation counts and measured time per evaluation;
            "counts", the operation counts only (deterministic, faster); False, none.
        figures_early: draw the published figures in a second thread while the fits run, for
            a report that will be written (`Report.write` then uses them).
        ceiling: also compute the section "what no distance curve can fix" (`_ceiling`:
            the point-light model's ceiling against the area models; minutes).
        shapes, shape_grid: also "rect", "tube" (`shape_rows`; its search grid's side).
        progress: called with one line per stage (the CLI prints it on stderr).
    """
    import jax

    say = progress or (lambda s: None)
    t_start = time.perf_counter()
    emitters, shapes = _split(emitters, shapes, shape_grid)
    classes = resolve_families(families)
    ds_items = _dataset_items(datasets)
    _check_size(emitters, ds_items, sweep_n, plane_px, cost)
    timings: dict[str, float] = {}
    with jax.enable_x64(True):
        t = time.perf_counter()
        configs = _configs(emitters, ds_items, int(sweep_n), int(plane_px), say)
        timings["truth"] = time.perf_counter() - t
        t = time.perf_counter()
        say(f"published: {len(classes)} families x {len(configs)} configurations")
        pub, models, results, values = _published_rows(classes, configs)
        timings["published"] = time.perf_counter() - t
        painter = (
            _start_prerender(classes, configs, results, models, values)
            if fitted and figures_early
            else None
        )
        if fitted:
            t = time.perf_counter()
            _fitted_rows(classes, configs, pub, models, results, values, say)
            timings["fit"] = time.perf_counter() - t
        findings = seed_findings(classes, configs, results, models)
    if painter is not None:  # often the longest wait of a warm report: say so
        say("the published figures (drawn in a second thread while the fits ran)")
    prerendered = painter.result() if painter is not None else {}  # joined before timing costs
    costs: dict[str, Any] = {}
    if cost:
        t = time.perf_counter()
        say(f"cost: {len(classes)} families")
        costs = family_costs(
            [c.name for c in classes],
            {cls.name: models[(cls.name, configs[0].name, "published")] for cls in classes},
            measure=cost is True,
        )
        timings["cost"] = time.perf_counter() - t
    extra = _shape_section(classes, shapes, int(sweep_n), fitted, int(shape_grid), say, timings)
    meta = _meta(t_start, timings, sweep_n, plane_px) | extra
    if ceiling:
        meta["ceiling"] = _ceiling_section(say)
    return Report([c.name for c in classes], configs, results, findings, costs, meta, models,
                  values, prerendered)  # fmt: skip


def _shape_section(classes, shapes, sweep_n: int, fitted: bool, grid: int, say, timings) -> dict:
    """`{"shapes": ...}` (`_shapes`, timed) where shape lights are named, else `{}`."""
    if not shapes:
        return {}
    t = time.perf_counter()
    out = {"shapes": _shapes(classes, shapes, sweep_n, fitted, grid, say)}
    timings["shapes"] = time.perf_counter() - t
    return out


def _ceiling_section(say) -> dict[str, Any]:
    """The numbers of the section "what no distance curve can fix" (`_ceiling`)."""
    from ._ceiling import ceiling_data

    say("what no distance curve can fix: the ceiling and the area models")
    return ceiling_data()


def _split(emitters: Any, shapes: Any, grid: Any) -> tuple[Any, tuple[str, ...]]:
    """(the emitters, the shape lights): those named among the emitters and in `shapes`."""
    emitters, named = split_shapes(emitters)
    more = [shapes] if isinstance(shapes, str) else list(shapes)
    return emitters, _check_shapes([*named, *more], grid)


def _check_shapes(shapes: Sequence[Any], grid: Any) -> tuple[str, ...]:
    """The shape lights named, each once, in the judge's order; refuses any other value."""
    for s in shapes:
        if s not in SHAPE_LIGHTS:
            raise UnknownNameError(
                f"unknown shape light {s!r}; the report judges {', '.join(SHAPE_LIGHTS)} on "
                "its planes (and sphere, disk as emitters)"
            )
    if isinstance(grid, bool) or not isinstance(grid, int) or grid < 3:
        raise BadValueError(f"shape_grid must be an integer >= 3, got {grid!r}")
    return tuple(s for s in SHAPE_LIGHTS if s in shapes)


def shape_rows(
    families: Sequence[str | type] | None = None,
    shapes: Sequence[str] = SHAPE_LIGHTS,
    *,
    sweep_n: int = SWEEP_N,
    fitted: bool = True,
    grid: int = SHAPE_GRID,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """The rectangle's and the tube's rows alone, JSON-ready: what `build_report(shapes=...)`
    keeps in `meta["shapes"]` (`_area_shapes.shapes_data`; docs/area.md's generated table)."""
    classes = resolve_families(families)
    lights = _check_shapes([shapes] if isinstance(shapes, str) else shapes, grid)
    return _shapes(classes, lights, int(sweep_n), fitted, int(grid), progress or (lambda s: None))


def _shapes(classes, lights, sweep_n: int, fitted: bool, grid: int, say) -> dict[str, Any]:
    """The rectangle's and the tube's rows (`_area_shapes`): every family on each light's
    facing sweep as published and fitted (as every light's rows are made), then every model
    judged on the light's planes."""
    import jax

    with jax.enable_x64(True):
        sweeps = [shape_sweep(light, sweep_n) for light in lights]
        say(f"published: {len(classes)} families x the {', '.join(lights)} sweeps")
        pub, models, results, values = _published_rows(classes, sweeps)
        if fitted:
            _fitted_rows(classes, sweeps, pub, models, results, values, say)
        return shapes_data(sweeps, models, results, grid=grid, say=say)


def _dataset_items(datasets: Any) -> list[tuple[str, Any]]:
    """The datasets as (name, dataset) pairs, each checked; unnamed ones after their generator."""
    if isinstance(datasets, Mapping):
        ds_items = list(datasets.items())
    else:
        ds_items = []
        for i, ds in enumerate(datasets or []):
            prov = dict(getattr(ds, "provenance", {}) or {})
            ds_items.append((f"{prov.get('generator', 'dataset')}-{i + 1}", ds))
    for name, ds in ds_items:
        _check_name(name)
        check_dataset(name, ds)
    return ds_items


def _check_size(emitters: Any, ds_items: list, sweep_n: int, plane_px: int, cost: Any) -> None:
    """Refuse a bad `cost`, samplings below 8 and reports over the memory budget, before any
    work."""
    if cost not in (True, False, "counts"):
        raise BadValueError(f"cost must be True, False or 'counts', got {cost!r}")
    if int(sweep_n) < 8 or int(plane_px) < 8:
        raise BadValueError(f"sweep_n and plane_px must be >= 8, got {sweep_n} and {plane_px}")
    n_configs = len(resolve_emitters(emitters)) + len(ds_items)
    _budget.check(
        BYTES_BASE + n_configs * BYTES_PER_SAMPLE * (int(plane_px) ** 2 + int(sweep_n)),
        f"a report of {n_configs} configurations with {plane_px} x {plane_px} planes and "
        f"{sweep_n}-distance sweeps",
        "a smaller plane_px (--plane-px) or sweep_n (--sweep-n)",
    )


def _configs(emitters, ds_items, sweep_n: int, plane_px: int, say) -> list[Config]:
    """Every configuration's truth: the emitters' (sweep, plane, receivers), the datasets'."""
    configs: list[Config] = []
    ems = _as_float64(resolve_emitters(emitters))
    for name in ems:
        _check_name(name)
    for name, em in ems.items():
        say(f"truth: {name} ({sweep_n} distances, {plane_px} x {plane_px} plane)")
        configs.append(emitter_config(name, em, sweep_n, plane_px))
    for name, ds in ds_items:
        say(f"dataset: {name} ({len(ds)} samples)")
        configs.append(dataset_config(name, ds, sweep_n))
    return configs


def _published_rows(classes, configs):
    """Every family with its published parameters on every configuration: the parameters
    and notes, the models, the result rows and the stored values."""
    results: list[dict[str, Any]] = []
    models: dict[tuple[str, str, str], Any] = {}
    values: dict[tuple[str, str, str], dict[str, np.ndarray]] = {}
    pub: dict[tuple[str, str], tuple[dict, str]] = {}
    for cls in classes:
        for c in configs:
            params, note = published_params(cls, c.radius, truth_interpolator(c))
            pub[(cls.name, c.name)] = (params, note)
            model = cls(**params)
            models[(cls.name, c.name, "published")] = model
            results.append(evaluate_row(cls.name, c, "published", model, note=note, store=values))
    return pub, models, results, values


def _fitted_rows(classes, configs, pub, models, results, values, say) -> None:
    """Fit every family on the sweep configurations (one solve); a plane-only configuration
    (a dataset image) shows the fits of its emitter kind."""
    sweep_cfgs = [c for c in configs if c.sweep is not None]
    say(f"fit: {len(classes)} families x {len(sweep_cfgs)} configurations (one fit_many solve)")
    _fit_families(classes, sweep_cfgs, pub, models, results, values)
    for c in configs:
        if c.sweep is not None:
            continue
        for cls in classes:
            src = next((s for s in sweep_cfgs
                        if s.kind == c.kind and (cls.name, s.name, "fitted") in models), None)  # fmt: skip
            if src is None:
                continue
            m = models[(cls.name, src.name, "fitted")]
            models[(cls.name, c.name, "fitted")] = m
            results.append(evaluate_row(cls.name, c, "fitted", m, note=f"fitted on {src.name}",
                                        store=values))  # fmt: skip


def _meta(t_start: float, timings: dict[str, float], sweep_n: int, plane_px: int) -> dict:
    import jax

    return {
        "version": __version__,
        "created": _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "build_seconds": time.perf_counter() - t_start,
        "timings": timings,
        "published_cutoff": PUBLISHED_CUTOFF,
        "sweep_n": int(sweep_n),
        "plane_px": int(plane_px),
        "jax": jax.__version__,
        "backend": jax.default_backend(),
    }


class _Painter:
    """A thread drawing the published figures while the fits run (see `_figures.prerender`)."""

    def __init__(self, report: Report):
        import threading

        self._report = report
        self._out: dict[str, tuple[bytes, bytes | None]] = {}
        self._thread = threading.Thread(target=self._run, name="attenfit-figures", daemon=True)
        self._thread.start()

    def _run(self) -> None:

        try:
            self._out = _figures.prerender(self._report)
        except Exception:  # drawn again, in the main thread, by Report.write
            self._out = {}

    def result(self) -> dict[str, tuple[bytes, bytes | None]]:
        self._thread.join()
        return self._out


def _start_prerender(classes, configs, results, models, values) -> _Painter | None:
    """Start drawing the published figures in a thread (None if threads are unavailable)."""
    published = [r for r in results if r["mode"] == "published"]
    draft = Report(
        [c.name for c in classes], configs, published, [], {}, {}, dict(models), dict(values)
    )
    try:
        return _Painter(draft)
    except RuntimeError:
        return None


def _fit_range(cls: type, start: Mapping[str, Any]) -> float | None:
    """The range inside which a windowed family is fitted and judged: its published one."""
    return range_of(cls(**start))


def _fit_families(classes, sweep_cfgs, pub, models, results, values) -> None:
    """`_fit_rows` with a count of the (family, configuration) rows done (a bar, or lines)."""
    total = len(classes) * len(sweep_cfgs)
    with _progress.count(total, "fit: rows (a family on a configuration)") as bar:
        _fit_rows(classes, sweep_cfgs, pub, models, results, values, bar)


def _fit_rows(classes, sweep_cfgs, pub, models, results, values, bar) -> None:
    """Fit every family on every sweep, in one solve per sample count (`_report_fit`).

    Only shape parameters are free (`shape_free`): a range is the user's budget and stays at
    its published value. Windowed families are fitted where they are judged, d <= range/2
    (weights 0 beyond). A family with nothing free keeps its published parameters. If the
    combined solve fails as a whole, each row is marked failed with the error.
    """
    groups: dict[int, list[Config]] = {}
    for c in sweep_cfgs:
        groups.setdefault(int(c.sweep.d.size), []).append(c)
    fixed = {cls: range_params(cls) for cls in classes}
    for cfgs in groups.values():
        problems, keys = [], []
        for cls in classes:
            for c in cfgs:
                start = pub[(cls.name, c.name)][0]
                rg = _fit_range(cls, start)
                if not shape_free(cls):
                    _keep_published(cls, c, models, results, values)
                    bar.update()
                    continue
                d = c.sweep.d
                w = (d <= 0.5 * rg).astype(np.float64) if rg is not None else np.ones_like(d)
                problems.append((cls, start, d, c.sweep.truth, w))
                keys.append((cls, c, rg))
        if not problems:
            continue
        try:
            outs, error = fit_all(problems, fixed=fixed), ""
        except Exception as exc:  # e.g. a user's family that cannot be traced under a switch
            outs, error = [None] * len(problems), f"{type(exc).__name__}: {exc}"
        for (cls, c, rg), out in zip(keys, outs, strict=True):
            bar.update()
            start = pub[(cls.name, c.name)][0]
            results.append(_fitted_row(cls, c, rg, out, error, start, models, values))


def _keep_published(cls, c, models, results, values) -> None:
    """A family with nothing free: its fitted row is its published model."""
    model = models[(cls.name, c.name, "published")]
    models[(cls.name, c.name, "fitted")] = model
    note = (
        f"nothing to fit ({', '.join(range_params(cls))} is the range, kept fixed): "
        "fitted = published"
        if range_params(cls)
        else "no parameter: fitted = published"
    )
    results.append(evaluate_row(cls.name, c, "fitted", model, note=note, store=values))


def _fitted_row(cls, c, rg, out, error: str, start, models, values) -> dict[str, Any]:
    """The result row of one fit (`out`: `(params, info)`, None when the solve failed)."""
    if out is None:
        return failed_row(cls.name, c, f"fit error: {error}")
    params, info = out
    if params is None:
        return failed_row(cls.name, c, f"fit did not converge: {_why(info, start)}", info)
    try:
        model = cls(**params)
    except Exception as exc:
        return failed_row(cls.name, c, f"fitted parameters rejected: {exc}", info)
    models[(cls.name, c.name, "fitted")] = model
    note = f"free: {', '.join(info['free']) or 'none'}"
    if range_params(cls):
        note += f"; {', '.join(range_params(cls))} fixed (the range)"
    moved = _moved(info, start)
    if moved:  # converged where the loss reached rounding level, the optimum at a limit
        note += f"; {'; '.join(moved)}: no finite optimum"
    return evaluate_row(cls.name, c, "fitted", model, note=note, fit=info, store=values, range_=rg)


def _moved(info: Mapping[str, Any], start: Mapping[str, Any]) -> list[str]:
    """The positive scalar parameters a fit drove towards 0 or infinity, in words."""
    moved = []
    for k, v in (info.get("last_params") or {}).items():
        s0 = start.get(k)
        if s0 is None or np.ndim(v) or np.ndim(s0) or not float(s0) > 0:
            continue
        if 0 <= float(v) < 1e-2 * float(s0):
            moved.append(f"{k} heads to 0 ({k} = {float(v):.2g})")
        elif float(v) > 30 * float(s0):
            moved.append(f"{k} heads to infinity ({k} = {float(v):.3g})")
    return moved


def _why(info: Mapping[str, Any], start: Mapping[str, Any]) -> str:
    """Why a fit did not converge, in words: a parameter running off to a bound says so."""
    moved = _moved(info, start)
    if moved:
        return (
            f"no finite optimum: {'; '.join(moved)} after {info.get('steps')} steps, "
            f"loss {float(info.get('loss', float('nan'))):.2g}"
        )
    return str(info.get("message", ""))


#: Peak memory of a report: a baseline and so much per sample (pixel or distance) of each
#: configuration, measured by `python -m benchmarks memory` (about 2 kB) and rounded up.
BYTES_BASE = 1 << 30
BYTES_PER_SAMPLE = 4096

_NAME = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.+-]{0,63}")


def _check_name(name: object) -> None:
    """A configuration's name heads tables and figures and names files: plain characters only."""
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        raise BadValueError(
            f"configuration name {name!r} must be 1-64 letters, digits or '_.+-' "
            "(it names the report's files), starting with a letter or digit"
        )
