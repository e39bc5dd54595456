# Everything runs from a virtual environment made here from pyproject.toml.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test lint format bench clean

# What building the compiled kernels needs beside a C compiler (pyproject.toml's build-system
# requirements, and ninja), installed into the environment: an editable install rebuilds a
# changed kernel on import with them.
BUILD_DEPS := "meson-python>=0.18" "meson>=1.2" "Cython>=3.0.8" "ninja"

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet $(BUILD_DEPS)
	@# Editable, without build isolation (meson-python's way): the build folder build/ keeps
	@# calling this environment's meson, ninja and cython (found by their full paths).
	PATH="$(CURDIR)/$(BIN):$$PATH" CYTHON="$(CURDIR)/$(BIN)/cython" \
		$(BIN)/python -m pip install --quiet --no-build-isolation -e ".[all,dev]"
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
	rm -rf $(VENV) build demo-output .pytest_cache
