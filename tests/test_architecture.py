"""The layout of the package: stages import only the stages below them, no module imports
another in a circle, no module is longer than a person reads in one sitting, and the public
API is the one attenfit has published (docs/architecture.md).

Imports are read from the source (every `import` statement, including those inside
functions, except those under `if TYPE_CHECKING:`), so a lazy import cannot hide an
upward dependency.
"""

from __future__ import annotations

import ast
import importlib
import subprocess
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parent.parent / "attenfit"

#: The stages, bottom to top. A module of stage k may import stages 0..k (its own included).
STAGES = ("base", "curves", "truth", "fit", "shaders", "judge", "report", "scenes", "cli", "public")
#: The base stage's modules (top-level private modules every stage may use).
BASE = (
    "_errors",
    "_atomic",
    "_version",
    "_cache",
    "_progress",
    "_input",
    "_budget",
    "_float64",
    "_ir",
)
#: Longest module allowed, in lines.
MAX_LINES = 600
#: Longest function allowed, in lines (its `def` line to its last, docstring included).
MAX_FUNCTION_LINES = 80


def _stage(module: str) -> str:
    """The stage of a module given as a dotted name under `attenfit`."""
    parts = module.split(".")
    if len(parts) == 1:  # the package itself
        return "public"
    top = parts[1]
    if top in BASE:
        return "base"
    if top.startswith("_") and top[1:] in STAGES:
        return top[1:]
    if top in ("cli", "_cli", "__main__"):
        return "cli"
    return "public"  # the public modules re-export their stage's names


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE.parent).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


def _type_checking_lines(tree: ast.AST) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and getattr(node.test, "id", "") == "TYPE_CHECKING":
            for child in node.body:
                lines.update(range(child.lineno, (child.end_lineno or child.lineno) + 1))
    return lines


def _imports(module: str, path: Path) -> set[str]:
    """The attenfit modules `module` imports (resolved to the longest existing module)."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip = _type_checking_lines(tree)
    is_pkg = path.name == "__init__.py"
    package = module if is_pkg else module.rsplit(".", 1)[0]
    known = _modules()
    found: set[str] = set()
    for node in ast.walk(tree):
        if getattr(node, "lineno", None) in skip:
            continue
        targets = []
        if isinstance(node, ast.Import):
            targets = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - node.level + 1]
                stem = ".".join(base + ([node.module] if node.module else []))
            else:
                stem = node.module or ""
            # `from . import x` imports x (the package is imported already); `from .m import
            # y` imports m (or m.y, where y is a module)
            targets = [f"{stem}.{a.name}" for a in node.names]
            if node.module:
                targets.append(stem)
        for t in targets:
            if t == "attenfit" or t.startswith("attenfit."):
                while t not in known and "." in t:
                    t = t.rsplit(".", 1)[0]
                if t in known and t != module:
                    found.add(t)
    return found


GRAPH = {m: _imports(m, p) for m, p in _modules().items()}


def _packages_of(module: str) -> list[str]:
    """The packages Python runs before `module` (its parents below `attenfit`)."""
    parts = module.split(".")
    return [".".join(parts[:k]) for k in range(2, len(parts))]


#: GRAPH with what Python really runs: importing a module runs its packages' `__init__` first.
RUNS = {
    m: targets
    | {p for t in targets for p in _packages_of(t) if not (m == p or m.startswith(p + "."))}
    for m, targets in GRAPH.items()
}


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_a_stage_imports_only_stages_below_it(module):
    rank = STAGES.index(_stage(module))
    upward = sorted(m for m in GRAPH[module] if STAGES.index(_stage(m)) > rank)
    assert not upward, f"{module} ({_stage(module)}) imports {upward} from stages above it"


def test_no_import_circles():
    """No module reaches itself through the imports of others (a depth-first search)."""
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(m: str) -> None:
        state[m] = 1
        path.append(m)
        for n in sorted(RUNS[m]):
            # a package's __init__ re-exporting its own modules is not a circle with them
            if m.startswith(n + ".") and (PACKAGE.parent / Path(*n.split("."))).is_dir():
                continue
            if state.get(n) == 1:
                cycle = [*path[path.index(n) :], n]
                pytest.fail(f"import circle: {' -> '.join(cycle)}")
            if n not in state:
                visit(n)
        path.pop()
        state[m] = 2

    for m in sorted(GRAPH):
        if m not in state:
            visit(m)


def _is_private_stage_module(module: str) -> bool:
    """A module inside a stage subpackage (`attenfit._report._plots`), not its interface."""
    parts = module.split(".")
    return len(parts) >= 3 and parts[1].startswith("_") and parts[2].startswith("_")


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_a_stage_uses_another_only_through_its_interface(module):
    """Across stages, a module imports the stage package (its `__init__`), never one of its
    private modules. Public modules are their stage's own face and re-export from it."""
    if _stage(module) == "public":
        return
    reached = sorted(
        t for t in GRAPH[module] if _is_private_stage_module(t) and _stage(t) != _stage(module)
    )
    assert not reached, f"{module} imports private modules of other stages: {reached}"


@pytest.mark.parametrize("module", sorted(m for m in GRAPH if _is_private_stage_module(m)))
def test_no_module_imports_its_own_package_interface(module):
    """A stage's modules import each other directly, never through the package `__init__`
    that re-exports them (which is what makes circles through `__init__`)."""
    path = _modules()[module]
    package = module.rsplit(".", 1)[0]
    tree = ast.parse(path.read_text(encoding="utf-8"))
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = module.split(".")[: -node.level]
            stem = ".".join(base + ([node.module] if node.module else []))
            if stem != package:
                continue
            for alias in node.names:
                assert f"{stem}.{alias.name}" in GRAPH, (
                    f"{module} line {node.lineno} imports {alias.name!r} from its own package "
                    f"{package}; import it from the module that defines it"
                )
        elif isinstance(node, ast.Import):
            for alias in node.names:
                assert alias.name != package, f"{module} imports its own package {package}"


def test_module_names_say_one_thing():
    """No private module repeats a stage's name for something else, and no two private
    modules share a name (the reader of a traceback knows which one it is)."""
    stems: dict[str, list[str]] = {}
    for module in GRAPH:
        last = module.rsplit(".", 1)[-1]
        if module == "attenfit" or not last.startswith("_") or last.startswith("__"):
            continue
        if last[1:] in STAGES and module != f"attenfit.{last}":
            pytest.fail(f"{module}: a module named after the stage {last[1:]!r}")
        if module.count(".") >= 2:  # a stage's module
            stems.setdefault(last, []).append(module)
    repeated = {k: v for k, v in stems.items() if len(v) > 1}
    assert not repeated, f"private modules sharing a name: {repeated}"


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_modules_are_short_enough_to_read(module):
    n = len(_modules()[module].read_text(encoding="utf-8").splitlines())
    assert n <= MAX_LINES, f"{module} has {n} lines (at most {MAX_LINES})"


def _function_lengths(module: str) -> dict[str, int]:
    """`module.function` (methods and nested functions as `module.outer.inner`) -> lines."""
    tree = ast.parse(_modules()[module].read_text(encoding="utf-8"))
    out: dict[str, int] = {}

    def visit(node: ast.AST, prefix: str) -> None:
        for child in ast.iter_child_nodes(node):
            name = prefix
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef | ast.ClassDef):
                name = f"{prefix}.{child.name}"
                if not isinstance(child, ast.ClassDef):
                    out[name] = (child.end_lineno or child.lineno) - child.lineno + 1
            visit(child, name)

    visit(tree, module)
    return out


@pytest.mark.parametrize("module", sorted(GRAPH))
def test_functions_are_short_enough_to_read(module):
    long = {name: n for name, n in _function_lengths(module).items() if n > MAX_FUNCTION_LINES}
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines: {long}"


def test_stage_packages_are_private_and_public_modules_are_thin():
    """Every subpackage is a private stage; a public module only re-exports names."""
    for path in PACKAGE.iterdir():
        if path.is_dir() and not path.name.startswith("__"):
            assert path.name.startswith("_"), f"{path.name}/ is a public subpackage"
    for module, path in _modules().items():
        if _stage(module) != "public" or module == "attenfit":
            continue
        tree = ast.parse(path.read_text(encoding="utf-8"))
        for node in tree.body:
            ok = isinstance(node, ast.ImportFrom | ast.Import) or (
                isinstance(node, ast.Expr | ast.Assign)  # the docstring, __all__
            )
            assert ok, f"{module} defines code at line {node.lineno}: move it into its stage"


#: Every name `attenfit` exported at the last release of the flat layout (commit 0162d57),
#: and the `__all__` of each public module then: all must stay importable.
PUBLIC = {
    "attenfit": [
        "AbstractEmitter", "AttenfitError", "BadTypeError", "BadValueError", "Candidate",
        "CapsuleEmitter", "Clamped", "Cost", "CryEngineLinear", "DataFileError", "Dataset",
        "DiskEmitter", "DiskFacing", "Family", "FitResult", "FitResults", "FrostbiteWindow",
        "GltfRange", "Godot", "InverseSquare", "JustCause2", "LOSSES", "MadamsCutoff",
        "MadamsRational", "MadamsSphere", "MadamsTan", "OutputExistsError", "ParetoFront",
        "Polynomial", "Recommendation", "Report", "SOLVERS", "Scene", "SphereEmitter", "Spline",
        "ThreeJS", "UnknownNameError", "UnrealEpsilon", "UnrealExponent", "UnrealWindow",
        "Yuksel", "YukselAdhoc", "__version__", "build_report", "cheapest_within", "cost",
        "cost_table", "count_ops", "directional", "emitter_from_dict", "export",
        "export_function", "facing_sweep", "families", "family_cost", "family_from_function",
        "fit", "fit_dataset", "fit_many", "get_family", "irradiance", "lambert_disk",
        "list_families", "metrics", "pareto_front", "plane_receivers", "plot_cost_vs_error",
        "plots", "quadrature", "random_receivers", "recommend", "register_family", "scene",
        "shader_cost", "spot_frostbite", "spot_t", "spot_threejs",
    ],
    "attenfit.families": [
        "Clamped", "CryEngineLinear", "DiskFacing", "FrostbiteWindow", "GltfRange", "Godot",
        "InverseSquare", "JustCause2", "MadamsCutoff", "MadamsRational", "MadamsSphere",
        "MadamsTan", "Polynomial", "Spline", "ThreeJS", "UnrealEpsilon", "UnrealExponent",
        "UnrealWindow", "Yuksel", "YukselAdhoc",
    ],
    "attenfit.directional": ["lambert_disk", "spot_frostbite", "spot_t", "spot_threejs"],
    "attenfit.quadrature": ["irradiance"],
    "attenfit.metrics": [
        "BANDS", "attenuation_errors", "band_errors", "discarded_fraction", "error_stats",
        "grid_energy", "image_errors", "plane_energy", "relative_error", "value_at_zero",
        "window_edge", "window_reach",
    ],
    "attenfit.plots": [
        "STYLE", "curve_styles", "new_figure", "plot_attenuation", "plot_error_map",
        "plot_plane_comparison", "plot_plane_image", "plot_relative_error", "plot_side_by_side",
    ],
    "attenfit.scene": [
        "LIGHT_KINDS", "RECEIVER_KINDS", "SCENE_KEYS", "SPOT_PROFILES", "DistanceDistribution",
        "LightTruth", "PlaneReceivers", "PointReceivers", "Scene", "SceneLight", "spot_profile",
    ],
    "attenfit.cost": [
        "CATEGORIES", "SHADER_WEIGHTS", "Cost", "ParetoFront", "cheapest_within", "cost_table",
        "count_ops", "family_cost", "measure_throughput", "pareto_front", "plot_cost_vs_error",
        "shader_cost",
    ],
    "attenfit.export": [
        "LANGUAGES", "UnsupportedPrimitiveError", "export", "float32_literal", "load_model",
    ],
    "attenfit.report": [
        "DEFAULT_RADIUS", "PUBLISHED_CUTOFF", "PUBLISHED_RULES", "SWEEP_N", "Report",
        "build_report", "default_emitters", "published_params",
    ],
    "attenfit.emitters": [
        "AbstractEmitter", "CapsuleEmitter", "DiskEmitter", "SphereEmitter", "emitter_from_dict",
    ],
    "attenfit.cli": [
        "EXIT_BAD_INPUT", "EXIT_ERROR", "EXIT_NOT_CONVERGED", "EXIT_OK", "get_parser", "main",
    ],
}  # fmt: skip


@pytest.mark.parametrize("module", sorted(PUBLIC))
def test_the_published_api_is_still_importable(module):
    mod = importlib.import_module(module)
    missing = [name for name in PUBLIC[module] if not hasattr(mod, name)]
    assert not missing, f"{module} lost {missing}"
    if module != "attenfit":
        assert set(PUBLIC[module]) <= set(mod.__all__)


def test_the_top_level_modules_are_the_public_ones():
    import attenfit

    for name in ("families", "parts", "directional", "emitters", "quadrature", "metrics",
                 "plots", "cost", "export", "report", "scene"):  # fmt: skip
        assert getattr(attenfit, name) is importlib.import_module(f"attenfit.{name}")


def test_a_user_composes_a_family_from_the_public_parts():
    """The parts a family is built from are public (`attenfit.parts`), not a private module."""
    import attenfit

    for name in attenfit.parts.__all__:
        assert callable(getattr(attenfit.parts, name)), name
    assert {"promote", "distance", "keep_nan", "yuksel", "smooth_window"} <= set(
        attenfit.parts.__all__
    )


def test_the_cli_names_every_engine_without_importing_the_scene_stage():
    from attenfit._cli._cmd_scene import ENGINE_NAMES
    from attenfit._scenes._engine import ENGINES

    assert ENGINE_NAMES == tuple(ENGINES)


def test_the_suite_keeps_each_test_module_on_one_worker(tmp_path):
    """`-n 2 --dist loadgroup` with this conftest's groups sends a module's tests to one
    worker, so its module-scoped fixtures are built once. pytest 9.2 broke this silently
    (pytest-xdist issue #1386: every module ran on both workers, the suite twice as long
    from an empty cache); pyproject.toml keeps pytest below it until xdist follows."""
    for name in ("a", "b"):
        (tmp_path / f"test_{name}.py").write_text(
            "import os\n\n"
            + "".join(
                f"def test_{k}():\n"
                f"    with open('worker_{name}_{k}', 'w') as f:\n"
                "        f.write(os.environ['PYTEST_XDIST_WORKER'])\n\n"
                for k in range(6)
            ),
            encoding="utf-8",
        )
    here = Path(__file__).resolve().parent
    (tmp_path / "conftest.py").write_text(
        (here / "conftest.py").read_text(encoding="utf-8"), encoding="utf-8"
    )
    (tmp_path / "pytest.ini").write_text("[pytest]\n", encoding="utf-8")
    proc = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-n", "2", "--dist", "loadgroup",
         "-p", "no:cacheprovider", str(tmp_path)],
        cwd=tmp_path, capture_output=True, text=True, timeout=300, check=False,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stdout[-2000:] + proc.stderr[-2000:]
    for name in ("a", "b"):
        workers = {(tmp_path / f"worker_{name}_{k}").read_text() for k in range(6)}
        assert len(workers) == 1, f"test_{name}.py ran on {sorted(workers)}"
