# Two commands on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
OUT ?= results/demo
PYTEST_ARGS ?=
# Tests run in two processes, a test file at a time each (pytest-xdist, --dist loadfile: a module's
# fixtures, such as the CSAIL replay, are computed once): on two cores the suite took 232 s, its
# longest file (the CSAIL replays) 110 s of them (2026-12-01). TEST_WORKERS=0 runs it in one process.
TEST_WORKERS ?= 2

# One BLAS/OpenMP thread per process: with two threads on two cores the COM ran 9-16x slower
# and k-means 10x slower (measured).
export OPENBLAS_NUM_THREADS ?= 1
export OMP_NUM_THREADS ?= 1
export MKL_NUM_THREADS ?= 1
export MPLBACKEND ?= Agg

.PHONY: demo test clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(VENV)/.installed: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@

# --overwrite: each `make demo` replaces the previous demo's results in $(OUT) (a run owns its folder)
demo: $(VENV)/.installed
	$(BIN)/gpexplore explore --out $(OUT) --overwrite

# pytest exits 5 when it collected nothing: that is a failure, not a pass.
test: $(VENV)/.installed-test
	$(BIN)/python -m pytest -n $(TEST_WORKERS) --dist loadfile $(PYTEST_ARGS); rc=$$?; \
	if [ $$rc -eq 5 ]; then echo "pytest collected no tests" >&2; exit 1; fi; exit $$rc

clean:
	rm -rf $(VENV) results .pytest_cache
