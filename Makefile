# rotor_avc -- `make demo` runs the main job, `make test` the whole test suite, each on a fresh
# machine: both create the virtual environment and install from PyPI first (demo: the package
# and ROS 2; test: also the test tool chain).
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
OUT ?= out/demo

# ROS traffic never leaves loopback; a private domain for this checkout's runs.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export ROS_DOMAIN_ID ?= 57
export MPLBACKEND ?= Agg
# small dense matrices: threaded BLAS only adds contention (5-30x slower on 2 cores)
export OPENBLAS_NUM_THREADS ?= 1

.PHONY: setup setup-test demo test test-full bench mutation clean

setup: $(VENV)/.installed

$(VENV)/.installed: setup.py requirements-ros.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip "setuptools>=70.1" wheel
	$(PY) -m pip install --quiet -r requirements-ros.txt
	$(PY) -m pip install --quiet -e .
	touch $@

# the test tool chain (pytest, colcon, dask, rosbags, python-control, ...) on top
setup-test: $(VENV)/.installed-test

$(VENV)/.installed-test: $(VENV)/.installed setup.py
	$(PY) -m pip install --quiet -e ".[test]"
	touch $@

demo: setup
	$(VENV)/bin/rotor-avc demo --out $(OUT)

test: setup-test
	$(PY) -m pytest -q

test-full: setup-test
	$(PY) -m pytest -q --full

# the benchmarks; their headline figures go into README.md's Performance section
bench: setup-test
	$(PY) bench/run_all.py --readme

# mutation check of the modules in tools/mutation_targets.toml (slow; not part of `make test`)
MUTATION_JOBS ?= 2
MUTATION_MAX ?= 40
mutation: setup-test
	$(PY) tools/mutation.py --jobs $(MUTATION_JOBS) --max $(MUTATION_MAX) --out out/mutation

clean:
	rm -rf $(VENV) out build install log .pytest_cache
