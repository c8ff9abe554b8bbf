# Specula: `make render` sets up .venv and renders the default scene to out/;
# `make test` sets up if needed and runs the tests.
PYTHON ?= python3.11
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

# bpy LTS releases of the version-range smoke test (tests/install/test_extension.py).
BPY42 := 4.2.23
BPY45 := 4.5.15
# Blender 3.4's Python gets numpy + embreex from this user scripts folder (docs/INSTALL.md).
B34_USER := build/blender34

.PHONY: setup render test test-fast bench scenes scenes-3.4 dist compat clean

setup: $(STAMP)

$(STAMP): requirements.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -r requirements.txt
	touch $(STAMP)

scenes: $(STAMP)
	$(PY) blend_scenes/build_scenes.py

# Blender 3.4 builds of the scenes, which every supported version (3.4 - 5.0) opens.
scenes-3.4: $(STAMP)
	mkdir -p $(B34_USER)/scripts/modules $(B34_USER)/config
	$(PY) -m pip install --quiet --target $(B34_USER)/scripts/modules --only-binary=:all: \
		--upgrade numpy==1.26.4 embreex==4.4.0.post1 numba==0.68.1 llvmlite==0.50.0
	BLENDER_USER_SCRIPTS=$(B34_USER)/scripts BLENDER_USER_CONFIG=$(B34_USER)/config \
		blender -b --python blend_scenes/build_scenes.py -- --out blend_scenes/v3.4

# dist/specula-<v>-<platform>.zip (Blender 4.2+ extensions) and specula-<v>-legacy.zip.
dist: $(STAMP)
	$(PY) tools/build_extension.py

# bpy 4.2 LTS and 4.5 LTS in their own venvs, for the smoke test (about 1 min, 2 x ~1 GB).
# numpy pinned to the 1.26 line those Blender releases ship (bpy on PyPI would pull numpy 2.4).
compat: .venv-bpy42/.installed .venv-bpy45/.installed

.venv-bpy42/.installed:
	$(PYTHON) -m venv .venv-bpy42
	.venv-bpy42/bin/python -m pip install --quiet bpy==$(BPY42) numpy==1.26.4
	touch $@

.venv-bpy45/.installed:
	$(PYTHON) -m venv .venv-bpy45
	.venv-bpy45/bin/python -m pip install --quiet bpy==$(BPY45) numpy==1.26.4
	touch $@

render: $(STAMP)
	mkdir -p out
	$(PY) -m addon render blend_scenes/default.blend --samples 16 \
		--output out/default.exr --output out/default.png

# Two processes (pytest-xdist): a file's tests, and the Cycles and install folders, each
# stay in one (tests/conftest.py).
test: $(STAMP)
	$(PY) -m pytest -q -n 2 --durations=40 tests

test-fast: $(STAMP)
	$(PY) -m pytest -q -m "not slow" tests

# Performance (tests/benchmarks/README.md): the core (numpy and compiled kernels), scaling
# and time to first pixels, then error against run time beside Cycles at 10 s and 60 s on
# CBspheres, CBdragon and CBspheres with depth of field. Reports and plots in out/bench/.
bench: $(STAMP)
	$(PY) -m tests.benchmarks.bench_core
	$(PY) -m tests.benchmarks.bench_scaling
	$(PY) -m tests.benchmarks.bench_cycles --scenes $(SCENES) --budgets $(BUDGETS)

clean:
	rm -rf out dist build

# Specula against Cycles (tests/cycles, tests/benchmarks; see tests/cycles/README.md).
.PHONY: references test-cycles bench-cycles figures

# Render the Cycles references of tests/cycles/variants.py into tests/cycles/references/
# (only those whose Blender version or variant changed; FORCE=1 renders all).
references: $(STAMP)
	$(PY) -m tests.cycles.references $(if $(FORCE),--force)

test-cycles: $(STAMP)
	$(PY) -m pytest -q tests/cycles

# Error against run time, Specula beside Cycles: out/bench/report.md and plots.
# BUDGETS=1,2,4 SCENES=cbspheres for a quick run.
BUDGETS ?= 10,60
SCENES ?= cbspheres,cbdragon,cbspheres_dof
bench-cycles: $(STAMP)
	$(PY) -m tests.benchmarks.bench_cycles --scenes $(SCENES) --budgets $(BUDGETS)

# The course project's experiments side by side: out/figures/*.png and differences.md.
figures: $(STAMP)
	$(PY) -m tests.benchmarks.course_figures

# Randomised comparison with Cycles (tests/cycles/fuzz.py): N random scenes from seed SEED0,
# each disagreement confirmed at 4x samples and shrunk; out/fuzz/summary.md, seed_<n>.blend,
# .json and .png. AVOID_KNOWN=1 leaves out the features of the known differences.
.PHONY: fuzz
N ?= 20
SEED0 ?= 0
fuzz: $(STAMP)
	mkdir -p out/fuzz
	$(PY) -m tests.cycles.fuzz --seeds $(SEED0)-$(shell echo $$(($(SEED0) + $(N) - 1))) \
		$(if $(AVOID_KNOWN),--avoid-known) 2>&1 | tee out/fuzz/log.txt
