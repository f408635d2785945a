# Two commands on a fresh Debian 12 machine: `make demo` and `make test`.
# Each installs what is missing (Debian packages, a virtualenv, the build) and runs.
SHELL := /bin/bash
PYTHON ?= python3
VENV ?= .venv
PY := $(VENV)/bin/python
DEMO_OUTPUT ?= demo-output
# libpcl-dev brings PCL 1.13, Eigen, FLANN, qhull and VTK; the rest are small.
APT_PACKAGES := g++ make python3-dev python3-venv libpcl-dev libeigen3-dev libnanoflann-dev \
                libqhull-dev liblzf-dev clang-format
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
SOURCES := $(shell find cpp python -type f \( -name '*.cpp' -o -name '*.hpp' -o -name '*.py' -o -name '*.pyi' \)) \
           CMakeLists.txt pyproject.toml
# `make sanitize`: its own virtualenv and build folder (never the ones above).
SAN_VENV ?= .venv-sanitize
SAN_PY := $(SAN_VENV)/bin/python
SAN_BUILD ?= build/sanitize

.PHONY: demo test lint bench sanitize system-packages install clean

demo: $(VENV)/.installed
	$(PY) -m pcl_rg demo --output $(DEMO_OUTPUT)

test: lint
	$(PY) -m pytest -q

# ruff's rules and formatting (pyproject.toml) and clang-format (.clang-format), checked,
# not applied: `ruff format python tests benchmarks` applies the formatting.
CPP_FILES = $(shell find cpp -name '*.cpp' -o -name '*.hpp')
lint: $(VENV)/.installed
	$(PY) -m ruff check python tests benchmarks
	$(PY) -m ruff format --check python tests benchmarks
	clang-format --dry-run -Werror $(CPP_FILES)

# Long fuzzing for local runs: many more damaged files than `make test` runs, and
# hypothesis's random profile with 20x the examples of every property test.
# FUZZ_SEED picks the damaged files (`make fuzz FUZZ_SEED=$RANDOM` for new ones).
FUZZ_SEED ?= 20261130
.PHONY: fuzz
fuzz: $(VENV)/.installed
	PCL_RG_HYPOTHESIS_PROFILE=fuzz PCL_RG_FUZZ_CASES=5000 PCL_RG_FUZZ_CLI_CASES=300 \
	    PCL_RG_FUZZ_SEED=$(FUZZ_SEED) \
	    $(PY) -m pytest -q tests/test_fuzz_files.py $$(grep -l '@given' tests/test_*.py)

bench: $(VENV)/.installed
	$(PY) -m pip install -q '.[bench]' --no-build-isolation -Cbuild-dir=build/wheel
	$(PY) benchmarks/speed/filters.py

install: $(VENV)/.installed

# The whole test suite against the C++ extension built with AddressSanitizer and
# UndefinedBehaviorSanitizer (CMake option PCL_RG_SANITIZE). python is not
# instrumented, so the ASan runtime is preloaded (libubsan comes in with the modules), and
# libstdc++ with it: python does not link libstdc++, so otherwise ASan's __cxa_throw
# interceptor finds no real __cxa_throw and aborts on the first C++ exception (in
# matplotlib's ft2font). The subprocesses the tests start (python -m pcl_rg, pcl-rg,
# thread_probe.py) inherit the environment.
# - detect_leaks=0: CPython keeps module state and interned objects until exit by
#   design, thousands of reports that are not ours.
# - alloc_dealloc_mismatch stays on: the one it reported (PCL's progressive
#   morphological filter freeing its clouds through our exported C++17 copy of the
#   shared_ptr deleter) was ours, fixed by hidden visibility (CMakeLists.txt).
# - -s: pytest's fd capture would swallow the report of a process that aborts
#   (UBSan ignores log_path next to ASan; --capture=sys breaks faulthandler).
# - allocator_may_return_null: an absurd allocation fails as in a plain run (NumPy
#   raises MemoryError), not as an ASan abort: Dask reads an HTTP server's reply as a
#   3 EiB message length, and pcl-rg batch must report that address as no scheduler.
sanitize: $(SAN_VENV)/.installed
	LD_PRELOAD="$$(gcc -print-file-name=libasan.so) $$(gcc -print-file-name=libstdc++.so)" \
	ASAN_OPTIONS=detect_leaks=0:allocator_may_return_null=1 \
	UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
	    $(SAN_PY) -m pytest -q -s

# Debian packages, installed only when one is missing (sudo when not root).
$(VENV)/.system-packages $(SAN_VENV)/.system-packages:
	@missing=$$(for p in $(APT_PACKAGES); do dpkg-query -W -f='$${Status}\n' $$p 2>/dev/null \
	    | grep -q "install ok installed" || echo $$p; done); \
	if [ -n "$$missing" ]; then \
	    echo "installing Debian packages:" $$missing; \
	    $(SUDO) apt-get update -qq && \
	    DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing; \
	fi
	@mkdir -p $(@D) && touch $@

# The virtualenv with build tools (no build isolation, so rebuilds are incremental
# in build/wheel) and the package with its test and plot extras.
$(VENV)/.installed: $(VENV)/.system-packages $(SOURCES)
	[ -x $(PY) ] || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q "scikit-build-core>=0.10" "pybind11>=2.13" "cmake>=3.18" ninja
	$(PY) -m pip install -q --no-build-isolation -Cbuild-dir=build/wheel '.[test]'
	touch $@

# The same with the sanitizers on, RelWithDebInfo so pybind11 keeps the symbols.
$(SAN_VENV)/.installed: $(SAN_VENV)/.system-packages $(SOURCES)
	[ -x $(SAN_PY) ] || $(PYTHON) -m venv $(SAN_VENV)
	$(SAN_PY) -m pip install -q --upgrade pip
	$(SAN_PY) -m pip install -q "scikit-build-core>=0.10" "pybind11>=2.13" "cmake>=3.18" ninja
	$(SAN_PY) -m pip install -q --no-build-isolation -Cbuild-dir=$(SAN_BUILD) \
	    -Ccmake.build-type=RelWithDebInfo -Ccmake.define.PCL_RG_SANITIZE=ON '.[test]'
	touch $@

clean:
	rm -rf build $(VENV) $(SAN_VENV) $(DEMO_OUTPUT)
