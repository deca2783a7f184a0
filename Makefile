# bayesnsi developer entry points: each target creates .venv when missing.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin

.PHONY: venv lint test demo bench clean

$(BIN)/bayesnsi: pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(BIN)/bayesnsi

venv: $(BIN)/bayesnsi

# lint: ruff (style, imports, bugbear; [tool.ruff]) and mypy on the whole package ([tool.mypy]);
# docs/architecture.md lists the architecture tests.
lint: venv
	$(BIN)/ruff check bayesnsi tests
	$(BIN)/mypy

# test: the suite on TEST_WORKERS processes (pytest-xdist; 2 by default, one per core of the CI machine;
# `make test TEST_WORKERS=0` runs it in one process), one BLAS thread each.
TEST_WORKERS ?= 2
test: lint
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1 $(BIN)/python -m pytest -q -n $(TEST_WORKERS) --durations=10

demo: venv
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(BIN)/bayesnsi demo --out demo-report --force

bench: venv
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(BIN)/python benchmarks/nsi.py

clean:
	rm -rf $(VENV) demo-report
