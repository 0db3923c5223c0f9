# taskspace: the two commands are `make demo` and `make test` (both create .venv).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)
PYTEST_WORKERS ?= 2
OUT ?= out

# The MotionBenchMaker problems are not shipped with taskspace: the project keeps them in
# shared/ beside the checkout (tests, benchmarks and examples read the variable).
MOTIONBENCHMAKER_BESIDE := $(abspath $(CURDIR)/../shared/benchmarks/motionbenchmaker_panda)
ifneq ($(wildcard $(MOTIONBENCHMAKER_BESIDE)),)
export TASKSPACE_MOTIONBENCHMAKER_DIR ?= $(MOTIONBENCHMAKER_BESIDE)
endif

.PHONY: native demo test lint typecheck pytest docs chromium bench bench-quick bench-peers clean apt-tools wheel-smoke

$(PY):
	$(PYTHON) -m venv $(VENV)

# uv installs the packages (the same versions as pip resolves, in a fraction of the time: it
# downloads in parallel and keeps a cache); pip only installs uv itself.
UV := $(VENV)/bin/uv
$(UV): | $(PY)
	$(PY) -m pip install --quiet uv
UV_PIP := $(UV) pip install --quiet --python $(PY)

# Debian packages that the build needs, installed with apt when missing.
APT_TOOLS := g++:g++ cmake:cmake
apt-tools:
	@missing=""; for pair in $(APT_TOOLS); do \
		command -v $${pair%%:*} >/dev/null 2>&1 || missing="$$missing $${pair#*:}"; done; \
	if [ -n "$$missing" ]; then \
		echo "installing$$missing (apt)"; \
		$(SUDO) apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq $$missing >/dev/null; fi

# taskspace and its compiled kernels (CMakeLists.txt, scikit-build-core): the build
# requirements first (the pin/coal/eigenpy wheels whose CMake configs the kernels use), then
# an editable install built against exactly those (--no-build-isolation: an isolated build
# could pick other wheel versions than the ones the kernels then run with). The build
# directory build/<tag> persists: a kernel whose source changed is recompiled alone when it
# is next imported (editable.rebuild), `make native` shows the result.
# NATIVE_ARCH=1 compiles for this processor (-march=native; never for a wheel).
NATIVE_ARCH ?= 0
SKBUILD_ARGS := $(if $(filter 1 ON on yes,$(NATIVE_ARCH)),-Ccmake.define.TASKSPACE_NATIVE_ARCH=ON,-Ccmake.define.TASKSPACE_NATIVE_ARCH=OFF)
BUILD_REQUIRES = $(shell $(PY) -c "exec('try: import tomllib\\nexcept ImportError: from pip._vendor import tomli as tomllib'); \
	print(' '.join(repr(r) for r in tomllib.load(open('pyproject.toml', 'rb'))['build-system']['requires']))")

# --compile-bytecode: the packages' .pyc files written once here, as pip does by default (uv
# does not). Without them, with PYTHONDONTWRITEBYTECODE=1 in the environment, every Python
# process of the tests (each xdist worker, each demo, CLI and docs-build subprocess, each Ray
# worker) compiled NumPy, SciPy, matplotlib, Ray... from source again: 20 s of collection in
# each worker instead of 5.
$(STAMP): pyproject.toml CMakeLists.txt cmake/build_info.json.in | $(UV)
	@$(MAKE) --no-print-directory apt-tools
	rm -f src/taskspace/_native/*.so src/taskspace/_native/.built  # modules of the old build.py
	$(UV_PIP) $(BUILD_REQUIRES)
	$(UV_PIP) --compile-bytecode --no-build-isolation $(SKBUILD_ARGS) -e ".[test,native]"
	touch $(STAMP)

# Rebuilds the kernels whose sources changed and shows whether they load.
native: $(STAMP)
	$(VENV)/bin/taskspace info

# Debian's Chromium renders the meshcat snapshots (never a downloaded browser).
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
		echo "installing chromium (apt)"; \
		$(SUDO) apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium >/dev/null; }

demo: $(STAMP) native chromium
	$(VENV)/bin/taskspace demo main --html $(OUT)/demo.html --png $(OUT)/demo.png

# The project's layering rules (DESIGN.md) live beside the checkout in shared/tools.
LAYERS_CHECK := $(wildcard ../shared/tools/check_layers.py)
lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(if $(LAYERS_CHECK),$(PY) $(LAYERS_CHECK),@echo "layering check skipped: ../shared/tools/check_layers.py not found")

typecheck: $(STAMP)
	$(VENV)/bin/mypy

# PYTHONDONTWRITEBYTECODE is cleared for the tests: the .pyc files of taskspace (src/) and of
# the tests (pytest's rewritten asserts) are written once into their __pycache__ folders
# (ignored by git) and read by the later processes instead of compiling the sources in each.
pytest: $(STAMP) native chromium
	PYTHONDONTWRITEBYTECODE= TASKSPACE_REQUIRE_NATIVE=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -n $(PYTEST_WORKERS) --dist loadgroup -q --durations=25

test: lint typecheck pytest wheel-smoke

# The installed package, not the checkout: a wheel (pip wheel, kernels compiled by CMake)
# installed into a fresh virtual environment, then from a directory outside the checkout
# `taskspace info` (the kernels must load), the README's quick example and a smoke subset of
# the tests. The wheel gets the same pin/coal/eigenpy/boost versions as .venv (constraints).
SMOKE_TESTS ?= tests/test_native_build_info.py tests/test_readme.py tests/ik/test_ik_native.py
wheel-smoke: $(STAMP)
	PYTHON=$(PYTHON) bash .ci/wheel_smoke.sh $(VENV) $(SMOKE_TESTS)

# The documentation site (Sphinx + sphinx-gallery; the gallery runs every example).
docs: $(STAMP) native chromium
	TASKSPACE_FAST=1 MPLBACKEND=Agg $(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

bench: $(STAMP) native
	$(PY) -m benchmarks.run --save benchmarks/results/latest.json

bench-quick: $(STAMP) native
	$(PY) -m benchmarks.run --quick

# Peer libraries, each in its own environment (they pin other Pinocchio versions).
bench-peers:
	bash benchmarks/peers/install.sh

clean:
	rm -rf $(VENV) .venv-peers out build .mypy_cache .ruff_cache .pytest_cache src/taskspace/_native/*.so src/taskspace/_native/.built \
		docs/_build docs/_generated
