"""The numbers behind the seeds' claims, each from the results or a direct evaluation."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from . import _metrics as M
from ._configs import WINDOWED
from ._evaluate import eval_f64


# ============================================================================ findings
def seed_findings(classes, configs, results, models) -> list[dict[str, Any]]:
    """The numbers behind the seeds' claims, each from the results or a direct evaluation."""
    names = {c.name for c in classes}
    out: list[dict[str, Any]] = []

    def row(fam, cfg, mode):
        for r in results:
            if r["family"] == fam and r["config"] == cfg and r["mode"] == mode:
                return r
        return None

    def add(key, quantity, value, config="", expected=None):
        out.append(
            {
                "key": key,
                "quantity": quantity,
                "value": value,
                "config": config,
                "expected": expected,
            }
        )

    sphere = next(
        (
            c
            for c in configs
            if c.kind == "sphere" and c.sweep is not None and c.source.startswith("attenfit")
        ),
        None,
    )
    disk = next(
        (
            c
            for c in configs
            if c.kind == "disk" and c.sweep is not None and c.source.startswith("attenfit")
        ),
        None,
    )

    if sphere is not None and "inverse_square" in names:
        r = row("inverse_square", sphere.name, "published")
        if r and r["sweep"]:
            add(
                "sphere_inverse_square_max_error",
                "inverse-square vs the sphere, receivers facing it from contact to 1000 r: max |rel. error|",
                r["sweep"]["overall"]["max_abs"],
                sphere.name,
                0.0,
            )
        if r and r["plane"]:
            add(
                "sphere_plane_inverse_square_max_error",
                "inverse-square vs the sphere touching a plane (every receiver unclipped): image max |rel. error|",
                r["plane"]["image"]["max_abs"],
                sphere.name,
                0.0,
            )
    if disk is not None:
        r = disk.radius
        sw = disk.sweep
        if "inverse_square" in names:
            rr = row("inverse_square", disk.name, "published")
            if rr and rr["sweep"]:
                add(
                    "disk_inverse_square_near_max_error",
                    "inverse-square vs the facing disk, near band d < r: max |rel. error|",
                    rr["sweep"]["bands"]["near"]["max_abs"],
                    disk.name,
                )
        for fam, key, what in (
            (
                "yuksel_adhoc",
                "disk_eq8_at_zero_ratio",
                "eq. 8 (yuksel_adhoc, r) / facing disk at d = 0",
            ),
            ("yuksel", "disk_eq7_at_zero_ratio", "eq. 7 (yuksel, r) / facing disk at d = 0"),
            ("disk_facing", "disk_facing_at_zero_ratio", "disk_facing (r) / facing disk at d = 0"),
        ):
            if fam in names:
                rr = row(fam, disk.name, "published")
                if rr and rr["sweep"]:
                    add(
                        key,
                        what,
                        rr["sweep"]["at_zero"]["ratio"],
                        disk.name,
                        2.0 if fam != "disk_facing" else 1.0,
                    )
        if "yuksel_adhoc" in names:
            cls = next(c for c in classes if c.name == "yuksel_adhoc")
            m = cls(r=math.sqrt(2.0) * r)
            f = eval_f64(m, sw.d)
            rel = M.relative_error(f, sw.truth)
            f0 = float(eval_f64(m, np.zeros(1))[0])
            worst = max(float(np.nanmax(np.abs(rel))), abs(f0 / sw.truth0 - 1.0))
            add(
                "disk_eq8_sqrt2_max_error",
                "eq. 8 with r' = √2 r vs the facing disk, d = 0 to 1000 r: max |rel. error|",
                worst,
                disk.name,
                0.0,
            )
            fr = row("yuksel_adhoc", disk.name, "fitted")
            if fr and fr["status"] == "ok":
                add(
                    "disk_eq8_fitted_radius_over_r",
                    "eq. 8 fitted to the facing disk: r' / r",
                    fr["params"]["r"] / r,
                    disk.name,
                    math.sqrt(2.0),
                )
        if {"yuksel", "yuksel_adhoc", "inverse_square"} <= names:
            get = {c.name: c for c in classes}
            f7 = eval_f64(get["yuksel"](r=r), sw.d)
            f8 = eval_f64(get["yuksel_adhoc"](r=r), sw.d)
            fi = eval_f64(get["inverse_square"](), sw.d)
            tol = 1e-12
            between = (f7 <= f8 * (1 + tol)) & (f8 <= fi * (1 + tol))
            add(
                "eq8_between_eq7_and_inverse_square",
                "fraction of distances (0.001 r to 1000 r) where eq. 7 ≤ eq. 8 ≤ 1/d²",
                float(np.mean(between)),
                disk.name,
                1.0,
            )
        if "disk_facing" in names:
            rr = row("disk_facing", disk.name, "published")
            if rr and rr["sweep"]:
                add(
                    "disk_facing_max_error",
                    "disk_facing (r) vs the facing disk: max |rel. error|",
                    rr["sweep"]["overall"]["max_abs"],
                    disk.name,
                    0.0,
                )
    if sphere is not None:
        for cls in classes:
            if cls.window not in WINDOWED:
                continue
            r = row(cls.name, sphere.name, "published")
            if not r or r["status"] != "ok":
                continue
            en = (r["plane"] or {}).get("energy") or {}
            add(
                f"window_{cls.name}_inner_half_max_error",
                f"{cls.name} (published) vs the sphere, d ≤ range/2: max |rel. error|",
                ((r["sweep"] or {}).get("inner_half") or {}).get("max_abs"),
                sphere.name,
            )
            add(
                f"window_{cls.name}_reach_1pct",
                f"{cls.name}: off by > 1% from this fraction of its range on",
                ((r["sweep"] or {}).get("reach") or {}).get("1%"),
                sphere.name,
            )
            if en.get("discarded_fraction") is not None:
                add(
                    f"window_{cls.name}_energy_dropped",
                    f"{cls.name}: fraction of the true plane energy beyond its range",
                    en["discarded_fraction"],
                    sphere.name,
                )
                add(
                    f"window_{cls.name}_energy_ratio",
                    f"{cls.name}: plane energy / true plane energy",
                    en.get("ratio"),
                    sphere.name,
                )
    return out
