# Specula: `make render` sets up .venv and renders the default scene to out/;
# `make test` sets up if needed and runs the tests.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: setup render test test-fast bench scenes clean

setup: $(STAMP)

$(STAMP): requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $(STAMP)

scenes: $(STAMP)
	$(PY) blend_scenes/build_scenes.py

render: $(STAMP)
	mkdir -p out
	$(PY) -m addon render blend_scenes/default.blend --samples 16 \
		--output out/default.exr --output out/default.png

test: $(STAMP)
	$(PY) -m pytest -q tests

test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow" tests

bench: $(STAMP)
	$(PY) -m tests.benchmarks.bench_core

clean:
	rm -rf out dist
