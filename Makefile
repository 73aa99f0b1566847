# armlab — the two commands: `make demo` and `make test` (`make lint`: the CI quality gates).
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed-stamp
# the dependency versions .venv installs (pip constraints); `make lock` regenerates it
LOCK := requirements/lock.txt
# the versions `make bench` adds for the peers (the bench extra over $(LOCK)); `make lock` too
BENCH_LOCK := requirements/lock-bench.txt

.PHONY: demo test test-latest lint docs bench soak clean setup lock

setup: $(STAMP)

$(STAMP): pyproject.toml $(LOCK)
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -c $(LOCK) -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(VENV)/bin/armlab run --out out/demo

test: $(STAMP)
	MPLBACKEND=Agg $(PY) -m pytest -q

# the suite against the newest releases pyproject.toml allows (no lock), in its own .venv-latest
test-latest:
	rm -rf .venv-latest
	$(PYTHON) -m venv .venv-latest
	.venv-latest/bin/python -m pip install --quiet --upgrade pip
	.venv-latest/bin/python -m pip install --quiet --upgrade -e ".[test]"
	.venv-latest/bin/python -m pip freeze --exclude-editable > .venv-latest/versions.txt
	MPLBACKEND=Agg .venv-latest/bin/python -m pytest -q

# regenerate $(LOCK): the newest allowed releases of the test and docs extras, frozen; then
# $(BENCH_LOCK): the bench extra installed over those versions, the packages it adds, frozen
lock:
	rm -rf .venv-lock
	$(PYTHON) -m venv .venv-lock
	.venv-lock/bin/python -m pip install --quiet --upgrade pip
	.venv-lock/bin/python -m pip install --quiet -e ".[test,docs]"
	head -n 3 $(LOCK) > $(LOCK).new
	.venv-lock/bin/python -m pip freeze --exclude-editable | grep -v '^armlab' >> $(LOCK).new
	mv $(LOCK).new $(LOCK)
	.venv-lock/bin/python -m pip install --quiet -c $(LOCK) -e ".[test,docs,bench]"
	head -n 3 $(BENCH_LOCK) > $(BENCH_LOCK).new
	.venv-lock/bin/python -m pip freeze --exclude-editable | grep -v '^armlab' \
		| { grep -v -x -F -f $(LOCK) || true; } >> $(BENCH_LOCK).new
	mv $(BENCH_LOCK).new $(BENCH_LOCK)
	rm -rf .venv-lock

# ruff (lint + format check) and mypy (files and settings in pyproject.toml [tool.mypy])
lint: $(STAMP)
	$(VENV)/bin/ruff check research tests benchmarks
	$(VENV)/bin/ruff format --check research tests benchmarks
	$(VENV)/bin/mypy

# the documentation (docs/, mkdocs.yml) into build/site; warnings are errors
docs: $(STAMP)
	$(PY) -m pip install --quiet -c $(LOCK) -e ".[test,docs]"
	$(VENV)/bin/mkdocs build --strict

# every benchmarks/bench_*.py (outputs in out/bench/); regenerates README.md's benchmark table;
# the peers (TOPP-RA, Robotics Toolbox) at the versions of $(BENCH_LOCK), the rest at $(LOCK)'s
bench: $(STAMP)
	$(PY) -m pip install --quiet -c $(LOCK) -c $(BENCH_LOCK) -e ".[test,bench]"
	$(PY) benchmarks/run_all.py --update-readme

# the planner property checks of tests/planning/test_planner_properties.py on many more random cases:
# up to 100 000 per planner (2 000 per optimiser) or 60 minutes each; counts in out/soak.json
soak: $(STAMP)
	MPLBACKEND=Agg OPENBLAS_NUM_THREADS=1 $(PY) tests/soak_planners.py --cases 100000 \
		--optimiser-cases 2000 --minutes 60 --out out/soak.json

clean:
	rm -rf $(VENV) .venv-latest .venv-lock out .pytest_cache
