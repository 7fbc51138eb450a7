# ivdyn: the two commands are `make demo` and `make test` (see README.md).
# Both work on a fresh machine with Rust and Python: they create .venv and fetch crates.

VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
CARGO  ?= cargo
export CARGO_TERM_COLOR ?= never

.PHONY: demo test venv rust-test nostd py-test fixtures bench bench-anchor clean paper

## demo: build and run the end-to-end example on the bundled robots
demo:
	$(CARGO) run --release -p ivdyn --example demo

## test: every Rust test, the no_std/no-alloc proof, and the Python suites
test: rust-test nostd py-test

venv: $(STAMP)
$(STAMP): python/requirements-dev.txt
	python3 -m venv $(VENV)
	$(VENV)/bin/pip install -q --upgrade pip
	$(VENV)/bin/pip install -q -r python/requirements-dev.txt
	$(VENV)/bin/pip install -q maturin==1.16.0
	touch $(STAMP)

rust-test:
	$(CARGO) test --workspace

# The core must build for a bare-metal target, and a #![no_main] probe with no global
# allocator must link: that fails if anything in ivdyn-core reaches `alloc`.
nostd:
	rustup target add thumbv7em-none-eabihf
	$(CARGO) build -p ivdyn-core --target thumbv7em-none-eabihf
	$(CARGO) build --release --target thumbv7em-none-eabihf --manifest-path tools/nostd-check/Cargo.toml

# Builds and installs the `ivdyn` package (crates/ivdyn-py via maturin, release, in-tree
# target/) into the venv, then runs every pytest suite (python/reference, python/tests).
# --no-build-isolation: maturin comes from the venv (no download per run); it must be on PATH.
py-test: venv
	@test -x $(VENV)/bin/maturin || $(VENV)/bin/pip install -q maturin==1.16.0
	PATH="$(abspath $(VENV))/bin:$$PATH" $(VENV)/bin/pip install -q --no-build-isolation .
	$(PY) -m pytest -q python

## fixtures: regenerate fixtures/ from Pinocchio and the NumPy reference
fixtures: venv
	$(PY) python/reference/gen_fixtures.py

## bench: criterion benchmarks (numbers go to benches/README.md by hand)
bench:
	$(CARGO) bench -p ivdyn-benches

clean:
	$(CARGO) clean
	rm -rf $(VENV)

## paper: reproduce the paper's Figs 2-3 and the Monte Carlo study (docs/paper-reproduction.md)
paper: venv
	$(CARGO) run --release -p ivdyn --example paper_reproduction -- --seeds 20 --n-max 1000000 --out out/paper
	$(PY) examples/plot_paper.py --in out/paper --out docs/figures
