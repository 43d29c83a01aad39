# loomlab — common tasks. `make run` is the main job, `make test` runs every test
# (and installs what it needs on a fresh Debian machine with Rust).
SHELL := /bin/bash
CARGO ?= cargo
OUT ?= out/run
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
# Mesa's Vulkan loader complains on every device creation when XDG_RUNTIME_DIR is unset (CI, containers).
export XDG_RUNTIME_DIR ?= $(shell d=/tmp/xdg-runtime-$$(id -u); mkdir -p -m 700 $$d && echo $$d)

.PHONY: run test deps lint lint-rust lint-python rust-test python-test python-env python-examples suite-check sweep bless bench figures fmt rl-env rl-train rl-table rl-result

## Run the default scenario suite: prints the results table, writes $(OUT)/report.json, the plots
## and $(OUT)/report.html (the page to open in a browser).
## A previous run in $(OUT) is kept: moved to $(OUT)-<time of its last episode> first (`loomlab run`
## itself refuses to write over a run; `loomlab run --resume` continues an interrupted one).
run: deps
	@if [ -e $(OUT)/manifest.json ] || [ -e $(OUT)/episodes.csv ]; then 	  old=$(OUT)-$$(date -r $(OUT)/episodes.csv +%Y%m%d-%H%M%S 2>/dev/null || date +%Y%m%d-%H%M%S); 	  while [ -e $$old ]; do old=$$old-1; done; 	  mv $(OUT) $$old && echo "make run: the previous run in $(OUT) is now in $$old"; 	fi
	$(CARGO) run --release -- run --out $(OUT)

## Install system packages: Mesa's lavapipe (software Vulkan) so wgpu renders without a GPU, and
## Chromium, in which tests/report_html.rs opens report.html headless.
deps:
	@if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then \
	  echo "installing mesa-vulkan-drivers (lavapipe) ..."; \
	  $(SUDO) apt-get update -qq && $(SUDO) DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers libvulkan1; \
	fi
	@if ! command -v chromium >/dev/null 2>&1; then \
	  echo "installing chromium (headless browser for the report.html test) ..."; \
	  $(SUDO) apt-get update -qq && $(SUDO) DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; \
	fi

## Formatting and lints (warnings are errors): the root workspace, and the Python side (the pyo3
## crate in python/, its own workspace, ruff, and the stubs checked against the built module).
lint: lint-rust lint-python

lint-rust:
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --workspace --no-deps --lib

# pyo3's build script needs an interpreter: the venv's (so clippy reuses maturin's build of pyo3).
PY_CARGO_ENV = PYO3_PYTHON=$(abspath $(VENV))/bin/python CARGO_TARGET_DIR=$${CARGO_TARGET_DIR:-$(CURDIR)/target}
lint-python: python-env
	cd python && $(CARGO) fmt -- --check
	cd python && $(PY_CARGO_ENV) $(CARGO) clippy --all-targets -- -D warnings
	$(VENV)/bin/ruff check python
	$(VENV)/bin/ruff format --check python
	cd python && $(abspath $(VENV))/bin/python -m mypy.stubtest loomlab._native --allowlist stubtest-allowlist.txt

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
	$(VENV)/bin/python -m pip install -q --upgrade pip maturin numpy gymnasium pytest "ray[tune]>=2.9" ruff mypy
	cd python && VIRTUAL_ENV=$(abspath $(VENV)) CARGO_TARGET_DIR=$${CARGO_TARGET_DIR:-$(CURDIR)/target} \
	  $(abspath $(VENV))/bin/maturin develop

## pytest, the sweep tests on a local Ray with 2 CPUs included (the RLlib training test needs torch,
## which is not installed here: `pip install 'loomlab[rllib]'` to run it), then every example in
## python/examples for a few steps. The sweep tests run the `loomlab` binary: built here first.
python-test: python-env
	$(CARGO) build --bin loomlab
	cd python && LOOMLAB_BIN=$${CARGO_TARGET_DIR:-$(CURDIR)/target}/debug/loomlab $(abspath $(VENV))/bin/python -m pytest -q
	$(MAKE) --no-print-directory python-examples

## Smoke-run every example for a few steps (`--smoke`); those whose optional dependency (torch,
## stable-baselines3, RLlib) is missing say so and exit 0 after importing everything else.
python-examples: python-env
	cd python/examples && for ex in *.py; do \
	  case $$ex in _*) continue;; esac; \
	  echo "== $$ex --smoke"; $(abspath $(VENV))/bin/python $$ex --smoke || exit 1; \
	done

## A detector-parameter sweep on a local Ray: `make sweep SWEEP=sweeps/baselines_random.toml`.
SWEEP ?= sweeps/hopfield_threshold_alpha.toml
sweep: python-env
	$(VENV)/bin/python -m loomlab.sweep $(SWEEP)

## The default suite must not regress against its committed baseline report (exit 1 lists every
## regression; tolerances in scenarios/README.md).
BASELINE ?= scenarios/baseline/default-report.json
suite-check: deps
	$(CARGO) run -- run --out out/suite-check --overwrite --baseline $(BASELINE) --brief --no-plots --no-html

## Re-run the default suite and make its report the new baseline (after an intended change).
bless: deps
	$(CARGO) run --release -- run --out out/bless --overwrite --baseline $(BASELINE) --bless

## Everything CI runs.
test: deps lint rust-test suite-check python-test

## RL on the detector signals (issue 17; README "Training a policy"). `make rl-result` trains PPO
## (stable-baselines3, CPU torch) on loomlab/EscapeDiscrete-v0 with normalized observations for at
## most RL_WALL_S seconds, evaluates it on held-out seeds next to the calibrated threshold
## controllers and the reference rows, and draws docs/rl_learning_curve.png. Torch lives in its own
## venv ($(RL_VENV)), never in `make test`'s. A finished run folder is never overwritten: remove
## $(RL_OUT) (or set RL_OUT) to start again; `make rl-train` after an interruption resumes it.
RL_VENV ?= .venv-rl
RL_SEED ?= 0
RL_WALL_S ?= 1620
RL_OUT ?= out/rl
RL_RUN = $(RL_OUT)/discrete-ppo-seed$(RL_SEED)
RL_EVAL_SEEDS ?= 2000-2024
RL_CALIBRATE_SEEDS ?= 7-14
rl-env: deps
	@test -x $(RL_VENV)/bin/python || $(PYTHON) -m venv $(RL_VENV)
	$(RL_VENV)/bin/python -m pip install -q --upgrade pip maturin
	cd python && VIRTUAL_ENV=$(abspath $(RL_VENV)) CARGO_TARGET_DIR=$${CARGO_TARGET_DIR:-$(CURDIR)/target} \
	  $(abspath $(RL_VENV))/bin/maturin develop --release --extras rl

rl-train: rl-env
	$(RL_VENV)/bin/python -m loomlab.train --env discrete --seed $(RL_SEED) --timesteps 2000000 \
	  --max-wall-s $(RL_WALL_S) --out $(RL_RUN) $$(test -e $(RL_RUN)/checkpoints/latest.json && echo --resume)

rl-table: rl-env
	$(RL_VENV)/bin/python -m loomlab.evaluation "$$($(RL_VENV)/bin/python -c 'import json,sys; print(json.load(open(sys.argv[1]))["path"])' $(RL_RUN)/checkpoints/latest.json)" \
	  --seeds $(RL_EVAL_SEEDS) --calibrate-seeds $(RL_CALIBRATE_SEEDS) --label ppo \
	  --out $(RL_OUT)/report.json --table $(RL_OUT)/table.md
	$(RL_VENV)/bin/python -m loomlab.train --plot $(RL_RUN) --plot-report $(RL_OUT)/report.json --plot-out docs/rl_learning_curve.png

rl-result: rl-train rl-table

## Criterion benchmarks (detector, baselines, simulator step).
bench: deps
	$(CARGO) bench --workspace

## Regenerate the paper's artificial-video figures into out/figures.
figures:
	$(CARGO) run --release -- figures --out out/figures

fmt:
	$(CARGO) fmt --all
