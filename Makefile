# Two commands do all the set-up on a fresh machine (Python 3.11+):
#   make run    creates .venv, installs the project, runs the main job
#   make test   creates .venv, installs the project, runs the test suite
# EXTRAS: the optional extras installed with the project (CI: dev,rl,ray; see pyproject.toml).
VENV   ?= .venv
PYTHON ?= python3
PY     := $(VENV)/bin/python
EXTRAS ?= dev
comma  := ,
STAMP  := $(VENV)/.installed-$(subst $(comma),+,$(EXTRAS))

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e '.[$(EXTRAS)]'
	touch $@

.PHONY: run test test-slow smoke bench lint
run: $(STAMP)
	$(PY) -m experiments.demo --layout three-room --sequence 0

# The suite on every core (pytest-xdist; a file's tests stay on one worker, so its module fixtures are built once).
test: $(STAMP)
	$(PY) -m pytest -n auto --dist loadfile

test-slow: $(STAMP)
	$(PY) -m pytest -m slow

# The README's command lines on every core, each worker in its own fresh copy of the checkout (a module fixture).
smoke: $(STAMP)
	$(PY) -m pytest -m smoke -n auto --dist load tests/smoke

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

bench: $(STAMP)
	$(PY) -m planning.external.simulator_bench --layout three-room --out results/bench-three-room.json
