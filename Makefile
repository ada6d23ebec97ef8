# The two commands a newcomer needs are `make demo` and `make test`; each sets up .venv (and, for the tests, the
# Debian packages of Blender 3.4) itself.
PYTHON ?= python3.11
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Blender 3.4.1 and what its (the system's) Python needs for the add-on tests, and a virtual screen for the GUI test
SYSTEM_PACKAGES := blender python3-numpy python3-pytest xvfb

.PHONY: demo test test-slow test-blenders lint bench bench-adaptive bench-compare bench-peers bench-animation bench-stages bench-meshes bench-reliability bench-viewport bench-scenes bench-cluster corpus docs study addon system-deps blender-wheels clean

# Blender versions as bpy wheels besides 5.0.1 (tests/addon/wheels.txt): one virtual environment each
BPY_WHEELS := $(shell sed -e 's/\#.*//' tests/addon/wheels.txt)
BPY_STAMPS := $(foreach version,$(BPY_WHEELS),.venv-bpy-$(version)/.installed)

$(STAMP): pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "error: $(PYTHON) not found; install Python 3.11" >&2; exit 1; }
	@test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e '.[dev,blender,report,cluster,exr]'
	@touch $@

.venv-bpy-%/.installed: tests/addon/wheels.txt
	@test -x .venv-bpy-$*/bin/python || $(PYTHON) -m venv .venv-bpy-$*
	.venv-bpy-$*/bin/python -m pip install --quiet --upgrade pip
	.venv-bpy-$*/bin/python -m pip install --quiet "bpy==$*" "numpy<2" "pytest>=8"
	@touch $@

blender-wheels: $(BPY_STAMPS)

system-deps:
	@missing=""; \
	command -v blender >/dev/null || missing="$$missing blender"; \
	command -v xvfb-run >/dev/null || missing="$$missing xvfb"; \
	/usr/bin/python3 -c "import numpy" 2>/dev/null || missing="$$missing python3-numpy"; \
	/usr/bin/python3 -c "import pytest" 2>/dev/null || missing="$$missing python3-pytest"; \
	if [ -n "$$missing" ]; then \
		if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
			echo "installing$$missing with apt-get (Blender 3.4 for the add-on tests)"; \
			apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(SYSTEM_PACKAGES) >/dev/null; \
		else \
			echo "warning: cannot install$$missing (needs root and apt-get): the Blender 3.4 and GUI tests will be skipped" >&2; \
		fi; \
	fi

demo: $(STAMP)
	$(BIN)/python scripts/render_both.py --out out --width 640 --height 480

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

test: lint system-deps blender-wheels
	$(BIN)/python -m pytest -q

test-slow: $(STAMP)
	$(BIN)/python -m pytest -q -m slow

# the whole add-on suite in every Blender (`make test` runs it whole in 3.4.1 and 5.0.1, and the files that go
# through the version branches in 4.2, 4.4 and 4.5)
test-blenders: system-deps blender-wheels
	WEATHERVANE_FULL_SUITES=1 $(BIN)/python -m pytest -q tests/addon tests/test_blender.py::test_addon_suite_passes_inside_blender_34 \
		tests/test_blender.py::test_addon_suite_passes_in_the_bpy_wheel

bench: $(STAMP)
	$(BIN)/python scripts/bench_tracer.py

# adaptive sampling against uniform on the default frame: error against 256 samples and time (docs/adaptive-sampling)
bench-adaptive: $(STAMP)
	$(BIN)/python scripts/bench_adaptive.py --rounds 5

# same-run comparison of the working tree with a commit (REF=<commit>, default HEAD), alternating processes
REF ?= HEAD
bench-compare: $(STAMP)
	$(BIN)/python scripts/bench_compare.py --ref $(REF) --rounds 7

# the peer rt3.py on its own scene against the tracer (one process), alternating in the same run
bench-peers: $(STAMP)
	$(BIN)/python scripts/bench_compare.py --ref $(REF) --rounds 9 --cases peer64,peer32

# the 120-frame animation, whole and incremental, against a commit's in the same run (REF=<commit>)
bench-animation: $(STAMP)
	$(BIN)/python scripts/bench_animation_commits.py --ref $(REF) --rounds 3

# where the time goes: CPU ms per stage of the default frame, float64 and float32
bench-stages: $(STAMP)
	$(BIN)/python scripts/bench_stages.py --dtype float64
	$(BIN)/python scripts/bench_stages.py --dtype float32

# meshes against the default frame (one process, same rounds) and a million triangles' first frame and peak memory
bench-meshes: $(STAMP)
	$(BIN)/python scripts/bench_meshes.py --rounds 5 --frames 5

bench-reliability: $(STAMP)
	$(BIN)/python scripts/bench_reliability.py --repeats 3

bench-viewport: $(STAMP)
	$(BIN)/python scripts/bench_viewport.py --repeats 5
	$(BIN)/python scripts/bench_viewport.py --repeats 5 --width 1586 --height 926  # a full-HD window's 3D View

# scenes of real size (a Geometry Nodes forest of 1,000 to 100,000 instances, 3,000 cubes separate and merged): F12
# with the tracer engine (its default 1 sample) against Cycles CPU at 4 samples, in bpy; 320x240 over 3 repeats, 1280x720
# once; writes docs/scenes-benchmark-320x240.json and -1280x720.json, a chart each (.png)
bench-scenes: $(STAMP)
	$(BIN)/python scripts/bench_scenes.py --sizes 320x240 --repeats 3 --out docs/scenes-benchmark-320x240
	$(BIN)/python scripts/bench_scenes.py --sizes 1280x720 --repeats 1 --out docs/scenes-benchmark-1280x720

# .blend files nobody on the team wrote, beside Cycles (scripts/corpus.py): Blender's own templates and samples and
# every .blend file under the folders in CORPUS (e.g. CORPUS=path/to/glTF-Blender-IO/tests), in bpy 5.0.1 and, where
# installed, Debian's Blender 3.4.1; writes docs/corpus.md and docs/corpus-blender-3.4.md (and .json)
CORPUS ?=
CORPUS_DESCRIBE ?=
corpus: $(STAMP)
	$(BIN)/python scripts/corpus.py $(foreach folder,$(CORPUS),--folder $(folder)) --describe "$(CORPUS_DESCRIBE)" \
		--out docs/corpus
	command -v blender >/dev/null && $(BIN)/python scripts/corpus.py --blender "$$(command -v blender)" \
		$(foreach folder,$(CORPUS),--folder $(folder)) --describe "$(CORPUS_DESCRIBE)" --out docs/corpus-blender-3.4

bench-cluster: $(STAMP)
	$(BIN)/python scripts/bench_cluster.py --repeats 3

docs: $(STAMP)
	$(BIN)/python scripts/plot_step_response.py

study: $(STAMP)
	$(BIN)/python scripts/study.py --repeats 5

addon: $(STAMP)
	$(BIN)/python scripts/build_addon.py

clean:
	rm -rf $(VENV) .venv-bpy-* out dist
