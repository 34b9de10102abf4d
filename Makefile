# stereo-nav: `make demo` and `make test` each set up .venv from nothing, then run.
# `make test` runs the lint and type checks (`make lint`), then the whole suite; CI runs it.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(PY) -m pip
STAMP := $(VENV)/.installed
DEMO_STAMP := $(VENV)/.installed-demo
TORCH_CPU := torch==2.13.0
export PYOPENGL_PLATFORM ?= egl

.PHONY: demo test lint format benchmark soak fuzz clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PIP) install --quiet --upgrade pip

# The demo needs the environment and the scripted agents only: no torch, no Ray.
$(DEMO_STAMP): pyproject.toml | $(PY)
	$(PIP) install --quiet -e .
	touch $(DEMO_STAMP)

# Everything, for the tests: the pinned CPU build of torch first (a bare `torch` requirement
# would pull a CUDA build), then the dev and rllib extras (the RLlib smoke test runs in CI).
$(STAMP): pyproject.toml | $(PY)
	$(PIP) install --quiet $(TORCH_CPU)
	$(PIP) install --quiet -e '.[dev,rllib]'
	touch $(STAMP) $(DEMO_STAMP)

demo: $(DEMO_STAMP)
	$(PY) scripts/demo.py --out out/demo

test: $(STAMP)
	$(MAKE) --no-print-directory lint
	$(PY) -m pytest -q -n 2 tests

lint: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m ruff format --check .
	$(PY) -m mypy

format: $(STAMP)
	$(PY) -m ruff format .
	$(PY) -m ruff check --fix .

# Writes out/benchmark.json, docs/benchmarks.md (method and every figure), docs/benchmark_summary.md
# (the short table) and pastes that table into README.md.
benchmark: $(STAMP)
	$(PY) scripts/benchmark.py --json out/benchmark.json --report docs/benchmarks.md \
		--summary docs/benchmark_summary.md --readme README.md

# Long runs for leaks and hangs (10,000 steps, 1,000 create/close cycles, vector envs).
soak: $(STAMP)
	$(PY) scripts/soak.py --json out/soak.json

# The hypothesis properties over modeling inputs and map files with 10,000 examples each.
fuzz: $(STAMP)
	HYPOTHESIS_PROFILE=soak $(PY) -m pytest -q -n 2 --hypothesis-show-statistics \
		tests/modeling/test_robustness.py \
		tests/stereo_nav_env/sim/test_map_validation.py::test_mutated_maps_are_refused_or_load

clean:
	rm -rf $(VENV) out .pytest_cache .ruff_cache .mypy_cache
