"""One set of numbers: every page that quotes a model's error on a light and band quotes the
same number (issue 28, item 2).

The pages' tables are read as committed (tests/test_docs_generated.py, marked slow,
regenerates the generated ones and fails when a page is stale):

* the decision table, in README.md (report-decision) and docs/report.md
  (report-decision-doc): per light, band and named model, its worst case and typical (p95);
* docs/area.md's area models' worst cases (area-worst), per model, light and band;
* docs/area.md's rectangle and tube numbers: the generated ceiling and decision rows
  (area-shapes) and the shapes benchmark's table, per model, mode and plane;
* docs/judging.md's re-judged table ("worst found", "typical (p95)");
* the summary (README.md) and the windows table (docs/report.md): a windowed family's
  largest error on the sphere's facing sweep within half its range, as published.

Numbers are compared to the 3 significant digits the pages print; two errors both below
1e-9 (float64 rounding of an exact model) agree.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
BANDS = {"contact to r": "contact", "r to 10 r": "near", "beyond 10 r": "far"}


def _section(page: str, name: str) -> str:
    text = (ROOT / page).read_text(encoding="utf-8")
    m = re.search(
        rf"<!-- BEGIN generated: {re.escape(name)}\b[^>]*-->\n(.*?)<!-- END generated: "
        rf"{re.escape(name)} -->",
        text,
        re.S,
    )
    assert m is not None, f"{page} has no generated section {name}"
    return m.group(1)


def _cells(line: str) -> list[str]:
    """A table row's cells (an escaped `\\|` stays inside its cell, unescaped)."""
    inner = line.strip().removeprefix("|").removesuffix("|")
    return [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", inner)]


def _rows(text: str, first: str) -> tuple[list[str], list[list[str]]]:
    """The header and rows of the first Markdown table whose first header cell is `first`."""
    lines = text.splitlines()
    for i, line in enumerate(lines):
        cells = _cells(line)
        if line.startswith("|") and cells[0] == first:
            rows = []
            for row in lines[i + 2 :]:
                if not row.startswith("|"):
                    break
                rows.append(_cells(row))
            return cells, rows
    raise AssertionError(f"no table headed {first!r}")


def _model(cell: str) -> str:
    """The model a cell names: "`clipped_disk` published (area model)" -> clipped_disk."""
    m = re.search(r"`([A-Za-z0-9_]+)`", cell)
    assert m is not None, cell
    return m.group(1)


def _pct(cell: str) -> float:
    m = re.match(r"([-+0-9.e]+)%", cell.strip())
    assert m is not None, cell
    return float(m.group(1)) / 100


def _decision(page: str, name: str, quoted: dict) -> None:
    head, rows = _rows(_section(page, name), "light")
    col = {h: i for i, h in enumerate(head)}
    light = band = ""
    for row in rows:
        light, band = row[0] or light, row[1] or band
        key = (_model(row[col["cheapest model"]]), light, BANDS[band])
        quoted[("worst", *key)].append((page, _pct(row[col["worst case"]])))
        quoted[("typical", *key)].append((page, _pct(row[col["typical (p95)"]])))


def _area_worst(quoted: dict) -> None:
    head, rows = _rows(_section("docs/area.md", "area-worst"), "area model")
    col = {h: i for i, h in enumerate(head)}
    for row in rows:
        key = (_model(row[0]), row[col["light"]], BANDS[row[col["distance from its surface"]]])
        quoted[("worst", *key)].append(("docs/area.md", _pct(row[col["worst case"]])))
        quoted[("typical", *key)].append(("docs/area.md", _pct(row[col["typical (p95)"]])))


def _shape_cell(cell: str) -> tuple[str, str] | None:
    """(model, mode) of a rect/tube table's model cell: "best f(d): `spline` fitted" ->
    (spline, fitted); "`three_rect` (area model)" -> (three_rect, published); None for a
    cell naming no single model ("`point_light (1/d^2)`")."""
    m = re.search(r"`([A-Za-z0-9_]+)`\s*(fitted)?", cell)
    return None if m is None else (m.group(1), m.group(2) or "published")


def _area_shapes(quoted: dict) -> None:
    """docs/area.md's rect and tube numbers: the generated ceiling and decision rows, and
    the benchmark's table (`python -m benchmarks shapes`), per model, mode and plane."""
    text = (ROOT / "docs" / "area.md").read_text(encoding="utf-8")
    ours = _section("docs/area.md", "area-shapes")
    tables = [("docs/area.md area-shapes", _rows(ours, "configuration")),
              ("docs/area.md shapes benchmark", _rows(text.replace(ours, ""), "configuration"))]  # fmt: skip
    for page, (head, rows) in tables:
        col = {h: i for i, h in enumerate(head)}
        for row in rows:
            named = _shape_cell(row[col["model"]])
            if named is None:
                continue
            key = (*named, row[0])
            quoted[("worst", *key)].append((page, _pct(row[col["worst case"]])))
            quoted[("typical", *key)].append((page, _pct(row[col["typical (p95)"]])))
    head, rows = _rows(ours, "light")
    col = {h: i for i, h in enumerate(head)}
    band = ""
    for row in rows:
        band = row[1] or band
        named = _shape_cell(row[col["cheapest model"]])
        assert named is not None, row
        quoted[("worst", *named, band)].append(
            ("docs/area.md decision", _pct(row[col["worst case"]]))
        )
        quoted[("typical", *named, band)].append(
            ("docs/area.md decision", _pct(row[col["typical (p95)"]]))
        )


def _judging(quoted: dict) -> None:
    text = (ROOT / "docs" / "judging.md").read_text(encoding="utf-8")
    head, rows = _rows(text, "light")
    col = {h: i for i, h in enumerate(head)}
    for row in rows:
        key = (_model(row[col["model"]]), row[0], BANDS[row[col["band"]]])
        quoted[("worst", *key)].append(("docs/judging.md", _pct(row[col["worst found"]])))
        quoted[("typical", *key)].append(("docs/judging.md", _pct(row[col["typical (p95)"]])))


def _windows(quoted: dict) -> None:
    head, rows = _rows(_section("README.md", "report-summary"), "family")
    col = {h: i for i, h in enumerate(head)}
    for row in rows:
        if "ᵂ" in row[col["sphere: facing sweep"]]:
            published = row[col["sphere: facing sweep"]].split("/")[0]
            quoted[("window", _model(row[0]), "sphere", "facing")].append(
                ("README.md", _pct(published))
            )
    head, rows = _rows(_section("docs/report.md", "report-findings"), "family")
    col = {h: i for i, h in enumerate(head)}
    for row in rows:
        quoted[("window", _model(row[0]), "sphere", "facing")].append(
            ("docs/report.md", _pct(row[col["max |error|, d ≤ range/2"]]))
        )


def _agree(a: float, b: float) -> bool:
    if a < 1e-9 and b < 1e-9:  # both float64 rounding of an exact model
        return True
    return abs(a - b) <= 5e-3 * max(abs(a), abs(b))  # the pages print 3 digits


@pytest.fixture(scope="module")
def quoted() -> dict:
    out: dict = defaultdict(list)
    _decision("README.md", "report-decision", out)
    _decision("docs/report.md", "report-decision-doc", out)
    _area_worst(out)
    _area_shapes(out)
    _judging(out)
    _windows(out)
    return out


def test_every_number_quoted_twice_agrees(quoted):
    bad = []
    for key, values in quoted.items():
        (page0, v0), *rest = values
        bad += [f"{key}: {page0} {v0:.4g} vs {p} {v:.4g}" for p, v in rest if not _agree(v0, v)]
    assert not bad, "\n".join(bad)


def test_the_pages_share_numbers(quoted):
    """The check compares something: the decision's models are quoted on several pages."""
    pages = {key: {p for p, _ in values} for key, values in quoted.items()}
    assert sum(len(p) >= 3 for p in pages.values()) >= 10
    area = {k for k, p in pages.items() if "docs/area.md" in p and len(p) > 1}
    assert any(k[1] == "clipped_disk" for k in area)
    shapes = {k for k, p in pages.items() if "docs/area.md area-shapes" in p and len(p) > 1}
    assert {k[1] for k in shapes} >= {"clipped_rect", "lambert_line"}  # ceiling = benchmark


def test_a_disagreement_is_caught():
    values = {("worst", "m", "disk", "far"): [("a.md", 0.0193), ("b.md", 0.0201)]}
    (_, v0), (_, v1) = values[("worst", "m", "disk", "far")]
    assert not _agree(v0, v1)
    assert _agree(3.3e-14, 5.8e-14) and _agree(0.0193, 0.01931)
