# loomlab — common tasks. `make run` is the main job, `make test` runs every test
# (and installs what it needs on a fresh Debian machine with Rust).
SHELL := /bin/bash
CARGO ?= cargo
OUT ?= out/run
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# Mesa's Vulkan loader complains on every device creation when XDG_RUNTIME_DIR is unset (CI, containers).
export XDG_RUNTIME_DIR ?= $(shell d=/tmp/xdg-runtime-$$(id -u); mkdir -p -m 700 $$d && echo $$d)

.PHONY: run test deps lint rust-test python-test python-env suite-check sweep bless bench figures fmt

## Run the default scenario suite: prints the results table, writes $(OUT)/report.json and plots.
run: deps
	$(CARGO) run --release -- run --out $(OUT)

## Install system packages: Mesa's lavapipe (software Vulkan) so wgpu renders without a GPU.
deps:
	@if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then \
	  echo "installing mesa-vulkan-drivers (lavapipe) ..."; \
	  $(SUDO) apt-get update -qq && $(SUDO) DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1; \
	fi

## Formatting and lints (warnings are errors).
lint:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

## All Rust tests (unit, integration, doc).
rust-test: deps
	$(CARGO) test --workspace

## The Python package (python): a venv in $(VENV), maturin build into the workspace's target
## directory (reusing the dependencies rust-test compiled), pytest.
VENV ?= .venv
PYTHON ?= python3
python-env: deps
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV) || { \
	  echo "installing python3-venv ..."; rm -rf $(VENV); \
	  $(SUDO) apt-get update -qq && $(SUDO) DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv && \
	  $(PYTHON) -m venv $(VENV); }
	$(VENV)/bin/python -m pip install -q --upgrade pip maturin numpy gymnasium pytest "ray[tune]>=2.9"
	cd python && VIRTUAL_ENV=$(abspath $(VENV)) CARGO_TARGET_DIR=$${CARGO_TARGET_DIR:-$(CURDIR)/target} \
	  $(abspath $(VENV))/bin/maturin develop

## pytest, the sweep tests on a local Ray with 2 CPUs included (the RLlib training test needs torch,
## which is not installed here: `pip install 'loomlab[rllib]'` to run it).
python-test: python-env
	cd python && $(abspath $(VENV))/bin/python -m pytest -q

## A detector-parameter sweep on a local Ray: `make sweep SWEEP=sweeps/baselines_random.toml`.
SWEEP ?= sweeps/hopfield_threshold_alpha.toml
sweep: python-env
	$(VENV)/bin/python -m loomlab.sweep $(SWEEP)

## The default suite must not regress against its committed baseline report (exit 1 lists every
## regression; tolerances in scenarios/README.md).
BASELINE ?= scenarios/baseline/default-report.json
suite-check: deps
	$(CARGO) run -- run --out out/suite-check --baseline $(BASELINE) --brief --no-plots

## Re-run the default suite and make its report the new baseline (after an intended change).
bless: deps
	$(CARGO) run --release -- run --out $(OUT) --baseline $(BASELINE) --bless

## Everything CI runs.
test: deps lint rust-test suite-check python-test

## Criterion benchmarks (detector, baselines, simulator step).
bench: deps
	$(CARGO) bench --workspace

## Regenerate the paper's artificial-video figures into out/figures.
figures:
	$(CARGO) run --release -- figures --out out/figures

fmt:
	$(CARGO) fmt --all
