"""The figures of the comparison report (`attenfit.report.Report.write_figures`).

Built from `attenfit.plots`; one function per figure kind, each saving PNG (and SVG) and
closing its figure. Curves come as small multiples: families without a range, then the
windowed ones, in panels of at most six curves (each with its own colour and line style),
the truth in black; distances are in light radii (d / r) throughout, with r given.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .._curves import get_family
from . import _plots as plots
from ._cost_plot import decision_cost_figure
from ._display import plot_display_models
from ._metrics import GAP_BAND_LABELS

WINDOWED = ("smooth", "hard")


def _split(report) -> tuple[list[str], list[str]]:

    plain, windowed = [], []
    for fam in report.families:
        try:
            w = get_family(fam).window
        except Exception:
            w = "none"
        (windowed if w in WINDOWED else plain).append(fam)
    return plain, windowed


def _vals(report, fam, cfg, mode, part):
    """The stored values of a family that evaluated fine (None otherwise)."""
    row = report._get(fam, cfg.name, mode)
    v = report._values.get((fam, cfg.name, mode))
    if row is None or row["status"] != "ok" or v is None:
        return None
    return v.get(part)


def _curves(report, cfg, fams, mode, part="sweep") -> dict[str, np.ndarray]:
    out = {}
    for fam in fams:
        v = _vals(report, fam, cfg, mode, part)
        if v is not None:
            out[fam] = v
    return out


def _groups(report) -> list[tuple[list[str], str]]:
    """Panels of at most `plots.GROUP` families: those without a range, then windowed ones."""
    plain, windowed = _split(report)
    out = []
    for fams, what in ((plain, "without a range"), (windowed, "windowed")):
        k = -(-len(fams) // plots.GROUP) if fams else 0
        for i in range(k):  # even splits: 9 -> 5 + 4, 11 -> 6 + 5
            part = fams[i * len(fams) // k : (i + 1) * len(fams) // k]
            out.append((part, what if k == 1 else f"{what} ({i + 1}/{k})"))
    return out


def _two_panel(report, cfg, mode: str, kind: str):
    """Small multiples of the curves (or their errors) of `cfg` in `mode`."""
    import matplotlib as mpl

    groups = _groups(report)
    sw = cfg.sweep
    ncols = 1 if len(groups) == 1 else 2
    nrows = -(-len(groups) // ncols)
    with mpl.rc_context(plots.STYLE):
        fig = plots.new_figure((5.6 * ncols, 4.6 * nrows))
        axes = fig.subplots(nrows, ncols, squeeze=False, sharex=True, sharey=True)
        mode_text = "as published" if mode == "published" else "fitted"
        fig.suptitle(
            f"{cfg.name} (r = {cfg.radius:g} m), {mode_text}: "
            + ("attenuation against the truth (black)" if kind == "attenuation"
               else "|relative error| on the facing sweep"),
            fontsize=11,
        )  # fmt: skip
        for ax in axes.ravel()[len(groups) :]:
            ax.set_visible(False)
        for ax, (fams, what) in zip(axes.ravel(), groups, strict=False):
            styles = plots.curve_styles(fams)
            dense = kind == "attenuation" and sw.dense_d is not None
            curves = _curves(report, cfg, fams, mode, "dense" if dense else "sweep")
            title = f"families {what}"
            if kind == "attenuation":
                pts = None
                if sw.stderr is not None or dense:
                    pts = (sw.d, sw.truth, sw.stderr)
                plots.plot_attenuation(
                    sw.dense_d if dense else sw.d,
                    curves,
                    None if pts is not None else sw.truth,
                    r=cfg.radius,
                    truth_label=f"truth ({cfg.source.split(' ')[0]})",
                    truth_points=pts,
                    truth_points_label=f"truth ({cfg.source}{', ±2σ' if sw.stderr is not None else ''})",
                    styles=styles,
                    title=title,
                    legend="below",
                    ax=ax,
                )
                lo = max(float(np.nanmin(sw.truth)) * 0.3, 1e-12)
                hi = float(np.nanmax(sw.truth)) * 30
                ax.set_ylim(lo, hi)
            else:
                plots.plot_relative_error(
                    sw.d,
                    curves,
                    sw.truth,
                    r=cfg.radius,
                    styles=styles,
                    title=title,
                    legend="below",
                    ax=ax,
                )
                rg = [report._get(f, cfg.name, mode) for f in fams]
                if any(((x or {}).get("window") or {}).get("range") for x in rg):
                    ax.text(0.01, 0.99, "windows are judged for d ≤ range/2", va="top",
                            transform=ax.transAxes, fontsize=7, color="0.3")  # fmt: skip
    return fig


def _in_r(extent, r: float):
    return tuple(float(e) / r for e in extent)


def _plane_errors(report, cfg):
    pl = cfg.plane
    models = {}
    for fam in report.families:
        v = _vals(report, fam, cfg, "published", "plane")
        if v is not None:
            models[fam] = pl.weight * v
    fig, _ = plots.plot_plane_comparison(
        pl.E, models, _in_r(pl.extent, cfg.radius), truth_label=pl.truth_label, ncols=5,
        unit="r",
    )  # fmt: skip
    fig.suptitle(
        f"{cfg.name} (r = {cfg.radius:g} m): error of each family as published on the plane",
        fontsize=10,
    )
    return fig


def _decided(report, cfg) -> dict[str, np.ndarray]:
    """The models the decision table names for `cfg`'s light, one per band (the one it names
    at the tightest tolerance), as images of its plane."""
    from .._curves import get_area_model
    from .._truth import area_irradiance

    pl = cfg.plane
    out: dict[str, np.ndarray] = {}
    if pl.points is None:
        return out
    seen: set[str] = set()
    for e in report.decisions():
        if e["config"] != cfg.name or e["model"] is None or e["band"] in seen:
            continue
        seen.add(e["band"])
        label = f"{e['model']} ({GAP_BAND_LABELS[e['band']]}, {e['tolerance']:.0%})"
        if any(k.startswith(f"{e['model']} (") for k in out):
            continue
        if e.get("model_kind") == "area model":
            E = area_irradiance(get_area_model(e["model"])(), cfg.emitter, pl.points, pl.normals)
            out[label] = np.asarray(E, dtype=np.float64).reshape(pl.E.shape)
        else:
            v = _vals(report, e["model"], cfg, e["mode"], "plane")
            if v is not None:
                out[label] = pl.weight * v
    return out


def _side_by_side(report, cfg):
    """The truth once, the decision's models for this light (one per band) and published
    curves beside them, as displayed (one exposure), and their errors in stops (`_display`)."""
    pl = cfg.plane
    models: dict[str, np.ndarray] = {}
    truth, label = pl.E, pl.truth_label
    if pl.E_exact is not None:  # a Monte Carlo image: the exact one is a model beside it
        models["exact (attenfit.irradiance)"] = pl.E_exact
    models.update(_decided(report, cfg))
    for fam in ("inverse_square", "yuksel_adhoc", "yuksel", "unreal_window", "madams_cutoff"):
        if len(models) >= 4:
            break
        if any(k.startswith(f"{fam} (") for k in models):
            continue  # the decision names it already
        v = _vals(report, fam, cfg, "published", "plane")
        if v is not None:
            models[f"{fam} (published)"] = pl.weight * v
    if not models:
        return None
    fig, _ = plot_display_models(
        truth, models, _in_r(pl.extent, cfg.radius), truth_label=label, unit="r"
    )
    fig.suptitle(f"{cfg.name} (r = {cfg.radius:g} m): {pl.description.split(';')[0]}", fontsize=10)
    return fig


def _cost_vs_error(report):
    """The decision's error against the compiled cost, both model classes
    (`_cost_plot.decision_cost_figure`)."""
    return decision_cost_figure(report)


def _witness_z(report, cfg):
    """The z-scores of the exact values against a Monte Carlo dataset: their histogram over
    the standard normal's density, with the median |z| (0.674 for an unbiased renderer)."""
    import matplotlib as mpl

    z = np.asarray(cfg.witness_z, np.float64)
    z = z[np.isfinite(z)]
    if not z.size:
        return None
    with mpl.rc_context(plots.STYLE):
        fig = plots.new_figure((5.6, 3.6))
        ax = fig.subplots()
        lim = max(4.0, float(np.ceil(min(np.max(np.abs(z)), 8.0))))
        clipped = np.clip(z, -lim, lim)
        ax.hist(clipped, bins=min(60, max(10, z.size // 20)), range=(-lim, lim), density=True,
                color="#0072B2", alpha=0.7, label=f"{z.size} receivers")  # fmt: skip
        x = np.linspace(-lim, lim, 200)
        ax.plot(
            x, np.exp(-0.5 * x * x) / np.sqrt(2 * np.pi), color="black", label="standard normal"
        )
        ax.set_xlabel("z = (exact − Monte Carlo) / standard error (|z| > edge drawn at it)")
        ax.set_ylabel("density")
        ax.set_title(
            f"{cfg.name} ({cfg.source}): median |z| = {np.median(np.abs(z)):.3g} (unbiased: 0.674)"
        )
        ax.legend(loc="upper right", frameon=False)
    return fig


def _rows(report, cfgs, modes) -> list:
    """What the figures of configurations `cfgs` in `modes` read of the results: each row's
    status, window and sweep errors, and the stored values."""
    out = []
    for cfg in cfgs:
        for fam in report.families:
            for mode in modes:
                row = report._get(fam, cfg.name, mode)
                if row is not None:
                    values = report._values.get((fam, cfg.name, mode))
                    fields = (row["status"], row.get("window"), row.get("sweep"))
                    out.append((fam, cfg.name, mode, fields, values))
    return out


def _inputs(report, cfg, key: str, modes: tuple[str, ...]) -> tuple:
    """Everything figure `key` is drawn from (its cache key, with the code's version): the
    families and how they are grouped, its configuration(s), their rows in `modes`, and for
    the figures that show them, the decisions and the shader costs."""
    plain, windowed = _split(report)
    cfgs = [c for c in report.configs if c.sweep is not None] if cfg is None else [cfg]
    extra: tuple = ()
    if key.endswith("_side_by_side"):
        extra = tuple(e for e in report.decisions() if e["config"] == cfg.name)
    elif cfg is None:
        costs = {k: v.get("shader_cost") for k, v in report.costs.items()}
        extra = (costs, next(iter(report.costs.values()), {}).get("cost_label"))
    # of a configuration, the part the figure shows: its sweep, its plane (and the emitter
    # the decision's area models are evaluated on), or its witness's z-scores
    part = ("plane", "emitter") if "_plane_" in key else ("witness_z",)
    part = ("sweep",) if cfg is None or key.endswith(("_published", "_fitted")) else part
    shown = [(c.name, c.kind, c.radius, c.source, *(getattr(c, a) for a in part)) for c in cfgs]
    return (key, plain, windowed, shown, _rows(report, cfgs, modes), extra)


def figure_jobs(report, *, published_only: bool = False):
    """(configuration, key, make, inputs) for every figure, in report order; `make()` returns
    a figure or None, `inputs()` what it is drawn from (`_inputs`). With `published_only`,
    only those that need nothing beyond the published results (what `prerender` can draw
    while the fits run)."""
    jobs = []
    both = ("published", "fitted")
    for cfg in report.configs:
        if cfg.sweep is not None:
            for mode in ("published",) if published_only else both:
                if not any(report._get(f, cfg.name, mode) for f in report.families):
                    continue
                for kind, name in (("attenuation", "attenuation"), ("error", "error")):
                    key = f"{cfg.name}_{name}_{mode}"
                    jobs.append(
                        (
                            cfg,
                            key,
                            lambda cfg=cfg, mode=mode, kind=kind: _two_panel(
                                report, cfg, mode, kind
                            ),
                            lambda cfg=cfg, key=key, mode=mode: _inputs(report, cfg, key, (mode,)),
                        )
                    )
        if getattr(cfg, "witness_z", None) is not None:
            key = f"{cfg.name}_witness_z"
            jobs.append(
                (
                    cfg,
                    key,
                    lambda cfg=cfg: _witness_z(report, cfg),
                    lambda cfg=cfg, key=key: _inputs(report, cfg, key, ()),
                )
            )
        if cfg.plane is not None:
            key = f"{cfg.name}_plane_errors"
            jobs.append(
                (
                    cfg,
                    key,
                    lambda cfg=cfg: _plane_errors(report, cfg),
                    lambda cfg=cfg, key=key: _inputs(report, cfg, key, ("published",)),
                )
            )
            if not published_only:  # it shows the decision's models: after the fits
                key = f"{cfg.name}_plane_side_by_side"
                jobs.append(
                    (
                        cfg,
                        key,
                        lambda cfg=cfg: _side_by_side(report, cfg),
                        lambda cfg=cfg, key=key: _inputs(report, cfg, key, both),
                    )
                )
    if not published_only:
        jobs.append(
            (
                None,
                "cost_vs_error",
                lambda: _cost_vs_error(report),
                lambda: _inputs(report, None, "cost_vs_error", both),
            )
        )
    return jobs


#: Figures drawn in this process (what the figure cache spares; its tests count them).
DRAWN: list[str] = []


def _render(job, dpi: int, svg: bool) -> tuple[bytes, bytes | None] | None:
    """A figure's PNG (and SVG) bytes: from attenfit's cache when the same inputs, dpi and
    code drew it before, else drawn now and cached. None: the figure has nothing to show."""
    from .. import _cache

    _cfg, key, make, inputs = job
    try:
        ident = _cache.fingerprint(inputs(), dpi, _matplotlib_version())
    except Exception:  # a value the fingerprint cannot walk: draw it
        ident = None
    if ident is not None:
        png = _cache.read("figure", ident + " png")
        svg_bytes = _cache.read("figure", ident + " svg") if svg else None
        if png is not None and png.startswith(_PNG) and (svg_bytes is not None or not svg):
            return png, svg_bytes
    fig = make()
    if fig is None:
        return None
    DRAWN.append(key)
    png, svg_bytes = _to_bytes(fig, dpi, svg)
    if ident is not None:
        _cache.write("figure", ident + " png", png)
        if svg_bytes is not None:
            _cache.write("figure", ident + " svg", svg_bytes)
    return png, svg_bytes


_PNG = b"\x89PNG\r\n\x1a\n"


def _matplotlib_version() -> str:
    from importlib import metadata

    try:
        return metadata.version("matplotlib")
    except metadata.PackageNotFoundError:
        return "none"


def _to_bytes(fig, dpi: int, svg: bool) -> tuple[bytes, bytes | None]:
    """`fig` as PNG bytes at `dpi` (and SVG bytes when `svg`)."""
    import io

    import matplotlib as mpl

    with mpl.rc_context(plots.STYLE):
        png = io.BytesIO()
        fig.savefig(png, dpi=dpi, format="png")
        svg_bytes = None
        if svg:
            buf = io.BytesIO()
            fig.savefig(buf, format="svg")
            svg_bytes = buf.getvalue()
    return png.getvalue(), svg_bytes


def prerender(
    report, *, dpi: int = 100, svg: bool = False
) -> dict[str, tuple[bytes, bytes | None]]:
    """Draw the figures that need only the published results into memory: key -> (PNG, SVG).

    `build_report` runs this in a thread while the fits compile (XLA releases the GIL), so the
    two cores work at once; `draw_all` then writes these bytes instead of drawing again.
    Figures drawn from the same inputs before come from the cache (`_render`).
    """
    out: dict[str, tuple[bytes, bytes | None]] = {}
    for job in figure_jobs(report, published_only=True):
        drawn = _render(job, dpi, svg)
        if drawn is not None:
            out[job[1]] = drawn
    return out


def draw_all(
    report,
    folder: Path,
    *,
    dpi: int = 100,
    svg: bool = False,
    progress=None,
    prerendered: dict[str, tuple[bytes, bytes | None]] | None = None,
) -> dict[str, Path]:
    """Draw every figure of `report` into `folder`; return figure key -> PNG path.

    Figures in `prerendered` (from `prerender`, same dpi and formats) are written, not redrawn;
    those drawn from the same inputs before come from the cache (`_render`).
    """
    out: dict[str, Path] = {}
    say = progress or (lambda s: None)
    prerendered = prerendered or {}
    current = None
    for job in figure_jobs(report):
        cfg, key = job[0], job[1]
        if cfg is not None and cfg is not current:
            current = cfg
            say(f"figures: {cfg.name}")
        if key in prerendered and (prerendered[key][1] is not None or not svg):
            drawn = prerendered[key]
        else:
            drawn = _render(job, dpi, svg)
        if drawn is None:
            continue
        (folder / f"{key}.png").write_bytes(drawn[0])
        if svg:
            (folder / f"{key}.svg").write_bytes(drawn[1])
        out[key] = folder / f"{key}.png"
    return out
