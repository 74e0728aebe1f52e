"""How long a person waits for the command line: each command in fresh processes, cold (an
empty cache: everything traced and compiled) and warm (run again with the cache the cold run
left), and how long Ctrl-C takes to end a render.

    python -m benchmarks latency

Each command runs as `python -m attenfit ...` with its own cache folder (`ATTENFIT_CACHE_DIR`),
stdout and stderr to files (not a terminal: no progress drawing). Warm times are the median
of three runs. The goals (issue 20) are printed beside the times.
"""

from __future__ import annotations

import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "examples" / "scenes"

#: (label, argv, cold goal s, warm goal s); None: no goal.
COMMANDS = [
    ("attenfit --help", ["--help"], None, 0.3),
    ("attenfit families", ["families"], None, 0.8),
    *(
        (f"attenfit scene {name}", ["scene", str(SCENES / name)], 10.0, 2.0)
        for name in ("room.toml", "vpl_on_surface.toml", "short_range.toml", "spotlight.toml")
    ),
    ("attenfit report", ["report", "--out", "{tmp}/report", "--force"], 25.0, 10.0),
]
WARM_RUNS = 3


def _run(argv: list[str], cache: Path, tmp: Path) -> float:
    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO)}
    args = [a.replace("{tmp}", str(tmp)) for a in argv]
    start = time.perf_counter()
    with open(tmp / "out.txt", "w") as out, open(tmp / "err.txt", "w") as err:
        proc = subprocess.run(
            [sys.executable, "-m", "attenfit", *args], env=env, stdout=out, stderr=err
        )
    took = time.perf_counter() - start
    if proc.returncode != 0:
        raise SystemExit(
            f"attenfit {' '.join(args)} exited {proc.returncode}: {(tmp / 'err.txt').read_text()[-500:]}"
        )
    return took


def _interrupt(tmp: Path, cache: Path, after: float) -> float:
    """Seconds from SIGINT to exit of a Mitsuba render started `after` seconds before."""
    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO)}
    argv = ["gen", "--emitter", "sphere", "--radius", "0.5", "--receivers", "random", "--samples",
            "512", "--spp", "262144", "--chunk", "32", "--out", str(tmp / "g.npz"), "--force"]  # fmt: skip
    proc = subprocess.Popen(
        [sys.executable, "-m", "attenfit", *argv], env=env,
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    time.sleep(after)
    start = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    proc.wait(timeout=120)
    took = time.perf_counter() - start
    if proc.returncode != 130:
        raise SystemExit(f"attenfit gen after SIGINT exited {proc.returncode}, not 130")
    return took


def _goal(seconds: float, goal: float | None) -> str:
    if goal is None:
        return ""
    return f"{'meets' if seconds <= goal else 'misses'} <= {goal:g} s"


def main() -> None:
    print(f"fresh processes, {os.cpu_count()} cores; warm: median of {WARM_RUNS} runs")
    print(f"{'command':40s} {'cold s':>8s} {'warm s':>8s}   goals (cold, warm)")
    with tempfile.TemporaryDirectory() as root:
        for i, (label, argv, cold_goal, warm_goal) in enumerate(COMMANDS):
            cache = Path(root) / f"cache{i}"
            tmp = Path(root) / f"tmp{i}"
            tmp.mkdir()
            cold = _run(argv, cache, tmp)
            warm = statistics.median(_run(argv, cache, tmp) for _ in range(WARM_RUNS))
            goals = ", ".join(g for g in (_goal(cold, cold_goal), _goal(warm, warm_goal)) if g)
            print(f"{label:40s} {cold:8.2f} {warm:8.2f}   {goals}", flush=True)
        tmp = Path(root) / "gen"
        tmp.mkdir()
        exits = [_interrupt(tmp, Path(root) / "cache-gen", after) for after in (1.0, 3.0, 8.0)]
        print(
            f"{'Ctrl-C to exit, attenfit gen':40s} {max(exits):8.2f} s at most "
            f"(sent 1, 3 and 8 s in: {', '.join(f'{t:.2f}' for t in exits)} s)   goal <= 1 s"
        )


if __name__ == "__main__":
    main()
