# Everything runs from a virtual environment made here from pyproject.toml.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint format bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[all,dev]"
	@# Compile the numba kernels here, once (numba caches them), so that the timings of
	@# `make demo` and of the first runs are those of warm kernels.
	$(BIN)/exactgrasp demo --quick --no-progress --out $(VENV)/compiled-kernels >/dev/null
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/exactgrasp demo --out demo-output

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check . && $(BIN)/ruff format --check .

format: $(STAMP)
	$(BIN)/ruff format . && $(BIN)/ruff check --fix .

bench: $(STAMP)
	$(BIN)/python benchmarks/voxel.py
	$(BIN)/python benchmarks/exact.py
	$(BIN)/python benchmarks/cold_start.py

clean:
	rm -rf $(VENV) demo-output .pytest_cache
