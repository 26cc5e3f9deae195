# mcpilco developer entry points. Every target creates/reuses the virtual environment.
PYTHON ?= python3
VENV   := .venv
PY     := $(VENV)/bin/python
TORCH  := torch==2.13.0
TORCH_INDEX ?=   # e.g. https://download.pytorch.org/whl/cpu: the CPU wheel (PyPI's Linux wheel is the CUDA build)
STAMP  := $(VENV)/.installed
TEST_WORKERS ?= auto   # pytest-xdist workers (one per core); 0 runs the tests in one process

.PHONY: help install smoke train test test-slow bench bench-control bench-trial docs screenshot lint clean

help:  ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  %-10s %s\n", $$1, $$2}'

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet $(TORCH) $(if $(strip $(TORCH_INDEX)),--index-url $(strip $(TORCH_INDEX)))   # pinned first
	$(PY) -m pip install --quiet -e '.[dev,gym]'   # gym: the Gymnasium adapter's tests run too
	touch $(STAMP)

install: $(STAMP)  ## create the virtual environment and install mcpilco

SMOKE_DIR ?= runs/smoke

smoke: $(STAMP)  ## one minute end to end: two tiny trials (not the thesis's settings), replay, summary
	$(PY) -m runners.train +experiment=smoke hydra.run.dir=$(SMOKE_DIR) overwrite=true
	$(PY) -m runners.replay $(SMOKE_DIR)
	$(PY) -m analysis.summary $(SMOKE_DIR)

train: $(STAMP)  ## run the default experiment (cart-pole swing-up, MC-PILCO, SE kernel)
	$(PY) -m runners.train $(ARGS)

test: $(STAMP)  ## run the test suite (the command CI runs), one worker per core
	$(PY) -m pytest -q -n $(TEST_WORKERS)

test-slow: $(STAMP)  ## run the long learning tests too
	$(PY) -m pytest -q -m slow -n $(TEST_WORKERS)

bench: $(STAMP)  ## time one policy-optimisation step, a GP fit and the torque controllers' calls
	$(PY) -m runners.bench $(ARGS)

bench-control: $(STAMP)  ## controller latency per 1 kHz call (ARGS: --points --kernels --dtypes ...)
	$(PY) -m runners.bench_control $(ARGS)

bench-trial: $(STAMP)  ## time trial 1 at thesis settings, float64 and mixed (minutes)
	$(PY) -m runners.bench_trial $(ARGS)

docs: $(STAMP)  ## regenerate the configuration reference and results tables, build the site (strict) into site/
	$(PY) -m analysis.config_reference
	$(PY) -m analysis.results_tables
	NO_MKDOCS_2_WARNING=1 $(VENV)/bin/mkdocs build --strict --quiet

screenshot: $(STAMP)  ## RUN=<run dir>: its Rerun recording in the web viewer (headless Chromium) -> PNG
	$(PY) -m analysis.screenshot $(RUN) $(ARGS)

lint: $(STAMP)  ## ruff
	$(VENV)/bin/ruff check mcpilco runners analysis tests hydra_plugins examples
	$(VENV)/bin/ruff format --check mcpilco runners analysis tests hydra_plugins examples

clean:  ## remove the virtual environment and caches
	rm -rf $(VENV) .pytest_cache .ruff_cache site
