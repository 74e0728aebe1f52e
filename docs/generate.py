"""Regenerate every generated table and figure of the docs: `make docs`.

    python docs/generate.py                 # rewrite every generated section and figure
    python docs/generate.py NAME ...        # only these sections (see `SECTIONS`)
    python docs/generate.py --check         # exit 1 if a deterministic section is stale

A generated section sits in its page between `<!-- BEGIN generated: NAME ... -->` and
`<!-- END generated: NAME -->`; everything between is replaced. Every section here is
deterministic (counts, fitted values, errors: no timings), so `tests/test_docs_generated.py`
regenerates them and fails when the text in a page differs. Measured timings in the docs
are quoted by hand from a benchmark run and labelled with the machine.
"""

from __future__ import annotations

import dataclasses
import functools
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import jax

jax.config.update("jax_enable_x64", True)  # truth and fits in float64, as the CLI

import attenfit  # noqa: E402
from attenfit._atomic import atomic_write  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
SCENES = ROOT / "examples" / "scenes"
#: The example scenes, in the order the docs discuss them.
EXAMPLE_SCENES = ("room.toml", "vpl_on_surface.toml", "short_range.toml", "spotlight.toml")
FIGURES = ROOT / "docs" / "figures"


class Inputs:
    """What the sections are made from, computed once and only when a section needs it.

    The default report is built with operation counts but no timings (`cost="counts"`): every
    section is deterministic. The test suite may pass objects it has built already.
    """

    def __init__(self, report: Any = None, recommendations: dict[str, Any] | None = None):
        self._report = report
        self._recommendations = recommendations

    @functools.cached_property
    def report(self):
        if self._report is None:
            say = lambda s: print(f"docs: report: {s}", flush=True)  # noqa: E731
            self._report = attenfit.build_report(cost="counts", progress=say)
        return self._report

    @functools.cached_property
    def shapes(self) -> dict[str, Any]:
        """The rectangle's and the tube's rows (`build_report(shapes=...)`'s, alone)."""
        from attenfit._report import shape_rows

        say = lambda s: print(f"docs: shapes: {s}", flush=True)  # noqa: E731
        return shape_rows(progress=say)

    @functools.cached_property
    def recommendations(self) -> dict[str, Any]:
        if self._recommendations is None:
            self._recommendations = {
                name: attenfit.recommend(attenfit.Scene.load(SCENES / name), measure=False)
                for name in EXAMPLE_SCENES
            }
        return self._recommendations


# ----------------------------------------------------------------------------- sections
def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.3g}%"


def families_table(_: Inputs) -> str:
    """Every registered family: formula, parameters with defaults, source."""
    rows = ["| name | f(d) | parameters (defaults) | source |", "|---|---|---|---|"]
    for name in attenfit.list_families():
        info = attenfit.get_family(name).describe()
        params = []
        for p, v in info["params"].items():
            d = v["default"]
            shown = f"{len(d)} values" if isinstance(d, list) else f"{d:g}"
            bound = {"nonnegative": ", >= 0", "unit": ", in (0, 1)", "real": ", real"}.get(
                v["constraint"], ""
            )
            params.append(f"`{p}` ({shown}{bound})")
        formula = info["formula"].replace("|", "\\|")
        rows.append(f"| `{name}` | {formula} | {', '.join(params) or 'none'} | {info['source']} |")
    return "\n".join(rows)


def report_summary(inputs: Inputs) -> str:
    """The default report's summary table (README)."""
    return inputs.report.summary_markdown().rstrip()


def report_decision(inputs: Inputs) -> str:
    """The default report's decision table, "Which curve for which light" (README, report.md)."""
    return inputs.report.decision_markdown().rstrip()


def area_worst(inputs: Inputs) -> str:
    """Every area model's worst case per light and band, from the judge (docs/area.md)."""
    from attenfit._report._area_worst import area_worst_markdown

    return area_worst_markdown(inputs.report).rstrip()


def area_shapes(inputs: Inputs) -> str:
    """The rectangle's and the tube's ceiling and decision rows (docs/area.md), as
    `attenfit report --emitters rect,tube` writes them."""
    from attenfit._report._area_shapes import shapes_markdown
    from attenfit._report._decide import decision_markdown

    data = inputs.shapes
    return (shapes_markdown(data) + "\n" + decision_markdown(data["decisions"])).rstrip()


def report_findings(inputs: Inputs) -> str:
    """The numbers behind the seeds' claims, and the windows table (docs/report.md)."""
    rep = inputs.report
    out = [rep.findings_markdown().rstrip()]
    windows = rep.windows_markdown()
    if windows:
        out += ["", "Windows, as published: what each range costs inside it and what it drops.", ""]
        out.append(windows.rstrip())
    return "\n".join(out)


def published_rules(_: Inputs) -> str:
    """How `published_params` chooses each family's parameters (docs/report.md)."""
    return "\n".join(f"* {rule}" for rule in attenfit.report.PUBLISHED_RULES)


def scene_keys(_: Inputs) -> str:
    """The scene file format, key by key, from `attenfit.scene.SCENE_KEYS` (docs/scenes.md)."""
    out = []
    for table, keys in attenfit.scene.SCENE_KEYS.items():
        out += [f"`{table}`" if table != "top level" else "Top level", ""]
        out += ["| key | meaning |", "|---|---|"]
        out += [f"| `{k}` | {v} |" for k, v in keys.items()]
        out.append("")
    return "\n".join(out).rstrip()


def spotlight_toml(_: Inputs) -> str:
    """The example scene file shown in docs/scenes.md, as it is in examples/scenes/."""
    return "```toml\n" + (SCENES / "spotlight.toml").read_text(encoding="utf-8").strip() + "\n```"


def example_scenes(inputs: Inputs) -> str:
    """What `attenfit scene` recommends for each example scene (docs/scenes.md)."""
    recs = inputs.recommendations
    rows = [
        "| scene | tolerance | winner | its max error | shader cost | runner-up | families passing |",
        "|---|---|---|---|---|---|---|",
    ]
    notes = []
    for name in EXAMPLE_SCENES:
        rec = recs[name]
        w, r = rec.winner, rec.runner_up
        win = f"`{w.label}`" if w else f"none (closest `{rec.closest.label}`)"
        run = "-" if r is None else f"`{r.label}` ({_pct(r.error)}, cost {r.shader_cost:g})"
        n_pass = sum(c.status == "pass" for c in rec.candidates)
        n_excl = sum(c.status == "excluded" for c in rec.candidates)
        passing = f"{n_pass} of {len(rec.candidates)}" + (f" ({n_excl} excluded)" if n_excl else "")
        rows.append(
            f"| `{name}` | {_pct(rec.tolerance)} | {win} | {_pct(w.error if w else None)} "
            f"| {f'{w.shader_cost:g}' if w else '-'} | {run} | {passing} |"
        )
        if w is not None:
            params = "; ".join(
                f"light {i}: "
                + (
                    ", ".join(f"{k} = {v:.4g}" for k, v in p.items() if not isinstance(v, list))
                    or "no parameters"
                )
                for i, p in enumerate(w.params)
            )
            spot = ""
            if w.directional_params:
                spot = "; spot " + ", ".join(
                    f"umbra {d['umbra']:.3g} deg, penumbra {d['penumbra']:.3g} deg"
                    for d in w.directional_params
                    if d
                )
            notes.append(f"- `{name}`: {w.label}: {params}{spot}.")
    room, vpl, short, spot = (recs[n] for n in EXAMPLE_SCENES)
    by_vpl = {c.family: c for c in vpl.candidates}
    same = [
        f"`{c.family}`"
        for c in vpl.candidates
        if c.status == "pass"
        and c.shader_cost == vpl.winner.shader_cost
        and c.family != vpl.winner.family
    ]
    scene_fit = min(f["error"] for f in spot.directional_fits if "scene" in f["variant"])
    fitted_fit = min(f["error"] for f in spot.directional_fits if "fitted" in f["variant"])
    text = [
        *rows,
        "",
        "Fitted parameters of the winners:",
        "",
        *notes,
        "",
        f"`room.toml` confirms the seed's remark (Madams 2011, comment by John Hughes: at d/r "
        f'around 20 the attenuation "looks a LOT like 1/d^2"): `{room.winner.label}` is within '
        f"{_pct(room.winner.error)} (the bulb to {_pct(room.winner.error_by_light[0])}: a "
        f"uniform sphere is exactly a point light wherever no receiver sees it cut by its "
        f"horizon; the panel to {_pct(room.winner.error_by_light[1])}). "
        f"`vpl_on_surface.toml` puts receivers at d/r from 0.25: inverse square is off by "
        f"{_pct(by_vpl['inverse_square'].error)}; the winner `{vpl.winner.label}` is within "
        f"{_pct(vpl.winner.error)} at a shader cost of {vpl.winner.shader_cost:g}"
        + (f" (as cheap: {', '.join(same)}; the tie goes to the smaller error)" if same else "")
        + ". `short_range.toml` asks the "
        f"curve to reach 0 at the range, so only windowed families take part: "
        f"`{short.winner.label}` wins with {_pct(short.winner.error)}. `spotlight.toml` fits "
        f"the spot's falloff too: with the scene's angles the best falloff errs by "
        f"{_pct(scene_fit)}, with fitted angles by {_pct(fitted_fit)}.",
    ]
    return "\n".join(text)


def glsl_listing(_: Inputs) -> str:
    """`attenfit export yuksel --param r=0.05` (docs/shaders.md)."""
    text = attenfit.export.export(attenfit.Yuksel(r=0.05), "glsl")
    return "```glsl\n" + text.rstrip() + "\n```"


def op_counts(_: Inputs) -> str:
    """Operation counts and shader cost of every family (deterministic; docs/shaders.md)."""
    cols = ("add", "mul", "fma", "div", "sqrt", "transcendental", "select", "compare")
    rows = [
        "| family | shader cost | " + " | ".join(cols) + " |",
        "|---|---:|" + "---:|" * len(cols),
    ]
    for name in attenfit.list_families():
        ops = attenfit.count_ops(name)
        rows.append(
            f"| `{name}` | {attenfit.shader_cost(name):g} | "
            + " | ".join(str(ops[c]) for c in cols)
            + " |"
        )
    return "\n".join(rows)


class SkipSection(Exception):
    """A section that cannot be made on this machine (a compiler is missing): left as it is."""


def _compiled_rows():
    from attenfit._shaders._compilers import missing
    from attenfit._shaders._engines import engine_table

    why = missing("spirv")
    if why:
        raise SkipSection(f"SPIR-V counts need the SPIR-V compilers: {why}")
    return engine_table({n: attenfit.get_family(n)() for n in attenfit.list_families()})


def _versions(target: str) -> str:
    have = attenfit.cost.compilers()
    if target == "spirv":
        return f"glslangValidator {have['glslangValidator']}, spirv-opt {have['spirv-opt']}"
    lister = (
        f"nvdisasm {have['nvdisasm']}" if have.get("nvdisasm") else f"cuobjdump {have['cuobjdump']}"
    )
    return f"NVRTC {have['nvrtc']}, ptxas {have['ptxas']} (sm_89), {lister}"


def spirv_costs(_: Inputs) -> str:
    """SPIR-V instructions of each family's shader form, stable form and engine code."""
    rows = _compiled_rows()
    out = [
        f"Compiled with {_versions('spirv')}; default parameters baked in.",
        "",
        "| family | shader form | arithmetic | extended | select + branch | stable form | engine's code | shader / engine | engine function |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---|",
    ]
    for r in rows:
        sh, st = r["shader"], r["stable"]
        c = sh.spirv.classes
        form = "" if sh.form == "shader" else " (stable: no shader form)"
        eng = r.get("engine_spirv")
        ratio = f"{r['ratio']:.2f}" if "ratio" in r else "-"
        out.append(
            f"| `{r['family']}`{form} | {sh.spirv.total} | {c['arithmetic']} | {c['extended']} "
            f"| {c['select'] + c['branch']} | {st.spirv.total} | {eng.total if eng else '-'} "
            f"| {ratio} | {r.get('engine', '-')} |"
        )
    return "\n".join(out)


def sass_costs(_: Inputs) -> str:
    """NVIDIA SASS instructions (MUFU apart) of the shader form, stable form and engine code."""
    from attenfit._shaders._compilers import missing

    why = missing("sass")
    if why:
        raise SkipSection(f"SASS counts need NVIDIA's compilers: {why}")
    rows = _compiled_rows()
    out = [
        f"Compiled with {_versions('sass')}, `--use_fast_math`; default parameters baked in.",
        "",
        "| family | shader form | of which MUFU | stable form | of which MUFU | engine's code | of which MUFU |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for r in rows:
        sh, st, eng = r["shader"].sass, r["stable"].sass, r.get("engine_sass")
        out.append(
            f"| `{r['family']}` | {sh.total} | {sh.classes['mufu']} | {st.total} "
            f"| {st.classes['mufu']} | {eng.total if eng else '-'} "
            f"| {eng.classes['mufu'] if eng else '-'} |"
        )
    return "\n".join(out)


def _band(p, rng) -> str:
    if p is None or p.band is None:
        return "-"
    lo, hi = p.band
    low = "0" if lo <= 1e-7 else f"{lo:.3g} m"  # from the smallest distance the precision holds
    if rng is not None and hi >= 0.5 * rng:
        return f"{low} to (1 - {1 - hi / rng:.1e}) R"
    return f"{low} to {hi:.3g} m"


def precision_table(_: Inputs) -> str:
    """float32 and float16 bands within 1% of float64, and what fails (docs/shaders.md)."""
    out = [
        "| family | float32: within 1% | float16: within 1% | float16: what fails where (d in m) |",
        "|---|---|---|---|",
    ]
    for name in attenfit.list_families():
        fam = attenfit.get_family(name)()
        p32 = attenfit.cost.precision(fam, "float32")
        p16 = attenfit.cost.precision(fam, "float16")
        rng = fam.range_distance()
        rng = None if rng is None else float(rng)
        if p16 is None:
            out.append(f"| `{name}` | no shader form | - | - |")
            continue
        out.append(f"| `{name}` | {_band(p32, rng)} | {_band(p16, rng)} | {p16.describe()} |")
    return "\n".join(out)


@dataclasses.dataclass(frozen=True)
class Section:
    page: str
    make: Callable[[Inputs], str]


#: Every generated section: name -> (page, generator).
SECTIONS = {
    "report-decision": Section("README.md", report_decision),
    "report-decision-doc": Section("docs/report.md", report_decision),
    "report-summary": Section("README.md", report_summary),
    "report-findings": Section("docs/report.md", report_findings),
    "area-worst": Section("docs/area.md", area_worst),
    "area-shapes": Section("docs/area.md", area_shapes),
    "published-rules": Section("docs/report.md", published_rules),
    "families-table": Section("docs/families.md", families_table),
    "scene-keys": Section("docs/scenes.md", scene_keys),
    "spotlight-toml": Section("docs/scenes.md", spotlight_toml),
    "example-scenes": Section("docs/scenes.md", example_scenes),
    "glsl-yuksel": Section("docs/shaders.md", glsl_listing),
    "op-counts": Section("docs/shaders.md", op_counts),
    "spirv-costs": Section("docs/shaders.md", spirv_costs),
    "sass-costs": Section("docs/shaders.md", sass_costs),
    "precision-table": Section("docs/shaders.md", precision_table),
}


# ----------------------------------------------------------------------------- figures
def figures(inputs: Inputs) -> list[Path]:
    """The figures the docs show, drawn from the default report."""
    import matplotlib as mpl

    from attenfit._report import _figures

    rep = inputs.report
    cfg = next((c for c in rep.configs if c.kind == "disk" and c.sweep is not None), rep.configs[0])
    fig = _figures._two_panel(rep, cfg, "published", "attenuation")
    FIGURES.mkdir(parents=True, exist_ok=True)
    target = FIGURES / "report_attenuation.png"
    with mpl.rc_context(attenfit.plots.STYLE):
        atomic_write(target, lambda p: fig.savefig(p, dpi=100, format="png"), force=True)
    return [target, yuksel_fig3()]


def yuksel_fig3() -> Path:
    """Yuksel 2020's Figure 3 reproduced (examples/reproduce_yuksel_fig3.py), for docs/examples.md."""
    import importlib.util
    import shutil
    import tempfile

    script = ROOT / "examples" / "reproduce_yuksel_fig3.py"
    spec = importlib.util.spec_from_file_location("reproduce_yuksel_fig3", script)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    with tempfile.TemporaryDirectory() as tmp:
        module.main(["--out", str(Path(tmp) / "out")])
        target = FIGURES / "yuksel_fig3.png"
        shutil.copyfile(Path(tmp) / "out" / "yuksel_fig3.png", target)
    return target


# ----------------------------------------------------------------------------- pages
def _markers(name: str) -> re.Pattern:
    return re.compile(
        rf"(<!-- BEGIN generated: {re.escape(name)}\b[^>]*-->\n)(.*?)(<!-- END generated: "
        rf"{re.escape(name)} -->)",
        re.S,
    )


def current(name: str) -> str:
    """The text of section `name` as it stands in its page."""
    page = ROOT / SECTIONS[name].page
    m = _markers(name).search(page.read_text(encoding="utf-8"))
    if m is None:
        raise SystemExit(f"{page.name}: no generated section {name!r} (markers missing)")
    return m.group(2).rstrip("\n")


def rewrite(name: str, text: str) -> bool:
    """Put `text` into section `name` of its page; True if the page changed."""
    page = ROOT / SECTIONS[name].page
    old = page.read_text(encoding="utf-8")
    m = _markers(name).search(old)
    if m is None:
        raise SystemExit(f"{page.name}: no generated section {name!r} (markers missing)")
    new = old[: m.start(2)] + text.rstrip("\n") + "\n" + old[m.end(2) :]
    if new != old:
        atomic_write(page, new, force=True)
    return new != old


def main(argv: list[str]) -> int:
    check = "--check" in argv
    names = [a for a in argv if not a.startswith("--")] or list(SECTIONS)
    unknown = [n for n in names if n not in SECTIONS]
    if unknown:
        print(f"docs: unknown sections {unknown}; known: {', '.join(SECTIONS)}", file=sys.stderr)
        return 2
    from attenfit._fit import enable_persistent_cache

    enable_persistent_cache()
    inputs = Inputs()
    stale = []
    for name in names:
        try:
            text = SECTIONS[name].make(inputs)
        except SkipSection as why:
            print(f"docs: left {name} as it is: {why}")
            continue
        if check:
            if text.rstrip("\n") != current(name):
                stale.append(name)
        elif rewrite(name, text):
            print(f"docs: rewrote {name} in {SECTIONS[name].page}")
    if check:
        print(f"docs: stale sections: {stale}" if stale else "docs: every section is current")
        return 1 if stale else 0
    if set(names) == set(SECTIONS):
        for path in figures(inputs):
            print(f"docs: drew {path.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
