# Two commands do all the set-up on a fresh machine (Python 3.11+):
#   make run    creates .venv, installs the project, runs the main job
#   make test   creates .venv, installs the project, runs the test suite
VENV   ?= .venv
PYTHON ?= python3
PY     := $(VENV)/bin/python

$(VENV)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $@

.PHONY: run test test-slow bench
run: $(VENV)/.installed
	$(PY) -m experiments.demo --layout three-room --sequence 0

test: $(VENV)/.installed
	$(PY) -m pytest

test-slow: $(VENV)/.installed
	$(PY) -m pytest -m slow

bench: $(VENV)/.installed
	$(PY) -m planning.domain.bench --layout three-room --out results/bench-three-room.json
