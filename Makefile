# xface: every target sets itself up. On a machine with only Python >= 3.11 (3.11 for the ROS
# wheels), `make test` and `make demo` create .venv/ in this directory and install the project
# into it; later runs skip the install until pyproject.toml changes.
#
#   make demo        the ROS node on its default configuration fed by a bundled pose source
#   make test        ruff, ruff format --check, mypy --strict xface_core xface_ros, pytest (+ doctests)
#   make help        every target

SHELL := /bin/bash
.SHELLFLAGS := -eu -o pipefail -c
.DEFAULT_GOAL := help
.DELETE_ON_ERROR:

# Prefer python3.11: the ROS 2 Jazzy wheels on PyPI are built for it.
PYTHON ?= $(shell command -v python3.11 || command -v python3)
VENV ?= .venv
BIN := $(VENV)/bin
# Which extras `make` installs; EXTRAS=test skips the ROS wheels (tests/ros is then skipped).
EXTRAS ?= ros,test
STAMP := $(VENV)/.xface-installed
# Extra pytest arguments, e.g. make test PYTEST_ARGS='-m "not slow"' or PYTEST_ARGS=tests/core
PYTEST_ARGS ?=
# If set, the pytest recipe writes pytest's exit code there (.ci/run reads it).
PYTEST_EXIT_CODE_FILE ?=

# --- ROS isolation: every recipe, and every process it starts, stays on loopback -----------
# Discovery only on this host, no static peers, and a DDS domain of this run's own
# (1..99 from the PID, unless the caller chose one) so parallel runs do not see each other.
# The pytest fixture `ros_domain_id` hands single tests ids in 100..199.
export ROS_AUTOMATIC_DISCOVERY_RANGE := LOCALHOST
export ROS_STATIC_PEERS :=
ifndef ROS_DOMAIN_ID
ROS_DOMAIN_ID := $(shell echo $$(( $$$$ % 99 + 1 )))
endif
export ROS_DOMAIN_ID
# With the ROS extra installed, a missing rclpy is an error rather than skipped ROS tests.
export XFACE_REQUIRE_ROS ?= $(if $(findstring ros,$(EXTRAS)),1,0)

.PHONY: help setup msgs precompile test lint format-check typecheck pytest demo bench format clean distclean

help: ## list the targets
	@grep -E '^[a-z-]+:.*## ' $(MAKEFILE_LIST) | awk -F':.*## ' '{printf "  make %-13s %s\n", $$1, $$2}'

# --- set-up ---------------------------------------------------------------------------------
$(BIN)/python:
	@$(PYTHON) -c 'import sys; sys.exit(None if sys.version_info >= (3, 11) else "xface needs Python >= 3.11; $(PYTHON) is " + sys.version.split()[0])'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --progress-bar off --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	XFACE_PRECOMPILE=require $(BIN)/python -m pip install --progress-bar off --editable '.[$(EXTRAS)]'
	@touch $@

# With the ROS extra, the typed interfaces xface_msgs are built from the ROS wheels' rosidl
# generators and a C compiler into .venv (scripts/build_msgs.py; about 15 s the first time, under
# a second when nothing changed: it keeps a fingerprint of its sources).
MSGS_STAMP := $(VENV)/.xface-msgs
MSGS := $(if $(findstring ros,$(EXTRAS)),$(MSGS_STAMP),)
MSGS_SOURCES := $(wildcard xface_ros/xface_msgs/package.xml xface_ros/xface_msgs/msg/*.msg xface_ros/xface_msgs/srv/*.srv)

$(MSGS_STAMP): $(STAMP) scripts/build_msgs.py $(MSGS_SOURCES)
	$(BIN)/python scripts/build_msgs.py --prefix $(VENV) --build-dir build/xface_msgs
	@touch $@

msgs: $(MSGS_STAMP) ## build the ROS interfaces xface_msgs into .venv (with the ros extra)

setup: $(STAMP) $(MSGS) ## create .venv/ and install xface with the extras in EXTRAS (default ros,test)

# The install precompiles the engine (setup.py); after a change to xface_core/_engine the
# build no longer matches and the engine compiles on first use until this runs again.
precompile: $(STAMP) ## rebuild the precompiled engine in xface_core/_engine/_compiled
	$(BIN)/python -m xface_core.precompile xface_core/_engine/_compiled

# --- the test command: quality gates, then the tests ----------------------------------------
test: lint format-check typecheck pytest ## all gates and all tests (what CI runs)

lint: $(STAMP) ## ruff check
	$(BIN)/ruff check .

format-check: $(STAMP) ## ruff format --check
	$(BIN)/ruff format --check .

typecheck: $(STAMP) ## mypy --strict on xface_core and xface_ros
	$(BIN)/mypy --strict xface_core xface_ros

pytest: $(STAMP) $(MSGS) ## pytest: tests/ and the doctests of xface_core (PYTEST_ARGS=...)
	@echo "pytest with ROS_DOMAIN_ID=$(ROS_DOMAIN_ID) ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST"
	@rc=0; $(BIN)/python -m pytest $(PYTEST_ARGS) || rc=$$?; \
	if [ -n "$(PYTEST_EXIT_CODE_FILE)" ]; then echo "$$rc" > "$(PYTEST_EXIT_CODE_FILE)"; fi; \
	if [ "$$rc" -eq 5 ]; then echo "make: pytest collected no tests (exit code 5): failing" >&2; fi; \
	exit $$rc

# --- running xface --------------------------------------------------------------------------
demo: $(STAMP) $(MSGS) ## the node on its default config + a bundled pose source (Ctrl-C stops it)
	@echo "demo on ROS_DOMAIN_ID=$(ROS_DOMAIN_ID), discovery limited to this host"
	$(BIN)/python -m xface_ros.demo

bench: $(STAMP) ## the simulator benchmarks (xface bench)
	$(BIN)/xface bench

format: $(STAMP) ## fix what ruff can fix and format the code in place
	$(BIN)/ruff check --fix .
	$(BIN)/ruff format .

# --- cleaning -------------------------------------------------------------------------------
clean: ## remove caches and build output (keeps .venv/)
	rm -rf build dist *.egg-info .pytest_cache .mypy_cache .ruff_cache .hypothesis .benchmarks
	find . -path ./$(VENV) -prune -o -name __pycache__ -type d -prune -exec rm -rf {} +

distclean: clean ## also remove .venv/ and the precompiled engine
	rm -rf $(VENV) xface_core/_engine/_compiled
