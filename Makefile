# ivdyn: the two commands are `make demo` and `make test` (see README.md).
# Both work on a fresh machine with Rust and Python: they create .venv and fetch crates.

VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
CARGO  ?= cargo
export CARGO_TERM_COLOR ?= never

.PHONY: demo test test-wheel lint-then-test py-run smoke-run rust-build venv lint rust-test rust-tests rust-unit rust-doc nostd py-test fixtures bench bench-anchor bench-hour clean paper real-data floor messy py-install fuzz wheel wheel-smoke package publish-check

## demo: the main job on bundled data: the dynamics of the bundled robots, then a
## simulated UR5 log with friction and a 2 kg payload -> `ivdyn identify` (unloaded log)
## and `ivdyn payload` (log after the grasp, with the unloaded log as the before-log)
DEMO := out/demo
demo:
	$(CARGO) build --release -p ivdyn-cli --bin ivdyn -p ivdyn --example demo
	./target/release/examples/demo
	mkdir -p $(DEMO)
	./target/release/ivdyn simulate --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --fc 2,2,1.5,0.6,0.6,0.4 --fv 0.8,0.8,0.5,0.2,0.2,0.1 --noise 0.1 --seed 1 --out $(DEMO)/ur5_unloaded.mcap --quiet
	./target/release/ivdyn simulate --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --fc 2,2,1.5,0.6,0.6,0.4 --fv 0.8,0.8,0.5,0.2,0.2,0.1 --noise 0.1 --seed 2 \
	    --payload-mass 2 --payload-com 0.01,-0.02,0.05 --out $(DEMO)/ur5_payload.mcap --quiet
	./target/release/ivdyn identify --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --log $(DEMO)/ur5_unloaded.mcap --method wls --json $(DEMO)/identify.json --out-params $(DEMO)/ur5_params.json \
	    --report $(DEMO)/identify.html
	./target/release/ivdyn payload --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --log $(DEMO)/ur5_payload.mcap --before $(DEMO)/ur5_unloaded.mcap --json $(DEMO)/payload.json \
	    --report $(DEMO)/payload.html
	@echo "demo outputs in $(DEMO)/ (JSON and HTML reports identify.html, payload.html; logs); truth: 2 kg at (0.01, -0.02, 0.05) m"
	./target/release/ivdyn diagnose --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --log fixtures/diagnose/viscous_payload.mcap --out $(DEMO)/diagnose
	@echo "diagnosis of a MuJoCo log (truth: 1.2 kg payload, viscous friction on shoulder_lift and wrist_1): $(DEMO)/diagnose/report.html"

## test: formatting and lints, the published crates' packaging, every Rust test, the
## no_std/no-alloc proof, the Python suites, and the wheel in a fresh venv.
# Two stages, so that neither core idles: (1) the venv's packages install while packaging
# and the Rust test build run, then the Python extension builds in the dev profile in the
# same target dir, reusing that build (tools/feature_parity.py); (2) fmt and clippy, then the
# Rust tests (both take cargo's lock on target/, so one after the other), beside the Python
# suites, the fresh-venv wheel check and the no_std probe, which need only what stage 1 built.
# Stage 2 runs three jobs at once: the Python suites and the Rust tests each keep about two
# cores busy for most of it, but both end in steps of one (the small Rust suites, the
# doctests) that the no_std build and the wheel check fill. -Otarget prints each step's
# output whole when it ends.
test:
	$(MAKE) -j2 test-wheel
	$(MAKE) -j3 -Otarget lint-then-test py-run nostd smoke-run SMOKE_WHEELS=$(TEST_WHEELS)

lint-then-test:
	$(MAKE) lint
	$(MAKE) rust-test

# The Rust tests: every crate's unit and integration tests, then the doctests (docs/*.md pages
# with rust blocks are doctests too). Examples are not built here (`cargo test` would build
# them all: clippy --all-targets checks them), except write_log, which a Python test runs;
# ivdyn-py is tested from Python, and ivdyn-benches has no tests (criterion stays out).
# ivdyn's own unit tests (`--lib`) compile the whole crate a second time, with cfg(test):
# 182 CPU s at the profile's opt-level 2. So the unit tests are built apart, with ivdyn at
# opt-level 0 (its lib and lib test 48 CPU s; the lib tests of ivdyn-lab and
# ivdyn-fuzz link that build), so the crate the other tests and the wheel link stays at 2
# (a profile setting for all of `cargo test` would change every crate's build). The same
# packages are selected in both, so every dependency has the same features and builds once
# (`-p ivdyn` alone unifies fewer and rebuilt nalgebra, serde, ...). At opt-level 0 one
# test needs more than the default 2 MiB thread stack, hence RUST_MIN_STACK. `cargo test`
# alone runs them at opt-level 2, as ever.
RUST_PKGS := --workspace --exclude ivdyn-py --exclude ivdyn-benches
UNIT_TESTS := $(RUST_PKGS) --lib --config 'profile.test.package.ivdyn.opt-level=0'
rust-build: package
	$(CARGO) test $(RUST_PKGS) --bins --test '*' --no-run
	$(CARGO) test $(UNIT_TESTS) --no-run
	$(CARGO) build $(RUST_PKGS) --lib --bins --test '*' --example write_log

## lint: rustfmt (rustfmt.toml) and clippy with warnings as errors, on every target
lint:
	$(CARGO) fmt --all --check
	$(CARGO) clippy --workspace --all-targets -- -D warnings

venv: $(STAMP)
# --no-compile: Python compiles what it imports on first use; compiling every file of Ray,
# MuJoCo, Pinocchio and pandas up front takes CPU from the Rust build running beside it.
$(STAMP): python/requirements-dev.txt
	python3 -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q --no-compile -r python/requirements-dev.txt
	$(VENV)/bin/pip install -q maturin==1.16.0
	touch $(STAMP)

# Three independent parts; under make test's -j they run side by side (cargo holds its lock
# on target/ only while it builds, and everything is built by then): the unit tests and the
# doctests, mostly one core each, fill the time the integration suites leave.
rust-test: rust-tests rust-unit rust-doc

rust-tests:
	$(CARGO) test $(RUST_PKGS) --bins --test '*'

rust-unit:
	RUST_MIN_STACK=8388608 $(CARGO) test $(UNIT_TESTS)

rust-doc:
	$(CARGO) test $(RUST_PKGS) --doc

# The core must build for a bare-metal target, and a #![no_main] probe with no global
# allocator must link: that fails if anything in ivdyn-core reaches `alloc`.
# (The probe builds ivdyn-core for that target itself: no separate build of the core.)
nostd:
	rustup target add thumbv7em-none-eabihf
	$(CARGO) build --release --target thumbv7em-none-eabihf --manifest-path tools/nostd-check/Cargo.toml

## package: the published crates (ivdyn-core, ivdyn, ivdyn-cli) pack: manifests, versions
## beside paths, files inside each crate (`make publish-check` also builds the packed crates)
PUBLISHED := -p ivdyn-core -p ivdyn -p ivdyn-cli
package:
	$(CARGO) package $(PUBLISHED) --no-verify --allow-dirty -q

## publish-check: `cargo publish --dry-run` of the published crates (packs and builds them
## from the packed sources against crates.io, as a publish would)
# Its own target dir: cargo takes a registry crate's build by name and version, so an
# ivdyn-core 0.1.0 built by an earlier dry run would stand in for the one just packed.
publish-check:
	rm -rf target/package
	CARGO_TARGET_DIR=target/publish-check $(CARGO) publish --dry-run $(PUBLISHED) --allow-dirty

# wheel: the abi3 wheel (crates/ivdyn-py via maturin, release) in target/wheels; py-install
# installs that same wheel into the venv. It builds in its own target dir, target/wheel-build,
# so that it never waits on the lock of a cargo command running beside it.
WHEELS := target/wheels
MATURIN = PATH="$(abspath $(VENV))/bin:$$PATH" $(VENV)/bin/maturin build --quiet
wheel: venv
	@test -x $(VENV)/bin/maturin || $(VENV)/bin/pip install -q maturin==1.16.0
	rm -f $(WHEELS)/ivdyn-*.whl
	$(MATURIN) --release --out $(WHEELS) --target-dir target/wheel-build

py-install: wheel
	$(VENV)/bin/pip install -q --force-reinstall --no-deps $(WHEELS)/ivdyn-*.whl

# test-wheel (make test): the same wheel in the dev profile, built in cargo test's target dir
# right after the Rust test build, so that every crate they share compiles once (a release
# build of them all took more CPU than the Python suites' difference in speed); installed into
# the venv. Cargo shares a crate only when both builds enable the same features on it:
# tools/feature_parity.py names any that differ (the build is then right, only slower).
TEST_WHEELS := target/wheels-test
test-wheel: venv rust-build
	@$(PY) tools/feature_parity.py || echo "warning: the test wheel recompiles the crates above (make test is slower, not wrong)"
	rm -f $(TEST_WHEELS)/ivdyn-*.whl
	$(MATURIN) --profile dev --out $(TEST_WHEELS) --target-dir target
	$(VENV)/bin/pip install -q --force-reinstall --no-deps $(TEST_WHEELS)/ivdyn-*.whl

## wheel-smoke: the wheel installed into a fresh venv (NumPy from the package index, nothing
## from this tree on the path) runs python/tools/wheel_smoke.py
SMOKE_VENV := target/wheel-smoke-venv
SMOKE_WHEELS ?= $(WHEELS)
wheel-smoke: wheel
	$(MAKE) smoke-run

smoke-run:
	rm -rf $(SMOKE_VENV)
	python3 -m venv $(SMOKE_VENV)
	$(SMOKE_VENV)/bin/pip install -q $(SMOKE_WHEELS)/ivdyn-*.whl
	cd $(SMOKE_VENV) && ./bin/python $(abspath python/tools/wheel_smoke.py) $(abspath fixtures)

# py-test runs every pytest suite (python/reference, python/tests, python/tests_io), on
# two workers (pytest-xdist), each file's tests on one worker (--dist loadfile: its
# session and module fixtures, e.g. the synthetic fleet and a Ray runtime, are made once;
# --dist loadgroup ignored the xdist_group marks with pytest 9.2 / xdist 3.8: the names got
# no @group suffix and one file's tests ran on both workers), against the installed wheel
# (py-run: against whatever wheel is installed).
py-test: py-install
	$(MAKE) py-run

py-run:
	IVDYN_BIN=$(abspath target/debug/ivdyn) $(PY) -m pytest -q -n 2 --dist loadfile --durations=15 python

## fuzz: every reader fuzzed for FUZZ_SECS seconds each, coverage-guided (cargo-fuzz on
## nightly, installed here; 1 GB memory and 20 s per input at most). `make test` runs the
## same targets on mutated seeds for a few seconds (crates/ivdyn-fuzz/tests/smoke.rs).
FUZZ_SECS ?= 600
FUZZ_TARGETS := mcap csv urdf params db3 bag
fuzz:
	rustup toolchain install nightly --profile minimal
	@command -v cargo-fuzz >/dev/null || $(CARGO) install cargo-fuzz --version 0.13.2 --locked
	$(CARGO) run -q -p ivdyn-fuzz --example write_corpus
	cd crates/ivdyn-fuzz && for t in $(FUZZ_TARGETS); do \
	    cargo +nightly fuzz run $$t -- -max_total_time=$(FUZZ_SECS) -rss_limit_mb=1024 -timeout=20 || exit 1; done

## fixtures: regenerate fixtures/ from Pinocchio and the NumPy reference
fixtures: venv
	$(PY) python/reference/gen_fixtures.py

## bench: criterion benchmarks (numbers go to benches/README.md by hand)
bench:
	$(CARGO) bench -p ivdyn-benches

## bench-hour: a 1-hour, 1 kHz UR5 log (friction, 0.1 N m torque noise; ~610 MB, written
## once to $(HOUR_LOG), not into the repository) identified end to end by the streaming
## `ivdyn identify` (read, condition, regressor, parallel filter, WLS + IV/DWH, validation);
## wall time and peak memory from /usr/bin/time -v (benches/README.md has the numbers)
HOUR_LOG ?= /tmp/ivdyn-hour.mcap
bench-hour:
	$(CARGO) build --release -p ivdyn-cli --bin ivdyn
	test -f $(HOUR_LOG) || ./target/release/ivdyn simulate --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --duration 3600 --rate 1000 --fc 2,2,1.5,0.6,0.6,0.4 --fv 0.8,0.8,0.5,0.2,0.2,0.1 --noise 0.1 --seed 1 \
	    --out $(HOUR_LOG) --quiet
	uptime
	/usr/bin/time -v ./target/release/ivdyn identify --urdf fixtures/ur5.urdf --base base_link --tip tool0 \
	    --log $(HOUR_LOG) --json $(HOUR_LOG).json --quiet 2>&1 | \
	    grep -E "fit:|validation|Durbin|Elapsed|Maximum resident|User time|System time|Percent of CPU"

clean:
	$(CARGO) clean
	rm -rf $(VENV)

## paper: reproduce the paper's Figs 2-3 and the Monte Carlo study (docs/paper-reproduction.md)
paper: venv
	$(CARGO) run --release -p ivdyn-lab --example paper_reproduction -- --seeds 20 --n-max 1000000 --out out/paper
	$(PY) examples/plot_paper.py --in out/paper --out docs/figures

## real-data: identification on the real TX40 and LWR4+ recordings in ../shared/data/real
## (docs/real-data.md); DATA=path overrides the data folder
DATA ?= ../shared/data/real
real-data: venv
	$(CARGO) run --release -p ivdyn-lab --example real_data -- $(DATA) --out out/real
	$(PY) examples/plot_real_data.py --in out/real --out docs/figures

## floor: ivdyn identify's defaults against the plain NumPy least-squares floor on the real
## recordings (python/tools/ls_floor.py; the table of docs/real-data.md)
floor: py-install
	$(PY) python/tools/ls_floor.py --real $(DATA) --markdown out/floor.md --json out/floor.json

## messy: identify on messy logs (jitter, repeats, standstills, a gap, currents with k_t
## 10 % off) against the same motion logged cleanly, then the loaded/unloaded messy pair:
## drive gains, the payload with them and with the believed k_t, and the std's coverage
## (python/tools/messy_log.py; the table of docs/real-logs.md, "The messy pair")
messy: py-install
	$(PY) python/tools/messy_log.py
