"""The numbers behind the seeds' claims, each from the results or a direct evaluation."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _metrics as M
from ._configs import WINDOWED
from ._evaluate import eval_f64


class _Findings:
    """The rows found so far, the results they are read from, and the families by name."""

    def __init__(self, classes, results):
        self.by_name = {c.name: c for c in classes}
        self.results = results
        self.out: list[dict[str, Any]] = []

    def row(self, fam, cfg, mode):
        """The result of family `fam` on configuration `cfg` in `mode`, or None."""
        for r in self.results:
            if r["family"] == fam and r["config"] == cfg and r["mode"] == mode:
                return r
        return None

    def published(self, fam, cfg, path, key, quantity, expected=None):
        """Add the value at `path` of family `fam`'s published result on `cfg`, where the
        family is compared and its result has that part."""
        r = self.row(fam, cfg, "published") if fam in self.by_name else None
        if r and r[path[0]]:
            value = r
            for k in path:
                value = value[k]
            self.add(key, quantity, value, cfg, expected)

    def add(self, key, quantity, value, config="", expected=None):
        self.out.append(
            {"key": key, "quantity": quantity, "value": value, "config": config,
             "expected": expected}
        )  # fmt: skip


def seed_findings(classes, configs, results, models) -> list[dict[str, Any]]:
    """The numbers behind the seeds' claims, each from the results or a direct evaluation."""
    found = _Findings(classes, results)
    sphere = _swept(configs, "sphere")
    disk = _swept(configs, "disk")
    if sphere is not None:
        _sphere_findings(found, sphere)
    if disk is not None:
        _disk_findings(found, disk)
    if sphere is not None:
        _window_findings(found, sphere)
    return found.out


def _swept(configs, kind):
    """attenfit's own swept configuration of `kind`, or None."""
    return next(
        (
            c
            for c in configs
            if c.kind == kind and c.sweep is not None and c.source.startswith("attenfit")
        ),
        None,
    )


def _sphere_findings(found: _Findings, sphere) -> None:
    """Inverse square against the sphere: exact facing it and on a plane it touches."""
    for part, key, what in (
        ("sweep", "sphere_inverse_square_max_error", "inverse-square vs the sphere, receivers facing it from contact to 1000 r: max |rel. error|"),
        ("plane", "sphere_plane_inverse_square_max_error", "inverse-square vs the sphere touching a plane (every receiver unclipped): image max |rel. error|"),
    ):  # fmt: skip
        path = (part, "overall" if part == "sweep" else "image", "max_abs")
        found.published("inverse_square", sphere.name, path, key, what, 0.0)


def _disk_findings(found: _Findings, disk) -> None:
    """Inverse square near the facing disk; Yuksel's curves and the facing disk at d = 0 (and
    eq. 8 against the disk, `_eq8_findings`); the facing disk's own error."""
    found.published(
        "inverse_square", disk.name, ("sweep", "bands", "near", "max_abs"),
        "disk_inverse_square_near_max_error",
        "inverse-square vs the facing disk, near band d < r: max |rel. error|",
    )  # fmt: skip
    for fam, key, what, expected in (
        ("yuksel_adhoc", "disk_eq8_at_zero_ratio", "eq. 8 (yuksel_adhoc, r) / facing disk at d = 0", 2.0),
        ("yuksel", "disk_eq7_at_zero_ratio", "eq. 7 (yuksel, r) / facing disk at d = 0", 2.0),
        ("disk_facing", "disk_facing_at_zero_ratio", "disk_facing (r) / facing disk at d = 0", 1.0),
    ):  # fmt: skip
        found.published(fam, disk.name, ("sweep", "at_zero", "ratio"), key, what, expected)
    _eq8_findings(found, disk)
    found.published(
        "disk_facing", disk.name, ("sweep", "overall", "max_abs"), "disk_facing_max_error",
        "disk_facing (r) vs the facing disk: max |rel. error|", 0.0,
    )  # fmt: skip


def _eq8_findings(found: _Findings, disk) -> None:
    """Yuksel's eq. 8 with r' = sqrt(2) r is the facing disk, and lies between eq. 7 and 1/d^2."""
    get, r, sw = found.by_name, disk.radius, disk.sweep
    if "yuksel_adhoc" in get:
        m = get["yuksel_adhoc"](r=math.sqrt(2.0) * r)
        rel = M.relative_error(eval_f64(m, sw.d), sw.truth)
        f0 = float(eval_f64(m, np.zeros(1))[0])
        worst = max(float(np.nanmax(np.abs(rel))), abs(f0 / sw.truth0 - 1.0))
        found.add(
            "disk_eq8_sqrt2_max_error",
            "eq. 8 with r' = √2 r vs the facing disk, d = 0 to 1000 r: max |rel. error|",
            worst,
            disk.name,
            0.0,
        )
        fr = found.row("yuksel_adhoc", disk.name, "fitted")
        if fr and fr["status"] == "ok":
            found.add(
                "disk_eq8_fitted_radius_over_r",
                "eq. 8 fitted to the facing disk: r' / r",
                fr["params"]["r"] / r,
                disk.name,
                math.sqrt(2.0),
            )
    if {"yuksel", "yuksel_adhoc", "inverse_square"} <= set(get):
        f7 = eval_f64(get["yuksel"](r=r), sw.d)
        f8 = eval_f64(get["yuksel_adhoc"](r=r), sw.d)
        fi = eval_f64(get["inverse_square"](), sw.d)
        tol = 1e-12
        between = (f7 <= f8 * (1 + tol)) & (f8 <= fi * (1 + tol))
        found.add(
            "eq8_between_eq7_and_inverse_square",
            "fraction of distances (0.001 r to 1000 r) where eq. 7 ≤ eq. 8 ≤ 1/d²",
            float(np.mean(between)),
            disk.name,
            1.0,
        )


def _window_findings(found: _Findings, sphere) -> None:
    """Each windowed family as published against the sphere: error, reach, energy dropped."""
    for cls in found.by_name.values():
        if cls.window not in WINDOWED:
            continue
        r = found.row(cls.name, sphere.name, "published")
        if not r or r["status"] != "ok":
            continue
        sweep = r["sweep"] or {}
        en = (r["plane"] or {}).get("energy") or {}
        found.add(
            f"window_{cls.name}_inner_half_max_error",
            f"{cls.name} (published) vs the sphere, d ≤ range/2: max |rel. error|",
            (sweep.get("inner_half") or {}).get("max_abs"),
            sphere.name,
        )
        found.add(
            f"window_{cls.name}_reach_1pct",
            f"{cls.name}: off by > 1% from this fraction of its range on",
            (sweep.get("reach") or {}).get("1%"),
            sphere.name,
        )
        if en.get("discarded_fraction") is not None:
            found.add(
                f"window_{cls.name}_energy_dropped",
                f"{cls.name}: fraction of the true plane energy beyond its range",
                en["discarded_fraction"],
                sphere.name,
            )
            found.add(
                f"window_{cls.name}_energy_ratio",
                f"{cls.name}: plane energy / true plane energy",
                en.get("ratio"),
                sphere.name,
            )
