"""Regenerate the README's "Scene files" section: the format (from `attenfit.scene.SCENE_KEYS`)
and the recommendation for each example scene (from running `attenfit.recommend` on it).

    .venv/bin/python examples/scenes/readme_section.py          # rewrite README.md
    .venv/bin/python examples/scenes/readme_section.py --print  # print the section only

The section sits between `<!-- BEGIN SECTION:scene -->` and `<!-- END SECTION:scene -->`
(first run: it replaces the placeholder line `<!-- SECTION:scene -->`). Rankings use the
operation count, so the text does not depend on the machine's timing (`measure=False`).
"""

from __future__ import annotations

import sys
from pathlib import Path

import jax

jax.config.update("jax_enable_x64", True)  # as the CLI: truth and fits in float64

from attenfit._compile_cache import enable_persistent_cache  # noqa: E402

import attenfit  # noqa: E402
from attenfit._atomic import atomic_write  # noqa: E402
from attenfit.scene import SCENE_KEYS, Scene  # noqa: E402

HERE = Path(__file__).resolve().parent
README = HERE.parent.parent / "README.md"
BEGIN, END = "<!-- BEGIN SECTION:scene -->", "<!-- END SECTION:scene -->"
PLACEHOLDER = "<!-- SECTION:scene -->"
ORDER = ("room.toml", "vpl_on_surface.toml", "short_range.toml", "spotlight.toml")

INTRO = """\
### Scene files: model only what the scene needs

A scene file lists the lights, the receivers and the error a scene can tolerate; `attenfit
scene FILE` computes the exact irradiance of exactly those lights at exactly those receivers
(their radii, distances and angles, nothing else), fits every family the scene's
constraints allow, judges each by its largest error over the receivers and recommends the
cheapest within tolerance, with its parameters baked into GLSL/HLSL/WGSL/C (`attenfit.export`).

```
attenfit scene examples/scenes/room.toml                  # print the recommendation (Markdown)
attenfit scene examples/scenes/room.toml --json           # the same as JSON
attenfit scene examples/scenes/room.toml --out room/      # also write the files below
attenfit scene FILE --out DIR --force                     # replace an existing DIR
attenfit scene FILE --no-measure                          # skip timing (rank by op count, error)
```

`--out DIR` writes `recommendation.md`, `recommendation.json`, the winner's shader
functions `attenfit_<family>.{glsl,hlsl,wgsl,c}` (one light: parameters baked in; several:
uniforms, with the per-light values in the report; a spot adds `attenfit_spot_falloff`)
and `errors.png` (the judged error of the winner, runner-up and a few others against d/r,
one point per receiver), atomically. Exit codes: 0 (also when no family meets the
tolerance: the output says so and names the closest), 2 for a bad scene file (one line
naming the file, the table and the key, e.g. `scene.toml: [[lights]][1].radius: must be a
positive number, got -1`; tables of an array count from 0). In Python:
`attenfit.Scene.load(path)`, `attenfit.recommend(scene)` (or `scene.recommend()`) return
a `Recommendation` with `winner`, `runner_up`, `closest`, `candidates` (each with
`status`, `reason`, `error`, `shader_cost`, fitted `params` per light), `shaders`,
`to_dict()`, `to_markdown()`, `save(dir)` and `plot_errors()`.

**How a scene is judged.** The error of a receiver is `|E_model - E_true| / max(E_true,
error_floor * E_peak)`, with `E_peak` the light's brightest judged receiver: relative error
where the light is bright, and relative to the floor where it is dim. Receivers where the
truth is 0 (outside a spot's cone) are judged relative to `E_peak` (or the floor). Not
judged: receivers beyond a light's `range` (the engine culls them) and receivers facing
away from the light's centre (every point-light model gives 0 there; the report counts
those still lit by the horizon-clipped emitter as `unlit`). Each family is fitted per light
in one `fit_many` solve, with the judged error as the residual; length parameters start at
the light's radius; a light's `range` is pinned into the family's range parameter (with
Madams' `d_max = range - r` and `madams_cutoff`'s `cutoff = (r/range)^2` tied to the fitted
`r`; a light without a range gives windows a range 10 times the farthest receiver).
`reach_zero_at_range` excludes the unwindowed families and checks `f(range) = 0` after the
fit. Candidates within tolerance are ranked by shader cost (`attenfit.cost.shader_cost`,
the operation count: deterministic, and about the GPU shader rather than this machine's
CPU), then by error; measured ns/eval is reported next to it. A spot's true angular
profile (`profile`, default `aperture`: a circular source behind a circular opening, the
visible fraction of the source) is matched by `spot_frostbite` and `spot_threejs`, each with
the scene's angles and with both angles fitted; each family gets the cheapest variant that
keeps it within tolerance.
"""


def format_tables() -> str:
    out = ["#### The format, key by key", ""]
    for table, keys in SCENE_KEYS.items():
        out += [f"`{table}`" if table != "top level" else "Top level", ""]
        out += ["| key | meaning |", "|---|---|"]
        out += [f"| `{k}` | {v} |" for k, v in keys.items()]
        out.append("")
    out += [
        "An example (`examples/scenes/spotlight.toml`):",
        "",
        "```toml",
        (HERE / "spotlight.toml").read_text(encoding="utf-8").strip(),
        "```",
        "",
    ]
    return "\n".join(out)


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.3g}%"


def examples_table() -> str:
    rows = [
        "#### The example scenes (generated by `examples/scenes/readme_section.py`)",
        "",
        "| scene | tolerance | winner | its max error | shader cost | runner-up | what it shows |",
        "|---|---|---|---|---|---|---|",
    ]
    notes = []
    recs = {}
    for name in ORDER:
        scene = Scene.load(HERE / name)
        rec = recs[name] = attenfit.recommend(scene, measure=False)
        by = {c.family: c for c in rec.candidates}
        w, r = rec.winner, rec.runner_up
        win = f"`{w.label}`" if w else f"none (closest `{rec.closest.label}`)"
        run = "-"
        if r is not None:
            run = f"`{r.label}` ({_pct(r.error)}, cost {r.shader_cost:g})"
        inv = by.get("inverse_square")
        inv_txt = (
            f"inverse_square: {inv.status}"
            + (f", {_pct(inv.error)}" if inv.error is not None else f" ({inv.reason})")
            if inv
            else ""
        )
        n_pass = sum(c.status == "pass" for c in rec.candidates)
        n_excl = sum(c.status == "excluded" for c in rec.candidates)
        what = f"{n_pass} of {len(rec.candidates)} families pass ({n_excl} excluded); {inv_txt}"
        rows.append(
            f"| `{name}` | {_pct(scene.tolerance)} | {win} | {_pct(w.error if w else None)} "
            f"| {f'{w.shader_cost:g}' if w else '-'} | {run} | {what} |"
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
                sp = [d for d in w.directional_params if d]
                spot = "; spot " + ", ".join(
                    f"umbra {d['umbra']:.3g} deg, penumbra {d['penumbra']:.3g} deg" for d in sp
                )
            notes.append(f"- `{name}`: {w.label}: {params}{spot}.")
    rows += ["", "Fitted parameters of the winners:", "", *notes, ""]
    room, vpl, short, spot = (recs[n] for n in ORDER)
    rw, vw, sw, pw = room.winner, vpl.winner, short.winner, spot.winner
    same = [
        c.family for c in vpl.candidates if c.status == "pass" and c.shader_cost == vw.shader_cost
    ]
    rows += [
        f"`room.toml` confirms the seed's remark (Madams 2011, comment by John Hughes: at d/r "
        f'around 20 the attenuation "looks a LOT like 1/d^2"): `{rw.label}` is within '
        f"{_pct(rw.error)} (the bulb to {_pct(rw.error_by_light[0])}: a uniform sphere is "
        f"exactly a point light wherever no receiver sees it cut by its horizon; the panel to "
        f"{_pct(rw.error_by_light[1])}), and a softened curve does not do better there. "
        f"`vpl_on_surface.toml` puts receivers at d/r from 0.25: inverse square is off by "
        f"{_pct(vpl.candidates[[c.family for c in vpl.candidates].index('inverse_square')].error)}; "
        f"the winner `{vw.label}` ties in cost with {', '.join(f'`{n}`' for n in same if n != vw.family)} "
        f"(one expression, 1/(d^2 + c), fitted to the same curve; the tie goes to the smaller error, here by rounding). `short_range.toml` asks the curve to "
        f"reach 0 at the range, so only windowed families take part; `{sw.label}` fades only over "
        f"the last 20% of the range, beyond every receiver, so its window costs no accuracy. "
        f"`spotlight.toml` fits the spot's falloff too: with the scene's angles the best falloff "
        f"errs by {_pct(min(f['error'] for f in spot.directional_fits if 'scene' in f['variant']))}, "
        f"with fitted angles `{pw.directional}` by "
        f"{_pct(min(f['error'] for f in spot.directional_fits if 'fitted' in f['variant']))}.",
        "",
    ]
    return "\n".join(rows)


def section() -> str:
    return "\n".join([BEGIN, INTRO, format_tables(), examples_table(), END])


def main(argv: list[str]) -> int:
    enable_persistent_cache()  # as the CLI: a second run loads the compiled solves
    text = section()
    if "--print" in argv:
        print(text)
        return 0
    readme = README.read_text(encoding="utf-8")
    if BEGIN in readme and END in readme:
        head, rest = readme.split(BEGIN, 1)
        _, tail = rest.split(END, 1)
        new = head + text + tail
    elif PLACEHOLDER in readme:
        new = readme.replace(PLACEHOLDER, text, 1)
    else:
        print(f"README.md has neither {PLACEHOLDER} nor {BEGIN}", file=sys.stderr)
        return 1
    atomic_write(README, new, force=True)
    print("README.md: scene section updated", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
