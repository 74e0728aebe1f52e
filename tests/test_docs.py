"""The docs run: every Python and shell block of README.md and docs/*.md, page by page.

Each page runs top to bottom in its own temporary folder (with a copy of `examples/`), in
a fresh process, as a reader following it would (`tests/_doc_pages.py` says how blocks are
read and marked). Generated tables are checked against what the code now produces in
`tests/test_docs_generated.py`.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
from _doc_pages import PAGES, ROOT, blocks, script

RUNNER = Path(__file__).with_name("_doc_runner.py")
#: Seconds a page may take (its blocks together).
PAGE_TIMEOUT = 420


def _id(page: Path) -> str:
    return str(page.relative_to(ROOT))


#: The pages with code to run (every page is read by `test_every_page_is_read`).
RUNNABLE = [page for page in PAGES if script(page)]
#: Pages whose blocks take 1-3 minutes of a cold 2-core machine, each covered block by
#: block by its own tests (test_scene, test_scene_files, test_export, test_compiled_cost,
#: test_report, test_fit, test_witness, test_data_gen): run with `pytest -m slow` (and before
#: every release), not in CI's 10 minutes.
HEAVY = {
    "docs/scenes.md",
    "docs/shaders.md",
    "docs/report.md",
    "docs/usd-gltf.md",
    "docs/fitting.md",
    "docs/mitsuba.md",
}


@pytest.mark.parametrize(
    "page",
    [pytest.param(p, marks=pytest.mark.slow) if _id(p) in HEAVY else p for p in RUNNABLE],
    ids=_id,
)
def test_page_runs_top_to_bottom(page, tmp_path):
    todo = script(page)
    shutil.copytree(ROOT / "examples", tmp_path / "examples", ignore=shutil.ignore_patterns("out"))
    spec = tmp_path / ".blocks.json"
    spec.write_text(json.dumps(todo), encoding="utf-8")
    env = dict(os.environ)
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["MPLBACKEND"] = "Agg"
    env["PYTHONUNBUFFERED"] = "1"
    proc = subprocess.run(
        [sys.executable, str(RUNNER), str(spec)],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=PAGE_TIMEOUT,
        check=False,
    )
    assert proc.returncode == 0, (
        f"{_id(page)}: a block failed\n--- stdout (tail)\n{proc.stdout[-4000:]}\n"
        f"--- stderr (tail)\n{proc.stderr[-4000:]}"
    )


def test_every_page_is_read():
    """Every page parses (fences closed), and every block not run says why."""
    counts = {"run": 0, "small": 0, "skipped": 0, "other": 0}
    for page in PAGES:
        for b in blocks(page):
            if b.directive == "skip":
                assert len(b.argument) > 10, f"{b.where}: a skipped block needs a reason"
                counts["skipped"] += 1
            elif b.runs:
                counts["small" if b.directive == "small" else "run"] += 1
            else:
                counts["other"] += 1  # toml, glsl, text: shown, not run
        script(page)  # directives well formed
    print(f"docs code blocks: {counts}")
    assert counts["run"] + counts["small"] > 20
