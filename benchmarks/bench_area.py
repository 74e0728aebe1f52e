"""What no distance curve can fix: the point-light model with the best possible f(d) against
the area-light models, on the configurations of issue 18.

Per configuration (the floor under a one-sided disk at h = r/4, r, 4r; receivers of any
orientation around a sphere at d/r 1-1.5, 1.5-3, 3-10, 10-100; a capsule beside a wall):
the best possible f(d) (the exact facing attenuation, `attenfit._report._ceiling_eval`) and
each area model written for the light, shipped and (on the goal configurations) fitted:
max relative error over the receivers above 0.1% of their facing value, max absolute error
in units of the facing value, energy ratio, and the compiled cost of its shader form
(SPIR-V instructions, glslangValidator + spirv-opt -O; the point-light model's cost is
PointLight(family)'s, the family's form times g max(0, n.l)). Exact irradiance: attenfit's
closed forms (the capsule's by quadrature).

Goal (issue 18): an area model within 1% on the disk floor at h = r/4 and the sphere at
d/r 1-1.5. Run: `python -m benchmarks area` (about two minutes uncached on 2 cores).
"""

from __future__ import annotations

import time

from attenfit._report._ceiling_eval import ceiling_table, cheapest_within, family_costs


def _pct(x: float) -> str:
    return f"{100 * x:.3g}%" if x < 10 else f"{x:.3g}x"


def main() -> None:
    start = time.perf_counter()
    rows = ceiling_table()
    fams = family_costs()
    print(f"(computed in {time.perf_counter() - start:.1f} s)")
    print("\nThe ceiling: the point-light model with the best possible f(d)")
    print(f"{'configuration':58s} {'max rel':>8s} {'max abs':>8s} {'energy':>7s}")
    for r in rows:
        b = r["best_fd"]
        print(
            f"{r['title']:58s} {_pct(b['max_rel']):>8s} {_pct(b['max_abs']):>8s} {b['energy']:7.3f}"
        )
    lo, hi = min(fams.values()), max(fams.values())
    print(f"\npoint-light model's compiled cost, over {len(fams)} families: {lo:.0f}-{hi:.0f}")
    label = rows[0]["models"][0]["cost_label"]
    print(f"\nArea models (cost: {label})")
    for r in rows:
        print(f"\n{r['title']} (n = {r['n']})")
        print(
            f"  {'model':22s} {'max rel':>9s} {'max abs':>9s} {'energy':>7s} {'cost':>5s}  params"
        )
        for m in r["models"]:
            name = m["name"] + (" (fitted)" if m["fitted"] else "")
            params = (
                ", ".join(f"{k}={v:.4g}" for k, v in m["params"].items()) if m["fitted"] else ""
            )
            print(
                f"  {name:22s} {_pct(m['max_rel']):>9s} {_pct(m['max_abs']):>9s} "
                f"{m['energy']:7.3f} {m['cost']:5.0f}  {params}"
            )
    print("\nGoal: within 1% max relative error")
    for r in rows:
        best = cheapest_within(r, 0.01)
        closest = min(r["models"], key=lambda m: m["max_rel"])
        if best:
            print(
                f"  {r['title']}: {best['name']} ({_pct(best['max_rel'])}, cost {best['cost']:.0f})"
            )
        else:
            print(
                f"  {r['title']}: none; closest {closest['name']}"
                f"{' (fitted)' if closest['fitted'] else ''} ({_pct(closest['max_rel'])})"
            )


if __name__ == "__main__":
    main()
