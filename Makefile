# Two commands on a fresh Debian 12 machine: `make demo` and `make test`.
# Each installs what is missing (Debian packages, a virtualenv, the build) and runs.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
DEMO_OUTPUT ?= demo-output
# libpcl-dev brings PCL 1.13, Eigen, FLANN, qhull and VTK; the rest are small.
APT_PACKAGES := g++ make python3-dev python3-venv libpcl-dev libeigen3-dev libnanoflann-dev \
                libqhull-dev liblzf-dev
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
SOURCES := $(shell find cpp python -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.py' -o -name '*.pyi' \)) \
           CMakeLists.txt pyproject.toml

.PHONY: demo test bench system-packages install clean

demo: $(VENV)/.installed
	$(PY) -m pcl_rg demo --output $(DEMO_OUTPUT)

test: $(VENV)/.installed
	$(PY) -m pytest -q

bench: $(VENV)/.installed
	$(PY) -m pip install -q '.[bench]' --no-build-isolation -Cbuild-dir=build/wheel
	$(PY) benchmarks/bench_filters.py

install: $(VENV)/.installed

# Debian packages, installed only when one is missing (sudo when not root).
$(VENV)/.system-packages:
	@missing=$$(for p in $(APT_PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null \
	    | grep -q "install ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	    echo "installing Debian packages:" $$missing; \
	    $(SUDO) apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi
	@mkdir -p $(VENV) && touch $@

# The virtualenv with build tools (no build isolation, so rebuilds are incremental
# in build/wheel) and the package with its test and plot extras.
$(VENV)/.installed: $(VENV)/.system-packages $(SOURCES)
	[ -x $(PY) ] || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "scikit-build-core>=0.10" "pybind11>=2.13" "cmake>=3.18" ninja
	$(PY) -m pip install -q --no-build-isolation -Cbuild-dir=build/wheel '.[test]'
	touch $@

clean:
	rm -rf build $(VENV) $(DEMO_OUTPUT)
