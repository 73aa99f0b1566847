# armlab — the two commands: `make demo` and `make test` (`make lint`: the CI quality gates).
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test lint docs bench soak clean setup

setup: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/armlab run --out out/demo

test: $(STAMP)
	MPLBACKEND=Agg $(PY) -m pytest -q

# ruff (lint + format check) and mypy (files and settings in pyproject.toml [tool.mypy])
lint: $(STAMP)
	$(VENV)/bin/ruff check research tests benchmarks
	$(VENV)/bin/ruff format --check research tests benchmarks
	$(VENV)/bin/mypy

# the documentation (docs/, mkdocs.yml) into build/site; warnings are errors
docs: $(STAMP)
	$(PY) -m pip install --quiet -e ".[test,docs]"
	$(VENV)/bin/mkdocs build --strict

# every benchmarks/bench_*.py (outputs in out/bench/); regenerates README.md's benchmark table
bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[test,bench]"
	$(PY) benchmarks/run_all.py --update-readme

# the planner property checks of tests/test_planner_properties.py on many more random cases:
# up to 100 000 per planner (2 000 per optimiser) or 60 minutes each; counts in out/soak.json
soak: $(STAMP)
	MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 $(PY) tests/soak_planners.py --cases 100000 \
		--optimiser-cases 2000 --minutes 60 --out out/soak.json

clean:
	rm -rf $(VENV) out .pytest_cache
