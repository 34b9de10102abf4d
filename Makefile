# stereo-nav: `make demo` and `make test` each set up .venv from nothing, then run.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
STAMP := $(VENV)/.installed
TORCH_CPU := torch==2.13.0
export PYOPENGL_PLATFORM ?= egl

.PHONY: demo test lint format benchmark evaluate clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# The pinned CPU build of torch first: a bare `torch` requirement would pull a CUDA build.
$(STAMP): pyproject.toml | $(PY)
	$(PIP) install --quiet $(TORCH_CPU)
	$(PIP) install --quiet -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	$(PY) scripts/demo.py --out out/demo

test: $(STAMP)
	$(PY) -m pytest -q -n 2 tests

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .

format: $(STAMP)
	$(PY) -m ruff format .
	$(PY) -m ruff check --fix .

benchmark: $(STAMP)
	$(PY) scripts/benchmark.py --json out/benchmark.json

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache
