# taskspace: the two commands are `make demo` and `make test` (both create .venv).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
SUDO := $(shell [ "$$(id -u)" -eq 0 ] || echo sudo)
PYTEST_WORKERS ?= 2
OUT ?= out

.PHONY: native demo test lint typecheck pytest docs chromium bench bench-quick bench-peers clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(PY)
	$(PY) -m pip install --quiet -e ".[test,native]"
	touch $(STAMP)

# The compiled kernels (C++ on the installed Pinocchio; about a minute). Without them
# taskspace runs its Python path; `make demo` and `make test` build them.
NATIVE := src/taskspace/_native/.built
$(NATIVE): $(STAMP) src/taskspace/_native/ik_kernel.cpp src/taskspace/_native/planning_kernel.cpp \
		src/taskspace/_native/build.py
	@command -v g++ >/dev/null 2>&1 || { \
		echo "installing g++ (apt)"; \
		$(SUDO) apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq g++ >/dev/null; }
	$(PY) -m taskspace._native.build
	touch $(NATIVE)

native: $(NATIVE)

# Debian's Chromium renders the meshcat snapshots (never a downloaded browser).
chromium:
	@command -v chromium >/dev/null 2>&1 || { \
		echo "installing chromium (apt)"; \
		$(SUDO) apt-get update -qq && \
		DEBIAN_FRONTEND=noninteractive $(SUDO) apt-get install -y -qq chromium >/dev/null; }

demo: $(STAMP) $(NATIVE) chromium
	$(VENV)/bin/taskspace demo main --html $(OUT)/demo.html --png $(OUT)/demo.png

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

typecheck: $(STAMP)
	$(VENV)/bin/mypy

pytest: $(STAMP) $(NATIVE) chromium
	TASKSPACE_REQUIRE_NATIVE=1 OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -n $(PYTEST_WORKERS) --dist loadgroup -q

test: lint typecheck pytest

# The documentation site (Sphinx + sphinx-gallery; the gallery runs every example). The
# whole-suite `make test` builds it too (tests/test_docs.py).
docs: $(STAMP) $(NATIVE) chromium
	TASKSPACE_FAST=1 MPLBACKEND=Agg $(PY) -m sphinx -W --keep-going -b html docs docs/_build/html

bench: $(STAMP) $(NATIVE)
	$(PY) -m benchmarks.run --save benchmarks/results/latest.json

bench-quick: $(STAMP) $(NATIVE)
	$(PY) -m benchmarks.run --quick

# Peer libraries, each in its own environment (they pin other Pinocchio versions).
bench-peers:
	bash benchmarks/peers/install.sh

clean:
	rm -rf $(VENV) .venv-peers out .mypy_cache .ruff_cache .pytest_cache src/taskspace/_native/*.so src/taskspace/_native/.built \
		docs/_build docs/_generated
