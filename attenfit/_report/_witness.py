"""The report's Mitsuba witness section: exact values checked by a renderer nobody here wrote.

`witness_section(sets)` takes `(label, exact, rendered)` triples (attenfit `Dataset`s on the
same receivers: the exact irradiance, and a Monte Carlo render with a standard error per
receiver, e.g. from `data_gen.witness.render_witness`) and returns a `WitnessSection`: the
numbers (report.json `witness`), the Markdown and the z-score histogram as PNG bytes. The
rendering itself happens outside attenfit (the CLI calls `data_gen`); this module only judges.

z = (Mitsuba - exact) / stderr per receiver. With calibrated standard errors, z follows
N(0, 1): median |z| = 0.674 (the median of a half-normal, sqrt(2) erfinv(1/2)), and
|z| > 4 has probability 6.3e-5 per receiver.
"""

from __future__ import annotations

import base64
import dataclasses
import hashlib
import io
import json
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from .._errors import BadTypeError, BadValueError
from .._truth import Dataset

__all__ = [
    "HALF_NORMAL_MEDIAN",
    "WitnessSection",
    "cached_witness",
    "store_witness",
    "witness_key",
    "witness_section",
    "witness_z",
]

#: The median of |Z| for Z ~ N(0, 1): sqrt(2) erfinv(1/2).
HALF_NORMAL_MEDIAN = 0.6744897501960817
_Z_EDGE = 5.0  # the histogram's range; beyond it, receivers are counted at the edge


@dataclasses.dataclass(frozen=True)
class WitnessSection:
    """The witness's numbers (`data`), its Markdown (`markdown(figure_path)`) and figure."""

    data: dict[str, Any]
    png: bytes

    def markdown(self, figure: str | None = "figures/witness_z.png") -> str:
        """The section's Markdown, the histogram linked as `figure` (None: no link)."""
        d = self.data
        head = (
            "Every exact value above comes from attenfit's own formulas. Here Mitsuba 3 "
            f"({d['variant']}, {d['spp']} samples per receiver, {d['seconds']:.1f} s) renders "
            "each light's floor and random receivers independently, and z = (Mitsuba − exact) "
            f"/ stderr is shown per receiver. Over all {d['n']} receivers: **median |z| = "
            f"{d['median_abs_z']:.2f}** (calibrated errors give {HALF_NORMAL_MEDIAN:.2f}), "
            f"largest |z| = {d['max_abs_z']:.2f}."
        )
        lines = [
            "## Mitsuba witness",
            "",
            head,
            "",
            "| receivers | n | median abs z | largest abs z | median rel. stderr |",
            "|---|---:|---:|---:|---:|",
        ]
        for s in d["sets"]:
            lines.append(
                f"| {s['label']} | {s['n']} | {s['median_abs_z']:.2f} | {s['max_abs_z']:.2f} | "
                f"{s['median_rel_stderr']:.2g} |"
            )
        lines.append("")
        if figure:
            lines += [f"![Mitsuba witness: z-scores]({figure})", ""]
        lines += [
            "Receivers where both are 0 (the light below the horizon) are left out. A |z| "
            "beyond 4 would mean attenfit or the witness is wrong there (probability 6.3e-5 "
            "per receiver). `attenfit report --no-mitsuba` skips this section; "
            "[docs/mitsuba.md](docs/mitsuba.md) says what the standard error covers.",
            "",
        ]
        return "\n".join(lines)


def witness_z(exact: Dataset, rendered: Dataset) -> np.ndarray:
    """z per judged receiver: (rendered - exact) / stderr where either is non-zero."""
    for name, ds in (("exact", exact), ("rendered", rendered)):
        if not isinstance(ds, Dataset):
            raise BadTypeError(f"{name} must be an attenfit Dataset, got {type(ds).__name__}")
    if len(exact) != len(rendered) or not np.array_equal(
        np.asarray(exact.points), np.asarray(rendered.points)
    ):
        raise BadValueError("exact and rendered datasets must hold the same receivers")
    ex = np.asarray(exact.E, dtype=np.float64)
    mc = np.asarray(rendered.E, dtype=np.float64)
    se = np.asarray(rendered.stderr, dtype=np.float64)
    judged = (ex != 0) | (mc != 0)
    if np.any(judged & ~(se > 0)):
        raise BadValueError("the rendered dataset has a non-zero value without a standard error")
    return (mc[judged] - ex[judged]) / se[judged]


def witness_section(
    sets: Sequence[tuple[str, Dataset, Dataset]], *, seconds: float = 0.0, dpi: int = 100
) -> WitnessSection:
    """Judge `(label, exact, rendered)` triples; the section's numbers, Markdown and figure."""
    if not sets:
        raise BadValueError("the witness needs at least one (label, exact, rendered) set")
    rows, zs = [], []
    for label, exact, rendered in sets:
        z = witness_z(exact, rendered)
        ex = np.asarray(exact.E, dtype=np.float64)
        lit = ex > 0
        rel = np.asarray(rendered.stderr, dtype=np.float64)[lit] / ex[lit]
        zs.append((str(label), z))
        rows.append(
            {
                "label": str(label),
                "n": int(z.size),
                "median_abs_z": float(np.median(np.abs(z))) if z.size else math.nan,
                "max_abs_z": float(np.abs(z).max()) if z.size else math.nan,
                "median_rel_stderr": float(np.median(rel)) if rel.size else math.nan,
            }
        )
    every = np.concatenate([z for _, z in zs])
    prov = sets[0][2].provenance
    data = {
        "variant": str(prov.get("variant", "?")),
        "spp": int(prov.get("spp", 0)),
        "seconds": float(seconds),
        "n": int(every.size),
        "median_abs_z": float(np.median(np.abs(every))) if every.size else math.nan,
        "max_abs_z": float(np.abs(every).max()) if every.size else math.nan,
        "expected_median_abs_z": HALF_NORMAL_MEDIAN,
        "sets": rows,
    }
    return WitnessSection(data, _histogram_png(zs, data, dpi))


def _histogram_png(zs: list[tuple[str, np.ndarray]], data: dict[str, Any], dpi: int) -> bytes:
    """Stacked histograms of z per light (floor and random together), N(0, 1) in black."""
    import matplotlib

    matplotlib.use("Agg")
    from matplotlib.figure import Figure

    lights: dict[str, list[np.ndarray]] = {}
    for label, z in zs:
        lights.setdefault(label.split(" ")[0], []).append(z)
    fig = Figure(figsize=(6.4, 3.6), layout="constrained")
    ax = fig.add_subplot()
    edges = np.linspace(-_Z_EDGE, _Z_EDGE, 41)
    stacks = [np.clip(np.concatenate(v), -_Z_EDGE + 1e-9, _Z_EDGE - 1e-9) for v in lights.values()]
    colors = ["#0072b2", "#e69f00", "#009e73", "#cc79a7"]
    ax.hist(
        stacks,
        bins=edges,
        stacked=True,
        color=colors[: len(stacks)],
        label=[f"{k} (floor + random)" for k in lights],
    )
    n = sum(s.size for s in stacks)
    x = np.linspace(-_Z_EDGE, _Z_EDGE, 401)
    width = edges[1] - edges[0]
    ax.plot(x, n * width * np.exp(-0.5 * x**2) / math.sqrt(2 * math.pi), "k-", label="N(0, 1)")
    for side in (-1, 1):
        out = sum(int(np.sum(side * np.concatenate(v) >= _Z_EDGE)) for v in lights.values())
        if out:
            ax.plot([side * _Z_EDGE], [0], marker="<" if side < 0 else ">", color="red", ms=10)
            ax.annotate(
                f"{out} beyond",
                (side * _Z_EDGE, 0),
                textcoords="offset points",
                xytext=(-40 * (side > 0), 12),
                color="red",
            )
    ax.set_xlim(-_Z_EDGE, _Z_EDGE)
    ax.set_xlabel("z = (Mitsuba − exact) / stderr")
    ax.set_ylabel("receivers")
    ax.set_title(
        f"Mitsuba witness: median |z| = {data['median_abs_z']:.2f} "
        f"(calibrated: {HALF_NORMAL_MEDIAN:.2f})\n{data['n']} receivers, "
        f"{data['spp']} samples each, {data['variant']}",
        fontsize="medium",
    )
    ax.legend(loc="upper left", fontsize="small", frameon=False)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


# ----------------------------------------------------------------------------- the cache
#: The renderer's libraries: another version renders again.
_RENDERER_LIBRARIES = ("mitsuba", "drjit")


def witness_key(emitters: Any, renderer: str = "data_gen", **settings: Any) -> str | None:
    """The cache key of the witness of `emitters` rendered by the package `renderer` with
    `settings`: with the renderer's source files and its libraries' versions (attenfit's own
    version keys the cache itself). None where the renderer cannot be found (nothing to
    cache: it cannot render either)."""
    import importlib.util
    from importlib import metadata
    from pathlib import Path

    from .. import _cache

    try:
        spec = importlib.util.find_spec(renderer)
    except (ImportError, ValueError):
        return None
    if spec is None or not spec.submodule_search_locations:
        return None
    source = hashlib.sha256()
    for folder in spec.submodule_search_locations:
        for path in sorted(Path(folder).rglob("*.py")):
            source.update(str(path.relative_to(folder)).encode() + path.read_bytes())
    versions = {}
    for name in _RENDERER_LIBRARIES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = None
    return _cache.fingerprint(emitters, renderer, source.hexdigest(), versions, settings)


def cached_witness(key: str | None) -> WitnessSection | None:
    """The witness section cached under `key` (`witness_key`), or None."""
    from .. import _cache

    payload = None if key is None else _cache.read("witness", key)
    if payload is None:
        return None
    entry = json.loads(payload)
    png = base64.b64decode(entry["png"])
    if not png.startswith(b"\x89PNG\r\n\x1a\n"):
        _cache.notice("ignoring a cache entry that holds no witness figure; it will be rebuilt")
        return None
    return WitnessSection(entry["data"], png)


def store_witness(key: str | None, section: WitnessSection) -> None:
    """Cache `section` under `key` (`witness_key`), so that a later report with the same
    lights and renderer renders nothing."""
    from .. import _cache

    if key is not None:
        png = base64.b64encode(section.png).decode("ascii")
        _cache.write("witness", key, json.dumps({"data": section.data, "png": png}).encode())
