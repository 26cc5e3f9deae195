# mcpilco developer entry points. Every target creates/reuses the virtual environment.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
TORCH  := torch==2.13.0
STAMP  := $(VENV)/.installed
TEST_WORKERS ?= auto   # pytest-xdist workers (one per core); 0 runs the tests in one process

.PHONY: help install train test test-slow bench bench-trial screenshot lint clean

help:  ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  %-10s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(TORCH)   # pinned first: keeps the CPU wheel, no CUDA build
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

install: $(STAMP)  ## create the virtual environment and install mcpilco

train: $(STAMP)  ## run the default experiment (cart-pole swing-up, MC-PILCO, SE kernel)
	$(PY) -m runners.train $(ARGS)

test: $(STAMP)  ## run the test suite (the command CI runs), one worker per core
	$(PY) -m pytest -q -n $(TEST_WORKERS)

test-slow: $(STAMP)  ## run the long learning tests too
	$(PY) -m pytest -q -m slow -n $(TEST_WORKERS)

bench: $(STAMP)  ## time one policy-optimisation step and a GP fit
	$(PY) -m runners.bench $(ARGS)

bench-trial: $(STAMP)  ## time trial 1 at thesis settings, float64 and mixed (minutes)
	$(PY) -m runners.bench_trial $(ARGS)

screenshot: $(STAMP)  ## RUN=<run dir>: its Rerun recording in the web viewer (headless Chromium) -> PNG
	$(PY) -m analysis.screenshot $(RUN) $(ARGS)

lint: $(STAMP)  ## ruff
	$(VENV)/bin/ruff check mcpilco runners analysis tests hydra_plugins
	$(VENV)/bin/ruff format --check mcpilco runners analysis tests hydra_plugins

clean:  ## remove the virtual environment and caches
	rm -rf $(VENV) .pytest_cache .ruff_cache
