# One-command set-up: every target builds its own virtual environment first.
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
OUT ?= out

.PHONY: setup demo test test-slow lint bench clean

setup: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	# The CPU wheel: an unpinned torch pulls several GB of CUDA packages.
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

demo: setup  ## the main job: an exploration episode on the default world, metrics and pictures
	SDL_VIDEODRIVER=dummy $(VENV)/bin/slam-env demo --out $(OUT)

test: setup  ## the default test suite (what CI runs)
	SDL_VIDEODRIVER=dummy $(PY) -m pytest -n 2 -q -m "not slow"

test-slow: setup  ## long runs: soak, long NEES, training
	SDL_VIDEODRIVER=dummy $(PY) -m pytest -n 2 -q -m slow

lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

bench: setup
	$(PY) benchmarks/bench_env.py
	$(PY) benchmarks/bench_filter.py
	$(PY) benchmarks/bench_consistency.py
	if command -v valgrind >/dev/null; then $(PY) benchmarks/bench_instructions.py; fi

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache
