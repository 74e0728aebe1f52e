"""Write `examples/explore.ipynb` (outputs stripped) from the cells below.

The notebook is generated so that its source stays reviewable as plain Python and so that it
is committed without outputs. After editing a cell here, regenerate it with

    python examples/make_explore_notebook.py

(`--check` exits 1 when the committed notebook differs from what this script writes).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import nbformat

HERE = Path(__file__).resolve().parent
NOTEBOOK = HERE / "explore.ipynb"

CELLS: list[tuple[str, str]] = [
    (
        "md",
        """# Exploring light attenuation with attenfit

A guided tour for graphics programmers, top to bottom in a few minutes:

1. pick an emitter and its radius, and plot the exact attenuation against the seed curves
   (inverse square, Yuksel 2020, Madams 2011);
2. fit a family to the truth and read its error per distance band;
3. look at a receiving plane: truth, model and error map;
4. push float32 to an extreme: Yuksel's eq. 7 as printed against the stable form;
5. write your own falloff as a plain JAX function and fit it;
6. load a scene file and read the recommendation.

Conventions: `d` is the distance from the light's centre (m), the light has unit intensity
(1 W/sr), and an attenuation curve `f(d)` is in 1/m², so that the irradiance of a receiver
facing the light is `E = f(d)`.""",
    ),
    (
        "code",
        """%matplotlib inline
import jax

jax.config.update("jax_enable_x64", True)  # float64 for the truth and the fits

from pathlib import Path

import jax.numpy as jnp
import numpy as np
from IPython.display import display

import attenfit
from attenfit import metrics, plots

print("attenfit", attenfit.__version__, "-", len(attenfit.list_families()), "families")""",
    ),
    (
        "md",
        """## 1. An emitter, its truth, and the seed curves

Choose `KIND` (`"sphere"` or `"disk"`) and the radius `R`. `facing_sweep` puts receivers
on a log-spaced sweep of distances, each facing the light's centre, and computes their exact
irradiance (`attenfit.irradiance`); `attenuation()` divides out the point-light weight, which
leaves the plain curve the seeds plot.""",
    ),
    (
        "code",
        """KIND = "disk"  # or "sphere"
R = 0.1  # m


def make_emitter(kind, r):
    if kind == "sphere":
        return attenfit.SphereEmitter(center=[0.0, 0.0, 0.0], radius=r)
    return attenfit.DiskEmitter(center=[0.0, 0.0, 0.0], normal=[0.0, 0.0, -1.0], radius=r)


def truth_sweep(kind, r, n=160):
    d_min = 1.001 * r if kind == "sphere" else 1e-3 * r
    ds = attenfit.facing_sweep(make_emitter(kind, r), d_min, 1e3 * r, n=n, dtype=jnp.float64)
    return np.asarray(ds.distance()), np.asarray(ds.attenuation()), ds


SEEDS = ("inverse_square", "yuksel", "yuksel_adhoc", "madams_sphere", "disk_facing")


def seed_curves(d, r):
    out = {}
    for name in SEEDS:
        cls = attenfit.get_family(name)
        family = cls(r=r) if "r" in cls.param_names() else cls()
        out[name] = np.asarray(family(jnp.asarray(d)))
    return out


d, truth, dataset = truth_sweep(KIND, R)
curves = seed_curves(d, R)
fig, ax = plots.plot_attenuation(d, curves, truth, r=R, truth_label=f"exact {KIND}")
fig""",
    ),
    (
        "code",
        """fig, ax = plots.plot_relative_error(d, curves, truth, r=R, title=f"against the exact {KIND}")
fig""",
    ),
    (
        "md",
        """### The radius, interactively

With `ipywidgets` installed (`pip install ipywidgets`), the slider below redraws the relative
error for any radius. Without it, the same plot is drawn for three radii. Relative error
against `d/r` does not depend on `r` for the families whose only length is `r` (the scale
law), but the engine constants (Unreal's 1 cm², Godot's clamp) do not scale: watch
`unreal_epsilon` move.""",
    ),
    (
        "code",
        """def error_plot(r, kind=KIND, ax=None):
    d, truth, _ = truth_sweep(kind, r, n=96)
    c = seed_curves(d, r)
    c["unreal_epsilon"] = np.asarray(attenfit.UnrealEpsilon()(jnp.asarray(d)))
    return plots.plot_relative_error(d, c, truth, r=r, title=f"{kind}, r = {r:g} m", ax=ax)


try:
    import ipywidgets as widgets
except ImportError:
    widgets = None

if widgets is not None:
    slider = widgets.FloatLogSlider(value=R, base=10, min=-3, max=0, step=0.25, description="r (m)")
    widgets.interact(lambda r: display(error_plot(r)[0]), r=slider)
else:
    print("ipywidgets is not installed: static plots for three radii")
    fig = plots.new_figure((12, 3.6))
    for ax, r in zip(fig.subplots(1, 3), (0.01, 0.1, 1.0), strict=True):
        error_plot(r, ax=ax)
    display(fig)""",
    ),
    (
        "md",
        """## 2. Fit a family and read its error bands

`fit_dataset` fits the point-light model `E = weight * f(d)` to the dataset's irradiance
(relative least squares, optimistix Levenberg-Marquardt). `metrics.attenuation_errors`
splits the error into the bands near (d < r), mid (r to 10 r) and far (> 10 r).""",
    ),
    (
        "code",
        """FAMILY = "yuksel"

result = attenfit.fit_dataset(attenfit.get_family(FAMILY)(), dataset)
print(result.message, "in", result.steps, "steps; params:", result.params)

rows = []
for label, model in (("as published (r = R)", attenfit.get_family(FAMILY)(r=R)), ("fitted", result.model)):
    errs = metrics.attenuation_errors(d, np.asarray(model(jnp.asarray(d))), truth, R)
    bands = errs["bands"]
    rows.append((label, errs["overall"]["max_abs"], *(bands[b]["max_abs"] for b in ("near", "mid", "far"))))

print(f"{'':22s} {'overall':>9s} {'near':>9s} {'mid':>9s} {'far':>9s}   (max |relative error|)")
for label, *vals in rows:
    print(f"{label:22s} " + " ".join("      n/a" if v is None else f"{v:9.3g}" for v in vals))""",
    ),
    (
        "md",
        """## 3. A receiving plane

`plane_receivers` lays a grid on a plane under the light (here a height of 2 r), with normals
up; the truth includes horizon clipping. The model image is the point-light model with the
fitted family, `weight * f(d)`.""",
    ),
    (
        "code",
        """plane = attenfit.plane_receivers(make_emitter(KIND, R), height=2 * R, extent=6 * R, n=64, dtype=jnp.float64)
E_true = plane.grid_image()
E_model = plane.grid_image(np.asarray(plane.weight() * result.model(plane.distance())))
ext = (-6 * R, 6 * R, -6 * R, 6 * R)
print("plane image errors:", {k: v for k, v in metrics.image_errors(E_model, E_true).items() if k in ("max_abs", "rms", "energy_ratio")})
fig, axes = plots.plot_side_by_side(E_true, E_model, ext, label=f"{FAMILY} (fitted)")
fig""",
    ),
    (
        "md",
        """## 4. A float32 extreme

Yuksel's eq. 7 as printed, `2/r² (1 - d/sqrt(d² + r²))`, subtracts two numbers that agree
to ever more digits as `d/r` grows: in float32, at `d = 1e5 r`, `d/sqrt(d² + r²)` rounds to
exactly 1 and the light goes black. attenfit evaluates the same function as `2/(s (s + d))`,
`s = hypot(d, r)`, which has no cancellation. Far away eq. 7 is `1/d² (1 - 3/4 (r/d)² ...)`.
At `d = 1e21 r`, `d²` overflows float32: the naive form then returns `2/r²`, the light's peak;
the stable form returns 0 (the true 1e-40 is below float32's normal range, and XLA flushes
subnormals to zero).""",
    ),
    (
        "code",
        """r32 = jnp.float32(R)
for ratio in (1e2, 1e4, 1e5, 1e21):
    d32 = jnp.float32(ratio) * r32
    naive = 2 / r32**2 * (1 - d32 / jnp.sqrt(d32 * d32 + r32 * r32))
    stable = attenfit.Yuksel(r=r32)(d32)
    reference = 1 / float(d32) ** 2 * (1 - 0.75 / ratio**2)  # the series, in float64
    print(f"d = {ratio:5.0e} r: naive {float(naive):.6e}  stable {float(stable):.6e}  "
          f"reference {reference:.6e}  ({stable.dtype})")""",
    ),
    (
        "md",
        """## 5. Your own falloff, as a plain JAX function

`attenfit.fit` accepts a pair `(fn, params)`: any JAX function `fn(d, params)` of a dict of
parameters, and their start values (an optional third item gives constraints; `free` picks
the parameters to fit). Here, a lisyarus-style windowed curve with a free scale,
`scale (1 - s²)² / (1 + k s²)`, `s = d/range`, fitted to the truth within a range of 20 r
that stays fixed. For a new family that should work everywhere (reports,
export), subclass `attenfit.Family` and register it: see `custom_falloff.py`.""",
    ),
    (
        "code",
        """def windowed(d, p):
    s = jnp.minimum(d / p["range"], 1.0)
    return p["scale"] * (1 - s * s) ** 2 / (1 + p["k"] * s * s)


RANGE = 20 * R  # the light's range, chosen (not fitted): the curve is 0 beyond it
inside = d < RANGE
start = {"scale": float(truth[0]), "k": 100.0, "range": RANGE}
mine = attenfit.fit((windowed, start), d[inside], truth[inside], free=("scale", "k"))
print(mine.message, {k: round(v, 4) for k, v in mine.params.items()})
fn, fitted = mine.model
half = d < RANGE / 2  # a window's relative error reaches -1 at its range by design
rel = np.asarray(fn(jnp.asarray(d[half]), fitted)) / truth[half] - 1
print(f"max relative error: {mine.metrics['max_rel_error']:.3f} within the range, "
      f"{np.abs(rel).max():.3f} within half of it")
x = jnp.asarray(d[inside])
fig, ax = plots.plot_attenuation(
    d[inside],
    {"my windowed curve": np.asarray(fn(x, fitted)), "yuksel (fitted)": np.asarray(result.model(x))},
    truth[inside],
    r=R,
)
fig""",
    ),
    (
        "md",
        """## 6. A scene file and its recommendation

A scene (TOML) says which lights and receivers matter and how much error is acceptable;
`attenfit.recommend` computes the truth only there, fits the candidate families and picks
the cheapest one within tolerance. `examples/scenes/room.toml` is a room lit from its
ceiling, with receivers about 20 light radii away, where (as John Hughes remarks under
Madams' post) the curve "looks a LOT like 1/d²". To keep this quick, the candidates are
restricted to three families (the scene's `[constraints] families` key); drop that line to
judge every family (or run `attenfit scene examples/scenes/room.toml`).""",
    ),
    (
        "code",
        """import tomllib

scene_path = Path("scenes/room.toml")
if not scene_path.exists():  # run from the repository root
    scene_path = Path("examples") / scene_path
scene = attenfit.Scene.load(scene_path)  # validates every key
print(scene.name, "-", len(scene.lights), "light(s); tolerance", scene.tolerance)
print(scene.description)

raw = tomllib.loads(scene_path.read_text())
raw.setdefault("constraints", {})["families"] = ["inverse_square", "clamped", "yuksel"]
scene = attenfit.Scene.from_dict(raw, source=str(scene_path))
rec = attenfit.recommend(scene, measure=False)
if rec.winner is not None:
    print(f"winner: {rec.winner.family} - max error {rec.winner.error:.2e}, "
          f"shader cost {rec.winner.shader_cost}")
else:
    print(f"no family within tolerance; the closest is {rec.closest.family}")
for c in rec.candidates:
    error = "n/a" if c.error is None else f"{c.error:.2e}"
    print(f"  {c.family:16s} {c.status:8s} error {error:9s} cost {c.shader_cost}  ({c.reason})")""",
    ),
    (
        "code",
        """print(rec.shaders.get("glsl", "(no winner, no shader)"))""",
    ),
    (
        "md",
        """## Where next

* `python examples/reproduce_yuksel_fig3.py`, `reproduce_madams.py`,
  `virtual_point_lights.py`: the seeds' figures, reproduced and checked;
* `python examples/custom_falloff.py`: a registered family in a full report;
* `attenfit report`, `attenfit scene FILE`, `attenfit export FAMILY --lang glsl`: the CLI.""",
    ),
]


def build() -> nbformat.NotebookNode:
    nb = nbformat.v4.new_notebook()
    nb.metadata["kernelspec"] = {
        "name": "python3",
        "display_name": "Python 3",
        "language": "python",
    }
    nb.metadata["language_info"] = {"name": "python"}
    for i, (kind, src) in enumerate(CELLS):
        cell = (
            nbformat.v4.new_markdown_cell(src) if kind == "md" else nbformat.v4.new_code_cell(src)
        )
        cell["id"] = f"cell-{i:02d}"
        nb.cells.append(cell)
    nbformat.validate(nb)
    return nb


def formatted(text: str) -> str:
    """`text` (a notebook) with its code cells formatted by ruff, as `make lint` checks them.

    Formats a temporary copy next to the notebook (so the project's ruff settings apply);
    without ruff (it comes with the dev extra) the text is returned as it is.
    """
    fd, tmp = tempfile.mkstemp(suffix=".ipynb", prefix=".explore-fmt-", dir=HERE)
    os.close(fd)
    try:
        Path(tmp).write_text(text, encoding="utf-8")
        try:
            subprocess.run(
                [sys.executable, "-m", "ruff", "format", "--quiet", tmp],
                check=True,
                capture_output=True,
                cwd=HERE.parent,
            )
        except (OSError, subprocess.CalledProcessError):
            return text
        return Path(tmp).read_text(encoding="utf-8")
    finally:
        Path(tmp).unlink(missing_ok=True)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--check", action="store_true", help="exit 1 if explore.ipynb is stale")
    args = p.parse_args(argv)
    text = formatted(nbformat.writes(build()) + "\n")
    if args.check:
        same = NOTEBOOK.exists() and NOTEBOOK.read_text(encoding="utf-8") == text
        print("explore.ipynb is up to date" if same else "explore.ipynb is stale: regenerate it")
        return 0 if same else 1
    sys.path.insert(0, str(HERE.parent))
    from attenfit._atomic import atomic_write

    atomic_write(NOTEBOOK, text, force=True)
    print(f"wrote {NOTEBOOK}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
