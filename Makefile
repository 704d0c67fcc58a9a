# rotor_avc -- `make demo` runs the main job, `make test` the whole test suite, each on a fresh
# machine: both create the virtual environment and install everything from PyPI first.
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

.PHONY: setup demo test test-full bench clean

setup: $(VENV)/.installed

$(VENV)/.installed: setup.py requirements-ros.txt
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip "setuptools>=70.1" wheel
	$(PY) -m pip install --quiet -r requirements-ros.txt
	$(PY) -m pip install --quiet -e ".[test]"
	touch $@

demo: setup
	$(VENV)/bin/rotor-avc demo --out $(OUT)

test: setup
	$(PY) -m pytest -q

test-full: setup
	$(PY) -m pytest -q --full

bench: setup
	$(PY) bench/run_all.py

clean:
	rm -rf $(VENV) out build install log .pytest_cache
