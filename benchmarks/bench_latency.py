"""How long a person waits for the command line: each command in fresh processes, cold (an
empty cache: everything traced and compiled) and warm (run again with the cache the cold run
left), wall and CPU seconds; and how long Ctrl-C takes to end a render.

    python -m benchmarks latency                      # everything
    python -m benchmarks.bench_latency --skip report gen --warm 3
    ATTENFIT_LATENCY_SKIP=report,gen python -m benchmarks latency

Each command runs as `python -m attenfit ...` with its own cache folder (`ATTENFIT_CACHE_DIR`,
a fresh temporary one: the cold run starts empty, the warm runs read what it left), stdout
and stderr to files (not a terminal: plain progress lines), and Python's bytecode cache on
(as a person's Python has it). Every example scene is a row (TOML, USD, glTF), and one more
asks a new question each run: room.toml with another seed, its random receivers moved, as
a person editing a scene and asking again. CPU seconds are the command's
own and its children's (user + system, `RUSAGE_CHILDREN`): on a loaded machine they move
less than the wall time. Warm times are the median of `--warm` runs. The goals are printed
beside the times, with the load average before and after each command.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENES = REPO / "examples" / "scenes"
BLENDER = SCENES / "blender"

#: The example scenes in TOML, each a row of its own (issue 30: "on each example scene").
TOML_SCENES = ("room", "batten", "downlight", "panel", "short_range", "spotlight",
               "vpl_on_surface")  # fmt: skip
SIDE = ["--side", str(BLENDER / "room.side.toml")]

#: (key for --skip, label, argv, cold goal s, warm goal s); None: no goal. In an argv,
#: "{tmp}" is the command's own folder and "{edited}" a copy of room.toml with another seed
#: written before each run (its random receivers move: a new question of the same shapes).
COMMANDS = [
    ("help", "attenfit --help", ["--help"], None, 0.3),
    ("families", "attenfit families", ["families"], None, 0.8),
    ("export", "attenfit export yuksel --lang glsl", ["export", "yuksel", "--lang", "glsl"],
     None, 0.5),
    *[(f"scene-{name}" if name != "room" else "scene", f"attenfit scene {name}.toml",
       ["scene", str(SCENES / f"{name}.toml")], 10.0, 2.0) for name in TOML_SCENES],
    ("edited", "attenfit scene room.toml, edited each run", ["scene", "{edited}"], 10.0, 2.0),
    ("usd", "attenfit scene blender/room.usda --side ...",
     ["scene", str(BLENDER / "room.usda"), *SIDE], 10.0, 2.0),
    ("gltf", "attenfit scene blender/room.glb --side ...",
     ["scene", str(BLENDER / "room.glb"), *SIDE], 10.0, 2.0),
    ("report", "attenfit report", ["report", "--out", "{tmp}/report", "--force"], 30.0, 10.0),
]  # fmt: skip
WARM_RUNS = 3
_EDITS = iter(range(2, 1 << 30))


def _edited(tmp: Path) -> str:
    """A copy of room.toml with a seed not used before (`{edited}` in an argv)."""
    text = (SCENES / "room.toml").read_text(encoding="utf-8")
    path = tmp / "room-edited.toml"
    path.write_text(text.replace("\nseed = 1\n", f"\nseed = {next(_EDITS)}\n"), "utf-8")
    return str(path)


def _run(argv: list[str], cache: Path, tmp: Path) -> tuple[float, float]:
    """Wall and CPU seconds of `python -m attenfit ARGV` in a fresh process."""
    env = _env(cache)
    args = [_edited(tmp) if a == "{edited}" else a.replace("{tmp}", str(tmp)) for a in argv]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    with open(tmp / "out.txt", "w") as out, open(tmp / "err.txt", "w") as err:
        proc = subprocess.run(
            [sys.executable, "-m", "attenfit", *args], env=env, stdout=out, stderr=err
        )
    took = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if proc.returncode != 0:
        tail = (tmp / "err.txt").read_text()[-500:]
        raise SystemExit(f"attenfit {' '.join(args)} exited {proc.returncode}: {tail}")
    return took, cpu


def _env(cache: Path) -> dict[str, str]:
    """The children's environment: their cache folder, and Python's own bytecode cache on as
    a person's Python has it (a sandbox's PYTHONDONTWRITEBYTECODE would make every process
    compile attenfit's sources again, about 0.25 s)."""
    env = {**os.environ, "ATTENFIT_CACHE_DIR": str(cache), "PYTHONPATH": str(REPO)}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def _interrupt(tmp: Path, cache: Path, after: float) -> float:
    """Seconds from SIGINT to exit of a Mitsuba render started `after` seconds before (its own
    output each, so that no run resumes another's kept chunks; about 40 s of rendering on 2
    cores, so that none finishes first)."""
    env = _env(cache)
    argv = ["gen", "--emitter", "sphere", "--radius", "0.5", "--receivers", "random", "--samples",
            "4096", "--spp", "262144", "--chunk", "32", "--out", str(tmp / f"g{after:g}.npz"),
            "--force"]  # fmt: skip
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


def _load() -> str:
    return "/".join(f"{x:.1f}" for x in os.getloadavg())


def _machine() -> str:
    model = ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return f"{model or platform.processor() or platform.machine()}, {os.cpu_count()} cores"


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_latency")
    keys = [c[0] for c in COMMANDS] + ["gen"]
    parser.add_argument("--skip", nargs="*", default=[], choices=keys, help="commands to skip")
    parser.add_argument("--warm", type=int, default=WARM_RUNS, help="warm runs (the median)")
    if argv is None:  # `python -m benchmarks latency`: options from the environment
        skip = os.environ.get("ATTENFIT_LATENCY_SKIP", "")
        argv = ["--skip", *[s for s in skip.split(",") if s]] if skip else []
    args = parser.parse_args(argv)
    print(f"fresh processes; {_machine()}; load average {_load()} (1/5/15 min)")
    print(f"cold: an empty cache; warm: the cache the cold run left, median of {args.warm}")
    print(
        f"{'command':46s} {'cold wall':>9s} {'cold CPU':>9s} {'warm wall':>9s} {'warm CPU':>9s}"
        "   goals (cold, warm wall)   load before/after"
    )
    with tempfile.TemporaryDirectory() as root:
        for i, (key, label, cmd, cold_goal, warm_goal) in enumerate(COMMANDS):
            if key in args.skip:
                continue
            cache = Path(root) / f"cache{i}"
            tmp = Path(root) / f"tmp{i}"
            tmp.mkdir()
            load = _load()
            cold, cold_cpu = _run(cmd, cache, tmp)
            warm_runs = [_run(cmd, cache, tmp) for _ in range(args.warm)]
            warm = statistics.median(w for w, _ in warm_runs)
            warm_cpu = statistics.median(c for _, c in warm_runs)
            goals = ", ".join(g for g in (_goal(cold, cold_goal), _goal(warm, warm_goal)) if g)
            print(
                f"{label:46s} {cold:9.2f} {cold_cpu:9.2f} {warm:9.2f} {warm_cpu:9.2f}   "
                f"{goals or '-':25s} {load} / {_load()}",
                flush=True,
            )
        if "gen" not in args.skip:
            tmp = Path(root) / "gen"
            tmp.mkdir()
            exits = [_interrupt(tmp, Path(root) / "cache-gen", after) for after in (1.0, 3.0, 8.0)]
            print(
                f"{'Ctrl-C to exit, attenfit gen':46s} {max(exits):9.2f} s at most "
                f"(sent 1, 3 and 8 s in: {', '.join(f'{t:.2f}' for t in exits)} s)   goal <= 1 s"
            )


if __name__ == "__main__":
    main(sys.argv[1:])
