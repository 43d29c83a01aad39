# loomlab — common tasks. `make run` is the main job, `make test` runs every test
# (and installs what it needs on a fresh Debian machine with Rust).
SHELL := /bin/bash
CARGO ?= cargo
OUT ?= out/run
SUDO := $(shell [ "$$(id -u)" = 0 ] || echo sudo)
VENV ?= .venv
PYTHON ?= python3
# Mesa's Vulkan loader complains on every device creation when XDG_RUNTIME_DIR is unset (CI, containers).
export XDG_RUNTIME_DIR ?= $(shell d=/tmp/xdg-runtime-$$(id -u); mkdir -p -m 700 $$d && echo $$d)

.PHONY: run cli dev test deps lint lint-rust lint-python rust-build rust-test check-features python-test python-interpreter python-venv python-env python-examples suite-check sweep bless readme-table heldout heldout-bless events events-bless bench bench-python bench-events bench-peer figures fmt rl-env rl-train rl-train-detectors rl-train-privileged rl-table rl-table-docs rl-result

# One build for everything that runs code: `make run`, the tests, the suite check, the Python
# binding and the sweep tests all use the release profile of one workspace (one Cargo.lock, the
# pyo3 crate a member, the same dependency features everywhere: check-features), so a fresh machine
# compiles the dependency graph once, plus one `check` pass shared by clippy and rustdoc. Before,
# CI compiled it three times (a dev build for the tests and the suite check, the binding's own
# workspace, and that workspace's clippy pass) and took 31-37 minutes; docs/contributing.md has the
# measured time per step.
PROFILE ?= release
CARGO_PROFILE = --profile $(PROFILE)
TARGET_DIR = $${CARGO_TARGET_DIR:-$(CURDIR)/target}
BIN = $(TARGET_DIR)/$(PROFILE)/loomlab

# Test harnesses compiled without optimisation (except the detector's): .ci/rustc-wrapper.
export RUSTC_WORKSPACE_WRAPPER ?= $(CURDIR)/.ci/rustc-wrapper

# PREBUILT=1 (set by `make test` after its build step): the test and check targets below leave out
# their build prerequisites (cli, python-env) and run what was built. Then none of them calls
# cargo except clippy, rustdoc and the doc tests, so they can all run at once: cargo holds a build
# lock for the whole command, and clippy holds it for minutes.
BUILT = $(if $(PREBUILT),,$(1))

# pyo3's build configuration, the same in every cargo call as in maturin's build of the binding
# (which sets these itself): any difference makes cargo compile pyo3, numpy and the binding again,
# ~30 s each time (CI did so three times). The interpreter is the venv's (`python-interpreter`).
VENV_PYTHON = $(abspath $(VENV))/bin/python
export PYO3_PYTHON := $(VENV_PYTHON)
export PYO3_BUILD_EXTENSION_MODULE := 1
export PYO3_ENVIRONMENT_SIGNATURE := $(shell $(PYTHON) -c 'import platform, sys; print(f"{platform.python_implementation().lower()}-{sys.version_info[0]}.{sys.version_info[1]}-{64 if sys.maxsize > 2**32 else 32}bit")' 2>/dev/null)

## Run the default scenario suite: prints the results table, writes $(OUT)/report.json, the plots
## and $(OUT)/report.html (the page to open in a browser).
## A previous run in $(OUT) is kept: moved to $(OUT)-<time of its last episode> first (`loomlab run`
## itself refuses to write over a run; `loomlab run --resume` continues an interrupted one).
run: deps cli
	@if [ -e $(OUT)/manifest.json ] || [ -e $(OUT)/episodes.csv ]; then \
	  old=$(OUT)-$$(date -r $(OUT)/episodes.csv +%Y%m%d-%H%M%S 2>/dev/null || date +%Y%m%d-%H%M%S); \
	  while [ -e $$old ]; do old=$$old-1; done; \
	  mv $(OUT) $$old && echo "make run: the previous run in $(OUT) is now in $$old"; \
	fi
	$(BIN) run --out $(OUT)

## The `loomlab` binary. Built with the whole workspace selected, so that it resolves the same
## dependency features as the test build (see check-features) and reuses what that compiled.
cli:
	$(CARGO) build $(CARGO_PROFILE) --workspace --bins

## Install system packages (once; quiet; a clear message when it fails): Mesa's lavapipe (software
## Vulkan) so wgpu renders without a GPU, and Chromium, in which tests/report_html.rs opens
## report.html headless. Uses sudo when not root.
APT_INSTALL = $(SUDO) apt-get -o DPkg::Lock::Timeout=300 update -qq >/dev/null && $(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get -o DPkg::Lock::Timeout=300 install -y -qq --no-install-recommends
deps:
	@if ! ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1; then \
	  echo "deps: installing mesa-vulkan-drivers (lavapipe, software Vulkan) with apt-get ..."; \
	  $(APT_INSTALL) mesa-vulkan-drivers libvulkan1 >/tmp/loomlab-apt-mesa.log 2>&1 || { \
	    echo "deps: apt-get install mesa-vulkan-drivers libvulkan1 failed (log: /tmp/loomlab-apt-mesa.log); install them by hand, then run make again" >&2; exit 1; }; \
	fi
	@if ! command -v chromium >/dev/null 2>&1; then \
	  echo "deps: installing chromium (headless browser for the report.html test) with apt-get ..."; \
	  $(APT_INSTALL) chromium >/tmp/loomlab-apt-chromium.log 2>&1 || { \
	    echo "deps: apt-get install chromium failed (log: /tmp/loomlab-apt-chromium.log); install it by hand, then run make again" >&2; exit 1; }; \
	fi

## Formatting and lints (warnings are errors) of the whole workspace, the pyo3 crate included, and
## of the Python side (ruff, the stubs checked against the built module, mypy on the package's
## public API: run_suite, PythonDetector, python -m loomlab).
lint: lint-rust lint-python

# pyo3's build script needs an interpreter: the venv's (clippy checks the binding too).
lint-rust: python-venv check-features
	$(CARGO) fmt --all -- --check
	$(CARGO) clippy $(CARGO_PROFILE) --workspace --all-targets -- -D warnings
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc $(CARGO_PROFILE) --workspace --no-deps --lib

lint-python: $(call BUILT,python-env)
	$(VENV)/bin/ruff check python
	$(VENV)/bin/ruff format --check python
	cd python && $(abspath $(VENV))/bin/python -m mypy.stubtest loomlab._native --allowlist stubtest-allowlist.txt
	cd python && $(abspath $(VENV))/bin/mypy python/loomlab/__init__.py python/loomlab/detectors.py python/loomlab/__main__.py \
	  examples/python_detector.py bench/python_detector_overhead.py tests/test_detectors.py

## Compile every test binary and the CLI (what CI overlaps with the installs). The binding is in
## the selection (a cdylib without tests: nothing here compiles it) so that its dependencies'
## features are unified with the tests', and maturin reuses what this compiled. `--tests` leaves out the
## examples (plain `cargo test` would also compile and link them; clippy --all-targets still checks
## them in lint).
## It also lists the test binaries (.ci/test-binaries.py) for `rust-test` with PREBUILT=1.
TEST_TARGETS = --workspace --tests
TEST_LIST = $(TARGET_DIR)/$(PROFILE)/loomlab-test-binaries.txt
rust-build: python-interpreter
	$(CARGO) test $(CARGO_PROFILE) $(TEST_TARGETS) --no-run
	$(CARGO) build $(CARGO_PROFILE) --workspace --bins
	$(CARGO) test $(CARGO_PROFILE) $(TEST_TARGETS) --no-run -q --message-format=json | $(PYTHON) .ci/test-binaries.py > $(TEST_LIST)

## All Rust tests (unit and integration, then the doc tests). With PREBUILT=1 the unit and
## integration test binaries run from rust-build's list, each in its package's directory as
## `cargo test` runs them, with no cargo call (the doc tests are compiled now: they wait for the lock).
RUN_TEST_LIST = while IFS=$$'\t' read -r dir exe; do echo "     Running $$exe"; (cd "$$dir" && "$$exe") || exit 1; done < $(TEST_LIST)
rust-test: $(call BUILT,deps python-interpreter)
	$(if $(PREBUILT),$(RUN_TEST_LIST),$(CARGO) test $(CARGO_PROFILE) $(TEST_TARGETS))
	$(CARGO) test $(CARGO_PROFILE) --workspace --doc

## The binding alone (maturin's build) must resolve the same dependency features as the workspace's
## test build, or maturin compiles ~60 crates a second time: compares `cargo tree -e features` of
## both for every package they share (fix: name the missing feature in python/Cargo.toml).
FEATURE_SET = sed 's/ (\*)$$//; s/ (proc-macro)//' | sort -u
check-features:
	@mkdir -p $(TARGET_DIR)
	@$(CARGO) tree -q --workspace -e normal,build,dev -f '{p}|{f}' --prefix none | $(FEATURE_SET) > $(TARGET_DIR)/features-workspace.txt
	@$(CARGO) tree -q -p loomlab-python -e normal,build -f '{p}|{f}' --prefix none | $(FEATURE_SET) > $(TARGET_DIR)/features-binding.txt
	@awk -F'|' 'NR == FNR { shared[$$1] = 1; next } shared[$$1]' $(TARGET_DIR)/features-binding.txt $(TARGET_DIR)/features-workspace.txt \
	  | diff -u --label workspace --label binding - $(TARGET_DIR)/features-binding.txt \
	  || { echo "check-features: the binding's dependency features differ from the test build's (above); name them in python/Cargo.toml" >&2; exit 1; }

## The venv's interpreter alone (seconds): pyo3's build scripts need it before the pip installs end.
python-interpreter:
	@test -x $(VENV)/bin/python || $(PYTHON) -m venv $(VENV) 2>/dev/null || { \
	  echo "python-interpreter: installing python3-venv with apt-get ..."; rm -rf $(VENV); \
	  $(APT_INSTALL) python3-venv >/tmp/loomlab-apt-venv.log 2>&1 && $(PYTHON) -m venv $(VENV); } || { \
	  echo "python-interpreter: could not create $(VENV) (log: /tmp/loomlab-apt-venv.log)" >&2; exit 1; }

# What `make test` installs into the venv; the stamp file records it, so a venv made for an
# earlier list is completed on the next run. `--no-compile`: Python compiles the modules it
# imports when it first does, not all of ray's beforehand (35 s of CPU saved beside the build).
PIP_PACKAGES = pip maturin numpy gymnasium pytest pytest-xdist ray[tune]>=2.9 ruff mypy

## The Python package (python): a venv in $(VENV), maturin build into the workspace's target
## directory (reusing the dependencies rust-test compiled), pytest.
python-venv: python-interpreter
	@test "$$(cat $(VENV)/.loomlab-deps 2>/dev/null)" = '$(PIP_PACKAGES)' || { echo 'python-venv: pip install $(PIP_PACKAGES) into $(VENV) ...'; \
	  $(VENV)/bin/python -m pip install -q --no-compile --disable-pip-version-check --upgrade $(foreach p,$(PIP_PACKAGES),'$(p)') \
	  && echo '$(PIP_PACKAGES)' > $(VENV)/.loomlab-deps; } || { echo "python-venv: pip install failed (see above)" >&2; exit 1; }

python-env: deps python-venv
	cd python && VIRTUAL_ENV=$(abspath $(VENV)) CARGO_TARGET_DIR=$(TARGET_DIR) \
	  $(abspath $(VENV))/bin/maturin develop -q $(CARGO_PROFILE)

## pytest, the sweep tests on a local Ray with 2 CPUs included (the RLlib training test needs torch,
## which is not installed here: `pip install 'loomlab[rllib]'` to run it), then every example in
## python/examples for a few steps. The sweep tests run the `loomlab` binary: built here first.
## pytest runs one process per CPU (pytest-xdist), each test file in one process (its fixtures
## are shared by its tests): 73 s -> 48 s on 2 CPUs.
python-test: $(call BUILT,python-env cli)
	cd python && LOOMLAB_BIN=$(BIN) $(abspath $(VENV))/bin/python -m pytest -q -n auto --dist loadfile
	$(RUN_EXAMPLES)

## Smoke-run every example for a few steps (`--smoke`); those whose optional dependency (torch,
## stable-baselines3, RLlib) is missing say so and exit 0 after importing everything else.
RUN_EXAMPLES = cd python/examples && for ex in *.py; do \
	  case $$ex in _*) continue;; esac; \
	  echo "== $$ex --smoke"; $(abspath $(VENV))/bin/python $$ex --smoke || exit 1; \
	done
python-examples: python-env
	$(RUN_EXAMPLES)

## A detector-parameter sweep on a local Ray: `make sweep SWEEP=sweeps/baselines_random.toml`.
SWEEP ?= sweeps/hopfield_threshold_alpha.toml
sweep: python-env
	$(VENV)/bin/python -m loomlab.sweep $(SWEEP)

## The default suite must not regress against its committed baseline report (exit 1 lists every
## regression; tolerances in scenarios/README.md).
BASELINE ?= scenarios/baseline/default-report.json
SUITE_CHECK = $(BIN) run --out out/suite-check --overwrite --baseline $(BASELINE) --brief --no-plots --no-html
suite-check: $(call BUILT,deps cli)
	$(SUITE_CHECK)

## Re-run the default suite and make its report the new baseline (after an intended change), then
## regenerate the documentation's tables from it (readme-table).
bless: deps cli
	$(BIN) run --out out/bless --overwrite --baseline $(BASELINE) --bless
	$(MAKE) --no-print-directory readme-table

## The results tables of README.md and docs/results.md, generated from the committed baseline report
## (the blocks between `<!-- NAME:begin -->` and `<!-- NAME:end -->`; `loomlab table --help`). The
## test `docs::generated_tables_match_the_baseline` (in rust-test) fails until this is run after a
## baseline changes.
## The held-out suite's blocks (`NAME@heldout`) are generated from its own baseline.
## The `results-robot` block of docs/results.md sets the baseline beside the default suite's
## report under the `robot` sensor profile (`loomlab run --sensor robot`), per row.
DOC_TABLES = README.md docs/results.md
ROBOT_BASELINE ?= scenarios/baseline/default-robot-report.json
readme-table: cli
	$(BIN) table $(BASELINE) $(addprefix --update ,$(DOC_TABLES))
	$(BIN) table $(EVENTS_BASELINE) --tag events --update README.md --update docs/events.md
	$(BIN) table $(HELDOUT_BASELINE) --tag heldout $(addprefix --update ,$(DOC_TABLES))
	$(BIN) table $(BASELINE) --compare $(ROBOT_BASELINE) $(addprefix --update ,$(DOC_TABLES))

## The default suite on the event camera (`--sensor events`), every registered row (`--detectors
## all`: the suite's rows, which read the same frames as without it, and the event rows
## `event_soc` and `event_lgmd`): `make events` compares a run with its committed baseline,
## `make events-bless` makes a run the new baseline and regenerates the `@events` tables
## (docs/events.md). Not in `make test` (~8 min on 2 cores).
EVENTS_BASELINE ?= scenarios/baseline/default-events-report.json
EVENTS_RUN = $(BIN) run --sensor events --detectors all --out out/events --overwrite --brief --baseline $(EVENTS_BASELINE)
events: deps cli
	$(EVENTS_RUN)

events-bless: deps cli
	$(EVENTS_RUN) --bless
	$(MAKE) --no-print-directory readme-table

## The held-out suite (scenarios/suites/heldout: scenario families the default suite does not have,
## never tuned on; the default suite's detector rows): `make heldout` runs it into $(HELDOUT_OUT)
## (report.json, plots, report.html; the table printed) and compares it with its committed baseline
## (exit 1 on a regression); `make heldout-bless` makes a run its new baseline after an intended
## change, then regenerates the documentation's tables (readme-table). `make run` stays the default
## suite.
HELDOUT_SUITE = scenarios/suites/heldout
HELDOUT_BASELINE ?= $(HELDOUT_SUITE)/baseline/report.json
HELDOUT_OUT ?= out/heldout
heldout: deps cli
	$(BIN) run $(HELDOUT_SUITE) --out $(HELDOUT_OUT) --overwrite --brief --baseline $(HELDOUT_BASELINE)

## The development suite (scenarios/suites/dev: families outside the default suite that the
## controller may be tuned on) on fresh draws: DEV_SEED (any but 0) picks them.
DEV_SEED ?= 5
dev: deps cli
	$(BIN) run scenarios/suites/dev --seed $(DEV_SEED) --out out/dev --overwrite --brief

heldout-bless: deps cli
	$(BIN) run $(HELDOUT_SUITE) --out $(HELDOUT_OUT) --overwrite --brief --baseline $(HELDOUT_BASELINE) --bless
	$(MAKE) --no-print-directory readme-table

## Everything CI runs. First the installs (apt, pip) run beside the compilation of every test
## binary, which needs neither, then the binding (maturin) and the CLI; then, all at once, the
## lints, the suite check, the Rust tests and the Python side (PREBUILT=1: nothing rebuilt): each
## leaves CPU idle that the others use (each one's output is printed when it ends; no test depends
## on timing). Each step's wall time is printed ("== make test: STEP took N s").
STEP = @s=$$(date +%s); $(MAKE) --no-print-directory $(1) && echo "== make test: $(1) took $$(( $$(date +%s) - s )) s"
test:
	$(call STEP,-j3 deps python-venv rust-build python-env)
	$(call STEP,-j4 --output-sync=target PREBUILT=1 lint suite-check rust-test python-test)

## RL on the detector signals (issues 17, 28 and 54; docs/tutorial.md §6, the result in docs/results.md).
## `make rl-result` trains two PPO policies (stable-baselines3, CPU torch) on the default suite, on
## the env's training seed stream, with the defaults of `python -m loomlab.train` (action repeat 8, a
## dodge held 0.6 s, the timely-dodge bonus) and the escape controller's manoeuvres as actions
## (`--env manoeuvre`), side by side: one on the suite's rows' decision features at the suite's
## camera size (RL_RUN, `--obs decision`, at most RL_DECISION_WALL_S seconds) and the learnability
## check on the privileged percept (RL_PRIV_RUN, at most RL_WALL_S). `rl-table` then evaluates both on held-out seeds
## (RL_EVAL_SEEDS) of the default and the held-out suites, per tier, next to the suites' own rows
## and the reference rows, writes docs/rl_result.json and docs/rl_learning_curve.png, and
## regenerates the README's and docs/results.md's RL blocks from the JSON (`rl-table-docs`;
## python/tests/test_rl_result.py fails while they disagree). Torch lives in its own venv
## ($(RL_VENV)), never in `make test`'s. A run folder is never overwritten: remove $(RL_OUT) (or set
## RL_OUT) to start again; `make rl-train` after an interruption resumes both runs.
RL_VENV ?= .venv-rl
RL_SEED ?= 0
RL_WALL_S ?= 2400
# the decision run trains on alone after the privileged one ends (the result's run: 131 k decisions)
RL_DECISION_WALL_S ?= 5000
RL_STEPS ?= 400000
RL_OUT ?= out/rl
RL_RUN = $(RL_OUT)/ppo-decision-seed$(RL_SEED)
RL_PRIV_RUN = $(RL_OUT)/ppo-privileged-seed$(RL_SEED)
RL_EVAL_SEEDS ?= 2000
RL_TRAIN_ARGS = --scenario suite:default --env manoeuvre --seed $(RL_SEED) --timesteps $(RL_STEPS) \
  --eval-every 16384 --eval-seeds 1000 --eval-stride 4
rl-env: deps
	@test -x $(RL_VENV)/bin/python || $(PYTHON) -m venv $(RL_VENV)
	$(RL_VENV)/bin/python -m pip install -q --upgrade pip maturin
	cd python && VIRTUAL_ENV=$(abspath $(RL_VENV)) CARGO_TARGET_DIR=$${CARGO_TARGET_DIR:-$(CURDIR)/target} \
	  $(abspath $(RL_VENV))/bin/maturin develop --release --extras rl

rl-train: rl-train-detectors rl-train-privileged

rl-train-detectors: rl-env
	$(RL_VENV)/bin/python -m loomlab.train --obs decision --frame-size 96 $(RL_TRAIN_ARGS) --max-wall-s $(RL_DECISION_WALL_S) \
	  --out $(RL_RUN) $$(test -e $(RL_RUN)/checkpoints/latest.json && echo --resume)

# The privileged observation does not depend on the frames: this run renders at n = 32 (9x fewer
# pixels than the suite's 96, the same observations).
rl-train-privileged: rl-env
	$(RL_VENV)/bin/python -m loomlab.train --obs privileged --frame-size 32 $(RL_TRAIN_ARGS) --max-wall-s $(RL_WALL_S) \
	  --out $(RL_PRIV_RUN) $$(test -e $(RL_PRIV_RUN)/checkpoints/latest.json && echo --resume)

rl-table: rl-env
	$(RL_VENV)/bin/python -m loomlab.rl_result build --run $(RL_RUN) --privileged-run $(RL_PRIV_RUN) \
	  --suite suite:default --suite suite:heldout --seeds $(RL_EVAL_SEEDS) --processes 2 --jobs 1 \
	  --out docs/rl_result.json --png docs/rl_learning_curve.png
	$(RL_VENV)/bin/python -m loomlab.rl_result tables README.md docs/results.md

## The README's and docs/results.md's RL blocks, regenerated from the committed docs/rl_result.json.
rl-table-docs: python-env
	$(VENV)/bin/python -m loomlab.rl_result tables README.md docs/results.md

# The two runs train side by side (each for at most RL_WALL_S), then the evaluation.
rl-result: rl-env
	$(MAKE) --no-print-directory -j2 rl-train
	$(MAKE) --no-print-directory rl-table

## Criterion benchmarks (detector, baselines, simulator step).
bench: deps
	$(CARGO) bench --workspace

## What a Python detector (loomlab.PythonDetector) costs per frame over its own work, at 96×96
## (docs/adding-a-detector.md; a benchmark, not a test).
bench-python: python-env
	$(VENV)/bin/python python/bench/python_detector_overhead.py

## The event camera's cost: the default suite under the `ideal` and the `events` sensor profiles,
## alternately, with the ratio (python/bench/event_camera_cost.py; a benchmark, not a test; stdlib
## only). EVENT_BENCH_ARGS: e.g. `--limit 40 --rounds 3`.
bench-events: cli
	$(PYTHON) python/bench/event_camera_cost.py --bin $(BIN) $(EVENT_BENCH_ARGS)

## loomlab's render step against pybullet's TinyRenderer (plane + sphere) at 64² and 128², timed
## alternately in one run, with the ratio (python/bench/peer_pybullet.py; a benchmark, not a test).
## pybullet is optional: PEER_PYTHON names an interpreter that has it (default: the venv's, where
## `pip install pybullet` adds it); without it loomlab is timed alone.
PEER_PYTHON ?= $(VENV)/bin/python
bench-peer: deps
	$(CARGO) build $(CARGO_PROFILE) -p loomlab-sim --example render_bench
	@command -v $(PEER_PYTHON) >/dev/null || { echo "bench-peer: $(PEER_PYTHON) missing (make python-venv, or PEER_PYTHON=python3)" >&2; exit 1; }
	$(PEER_PYTHON) python/bench/peer_pybullet.py --bench-binary $(TARGET_DIR)/$(PROFILE)/examples/render_bench $(PEER_ARGS)

## Regenerate the paper's artificial-video figures into out/figures.
figures:
	$(CARGO) run --release -- figures --out out/figures

fmt:
	$(CARGO) fmt --all
