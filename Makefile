# One-command set-up: every target builds its own virtual environment first.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
OUT ?= out
# Ray RLlib pins gymnasium==1.2.2: the 'rllib' extra gets a virtual environment of its own.
RLLIB_VENV ?= .venv-rllib
RPY := $(RLLIB_VENV)/bin/python
# The env contract (checkers, native vector env, options), run again on Ray's gymnasium.
CONTRACT_TESTS := tests/envs/test_checkers.py tests/envs/test_vector.py tests/envs/test_options.py

# The core install alone (no extras), in a virtual environment of its own.
CORE_VENV ?= .venv-core

.PHONY: setup setup-rllib demo test test-slow test-rllib test-core lint bench docs clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	# The CPU wheel: an unpinned torch pulls several GB of CUDA packages.
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

# `pip install .` and nothing else: both IDs, the native vector env, the filter and
# Gymnasium's checker run, and what needs an extra says so (tests/core_install.py).
test-core:
	rm -rf $(CORE_VENV)
	$(PYTHON) -m venv $(CORE_VENV)
	$(CORE_VENV)/bin/python -m pip install --quiet .
	rm -rf build  # setuptools' own, left in the tree by the install
	$(CORE_VENV)/bin/python tests/core_install.py

setup-rllib: $(RLLIB_VENV)/.installed

$(RLLIB_VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(RLLIB_VENV)
	$(RPY) -m pip install --quiet --upgrade pip
	$(RPY) -m pip install --quiet torch==2.13.0
	$(RPY) -m pip install --quiet -e '.[dev,rllib]'
	# The extra must keep the CPU torch (an unpinned one pulls several GB of CUDA).
	$(RPY) -c "import torch; assert torch.__version__.startswith('2.13.0+cpu'), torch.__version__"
	touch $@

demo: setup  ## the main job: an exploration episode on the default world, metrics and pictures
	SDL_VIDEODRIVER=dummy $(VENV)/bin/slam-env demo --out $(OUT)

test: setup  ## the default test suite (what CI runs)
	SDL_VIDEODRIVER=dummy $(PY) -m pytest -n 2 -q -m "not slow"

test-slow: setup  ## long runs: soak, long NEES, training
	SDL_VIDEODRIVER=dummy $(PY) -m pytest -n 2 -q -m slow

test-rllib: setup-rllib  ## Ray RLlib (a 2-node local cluster), and the env contract on Ray's gymnasium
	SDL_VIDEODRIVER=dummy $(RPY) -m pytest -q -m rllib
	SDL_VIDEODRIVER=dummy $(RPY) -m pytest -n 2 -q -m "not slow" $(CONTRACT_TESTS)

lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/lint-imports

# The documentation site: every warning an error, every cross-reference checked (the
# docs extra is part of dev).
docs: setup  ## the documentation site, in docs/_build/html
	SDL_VIDEODRIVER=dummy $(VENV)/bin/sphinx-build -W --keep-going -n -b html docs docs/_build/html

bench: setup
	$(PY) -m benchmarks.bench_env
	$(PY) -m benchmarks.bench_filter
	$(PY) -m benchmarks.bench_consistency
	if command -v valgrind >/dev/null; then $(PY) -m benchmarks.bench_instructions; fi

clean:
	rm -rf $(VENV) $(RLLIB_VENV) $(CORE_VENV) $(OUT) docs/_build .pytest_cache .ruff_cache
