"""What each family's shader costs as compiled, beside its stable form and the engine's code.

For every registered family (default parameters baked in): SPIR-V instructions
(glslangValidator, `spirv-opt -O`) and NVIDIA SASS instructions (NVRTC `--use_fast_math`,
`ptxas -O3`, sm_89; MUFU in parentheses) of the shader form `attenfit export` writes and of
the stable form (`--form stable`), and, where an engine ships the curve, of the engine's own
function (`attenfit._shaders._engines`) with the ratio shader/engine in SPIR-V instructions.
Compiles are cached (`~/.cache/attenfit/compiled`), so a second run takes a second.

Run: `python -m benchmarks shader` (about a minute uncached on 2 cores).
"""

from __future__ import annotations

import time

import attenfit
from attenfit._shaders._compilers import compilers
from attenfit._shaders._engines import engine_table


def _n(c, mufu: bool = False) -> str:
    if c is None:
        return "-"
    return f"{c.total}({c.classes['mufu']})" if mufu else str(c.total)


def main() -> None:
    print("compilers:", ", ".join(f"{k} {v or 'missing'}" for k, v in compilers().items()))
    start = time.perf_counter()
    fams = {n: attenfit.get_family(n)() for n in attenfit.list_families()}
    rows = engine_table(fams)
    print(f"(compiling: {time.perf_counter() - start:.1f} s)")
    head = (
        f"{'family':17s} {'form':6s} {'spv':>4s} {'stable':>6s} {'engine':>6s} {'ratio':>5s}  "
        f"{'sass(mufu)':>10s} {'stable':>7s} {'engine':>7s}  engine code"
    )
    print(head)
    print("-" * len(head))
    for r in rows:
        sh, st = r["shader"], r["stable"]
        ratio = f"{r['ratio']:.2f}" if "ratio" in r else "-"
        print(
            f"{r['family']:17s} {sh.form:6s} {_n(sh.spirv):>4s} {_n(st.spirv):>6s} "
            f"{_n(r.get('engine_spirv')):>6s} {ratio:>5s}  {_n(sh.sass, True):>10s} "
            f"{_n(st.sass, True):>7s} {_n(r.get('engine_sass'), True):>7s}  {r.get('engine', '')}"
        )
    worst = max((r["ratio"] for r in rows if "ratio" in r), default=None)
    if worst is not None:
        print(f"largest ratio shader/engine (SPIR-V): {worst:.2f}")


if __name__ == "__main__":
    main()
