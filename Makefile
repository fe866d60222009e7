# Nutty — one Makefile for a fresh Debian machine (Python 3.11, Node 20, root).
#   make run   install everything, build the editor, serve the default robot and program
#   make test  install everything, lint, and run every test (Python, front-end unit, browser end-to-end)
#   make test-fast  the inner loop: Python tests without a browser, Blender or spawned servers (< 90 s)
#   make lint  ruff (lint + format check), basedpyright on backend/, the editor's eslint + tsc --noEmit
#   make bench engine and NMF benchmarks; make bench-long adds three 60 s windows served at 500 Hz;
#              make soak: a served robot under churning clients (optional)
#   make blender-addon  the Blender add-on as an installable extension: dist/nutty_blender-<version>.zip
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
PIP := $(VENV)/bin/pip
FRONTEND := frontend
# pytest-xdist workers: one per core (CI's machine has two). `--dist loadfile` keeps each test module on
# one worker: the browser modules are stories whose tests build on each other's state (one server and
# one page per module), which split over two workers started twice and broke when split.
JOBS ?= $(shell nproc 2>/dev/null || echo 2)
# ROS 2 (the --ros2 tests, bench_ros2) discovers on this machine only; each test adds its own domain id.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST

.PHONY: run test test-fast lint deps deps-python deps-system deps-frontend frontend-build test-python test-frontend bench bench-long \
	soak figures blender-addon clean

run: deps frontend-build
	$(VENV)/bin/nutty serve

test: deps frontend-build
	$(MAKE) lint
	$(MAKE) test-python
	$(MAKE) test-frontend

# No browser, no Blender, no spawned servers: what a change to the engine, graph or API needs first.
test-fast: deps-python
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile -m "not browser and not blender and not server"

lint: deps-python deps-frontend
	$(VENV)/bin/ruff check backend tests benchmarks blender
	$(VENV)/bin/ruff format --check backend tests benchmarks blender
	$(VENV)/bin/basedpyright
	cd $(FRONTEND) && npm run --silent lint

deps: deps-system deps-python deps-frontend

# Chromium drives the browser tests and screenshots (no browser download is possible here).
deps-system:
	@if [ ! -x /usr/bin/chromium ]; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium chromium-driver; \
	  else echo "warning: /usr/bin/chromium missing and not root; browser tests will be skipped"; fi; \
	fi
	@# A C/C++ compiler builds tf2_msgs, which the ROS 2 wheels lack (backend/ros2/interfaces.py).
	@if ! command -v gcc >/dev/null || ! command -v g++ >/dev/null; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q build-essential; \
	  else echo "warning: gcc/g++ missing and not root; tf2_msgs (ROS 2 /tf) cannot be built"; fi; \
	fi
	@if ! $(PYTHON) -c "import os, sysconfig; raise SystemExit(not os.path.exists(os.path.join(sysconfig.get_paths()['include'], 'Python.h')))"; then \
	  if [ "$$(id -u)" = "0" ]; then \
	    apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q python3-dev; \
	  else echo "warning: Python.h missing and not root; tf2_msgs (ROS 2 /tf) cannot be built"; fi; \
	fi

$(VENV)/bin/activate:
	$(PYTHON) -m venv $(VENV)
	$(PIP) install -q --upgrade pip

deps-python: $(VENV)/bin/activate
	$(PIP) install -q -e ".[test,bench,robots,ros2,mcap,foxglove,hardware,sim]"
	@# tf2_msgs (ROS 2 /tf) has no wheel: generate and compile it into the venv (~3 s, once).
	@$(PY) -c "import tf2_msgs.msg" 2>/dev/null || $(PY) -m backend.ros2.interfaces build
	@# Blender as a module (tests that make glTF files with real Blender). bpy 5.0 pins numpy<2 in its
	@# metadata but runs with numpy 2, so it is installed without its pins (its other needs are listed).
	@$(PY) -c "import bpy" 2>/dev/null || $(PIP) install -q --no-deps "bpy==5.0.*" cython requests zstandard
	@# The compiled core's kernel and the engine's frame tail into numba's cache (~15 s once; then every
	@# engine loads them in 0.4 s instead of each compiling them on its first start, as parallel test
	@# servers would).
	@$(PY) -c "from backend.engine.core.program import KERNEL; from backend.engine.frame_tail import TAIL; \
	  raise SystemExit(not (KERNEL.wait() and TAIL.wait()))"

deps-frontend:
	@if [ -f $(FRONTEND)/package.json ]; then cd $(FRONTEND) && npm ci --no-audit --no-fund --loglevel=error; fi

frontend-build:
	@if [ -f $(FRONTEND)/package.json ]; then cd $(FRONTEND) && npm run build --silent; fi

test-python:
	$(PY) -m pytest -q -n $(JOBS) --dist loadfile

test-frontend:
	@if [ -f $(FRONTEND)/package.json ]; then cd $(FRONTEND) && npm test --silent; fi

# Each benchmark prints its figures and writes them, with the date and machine, as its section of
# benchmarks/RESULTS.md (benchmarks/results.py), so a full run regenerates the whole file.
bench: deps-python
	$(PY) benchmarks/bench_engine.py
	$(PY) benchmarks/bench_nmf.py
	$(PY) benchmarks/bench_safety.py
	$(PY) benchmarks/bench_clock.py
	$(PY) benchmarks/bench_fleet.py
	$(PY) benchmarks/bench_design.py
	$(PY) benchmarks/bench_previews.py
	$(PY) benchmarks/bench_ros2.py
	$(PY) benchmarks/bench_hardware.py
	$(PY) benchmarks/bench_sim.py

# The served steadiness target: bench_engine's runs plus `nutty serve` at 500 Hz for 60 s.
bench-long: deps-python
	$(PY) benchmarks/bench_engine.py --long

# Optional, not part of bench: `nutty serve` at 100 Hz under churning clients, then a SIGTERM.
SOAK_MINUTES ?= 1
soak: deps-python
	$(PY) benchmarks/soak.py --minutes $(SOAK_MINUTES)

figures: deps-python
	$(VENV)/bin/nutty figures docs/figures

# Standard library only: needs no virtualenv and no Blender (docs/blender.md installs the zip).
DIST ?= dist
blender-addon:
	$(PYTHON) blender/build_addon.py $(DIST)

clean:
	rm -rf $(VENV) $(FRONTEND)/node_modules $(FRONTEND)/dist dist .numba-cache
