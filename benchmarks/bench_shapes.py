"""The rectangle's and the tube's models at their worst case (docs/area.md, "Rectangle and tube
lights"): `python -m benchmarks shapes` prints the table pasted there.

Each model on each configuration of `attenfit._judge.SHAPE_CONFIGS` (a floor under a square
panel at h = w/4, w, 4 w; a wall beside a tube of radius l/100 at D = l/4, l, 4 l),
`shape_worst_case` (a 33 x 33 grid over a quadrant of the plane, then a local search from its
three largest distinct errors), with the compiled cost of its shader form
(`area_compiled_cost`: SPIR-V instructions where the compilers are installed). About a
minute on 2 cores (the tube's truth is a quadrature).
"""

from __future__ import annotations

from attenfit import area
from attenfit._curves import (
    ClippedDisk,
    ClippedRect,
    FrostbiteRect,
    FrostbiteTube,
    KarisTube,
    LambertLine,
    MrpRect,
    SnyderSphere,
    ThreeRect,
    UnrealRect,
)
from attenfit._judge import SHAPE_CONFIGS, shape_worst_case
from attenfit._shaders import area_compiled_cost


def _models(light: str) -> list:
    if light == "rect":
        return [
            area.PointLight(),
            ClippedDisk(),
            ClippedRect(),
            ThreeRect(),
            FrostbiteRect(),
            MrpRect(),
            UnrealRect(),
        ]
    return [area.PointLight(), SnyderSphere(), KarisTube(), FrostbiteTube(), LambertLine()]


def _pct(x: float) -> str:
    return f"{100 * x:.3g}%" if x >= 1e-6 else f"{100 * x:.1e}%"


def main() -> None:
    costs: dict[str, float] = {}
    print("| configuration | model | worst case | where (x, y, z) / size | typical (p95) | cost |")
    print("| --- | --- | ---: | --- | ---: | ---: |")
    for config in SHAPE_CONFIGS:
        for m in _models(config.light):
            if m.name not in costs:
                costs[m.name] = area_compiled_cost(m).cost
            w = shape_worst_case(m, config)
            name = "point_light (1/d^2)" if m.name == "point_light" else m.name
            print(
                f"| {config.label} | `{name}` | {_pct(w.error)} | {w.where()} | "
                f"{_pct(w.typical)} | {costs[m.name]:g} |",
                flush=True,
            )
    print(f"\ncost: {area_compiled_cost(ClippedRect()).label()}")


if __name__ == "__main__":
    main()
