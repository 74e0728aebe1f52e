"""`python -m benchmarks NAME --option value` hands every main that takes parameters the
options as a list of strings (benchmarks/__main__.py); each such main must parse them."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
from pathlib import Path

import pytest

BENCHMARKS = Path(__file__).resolve().parent.parent / "benchmarks"
NAMES = sorted(
    m.name for m in pkgutil.iter_modules([str(BENCHMARKS)]) if m.name.startswith("bench_")
)


@pytest.mark.parametrize("name", NAMES)
def test_a_benchmark_main_with_parameters_takes_the_runner_s_option_list(name):
    main = importlib.import_module(f"benchmarks.{name}").main
    params = list(inspect.signature(main).parameters.values())
    if not params:
        return
    assert len(params) == 1 and params[0].default is None, name
    assert params[0].annotation in ("list[str] | None", list[str] | None), name


def test_the_engine_benchmark_refuses_a_bad_option_before_any_work():
    from benchmarks import bench_engines

    with pytest.raises(SystemExit) as exc:
        bench_engines.main(["--samples", "many"])
    assert exc.value.code == 2
