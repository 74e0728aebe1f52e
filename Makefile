# The two entry points of the README: `make report` (the main job) and `make test`; every
# target creates .venv when it is missing and installs the project into it.
VENV ?= .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.attenfit-installed

.PHONY: report test lint format bench docs clean

$(STAMP): pyproject.toml
	test -x $(PY) || python3 -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	@# NVIDIA's compilers (SASS counts) only if their wheels install cleanly here; without
	@# them attenfit counts SPIR-V alone and the SASS tests skip with the reason.
	$(PY) -m pip install --quiet -e '.[dev,shader]' \
	  || echo "note: the optional [shader] extra (NVIDIA compiler wheels) did not install; SASS counts are skipped"
	touch $(STAMP)

# An existing report is replaced only when asked: `make report FORCE=1`.
report: $(STAMP)
	$(VENV)/bin/attenfit report $(if $(FORCE),--force)

test: $(STAMP)
	$(VENV)/bin/pytest

lint: $(STAMP)
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/ruff check .

format: $(STAMP)
	$(VENV)/bin/ruff format .
	$(VENV)/bin/ruff check --fix .

bench: $(STAMP)
	$(PY) -m benchmarks

# Every generated table and figure of README.md and docs/ (docs/generate.py).
docs: $(STAMP)
	$(PY) docs/generate.py

clean:
	rm -rf $(VENV) attenfit-report .pytest_cache .hypothesis
