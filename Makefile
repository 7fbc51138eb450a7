# ivdyn: the two commands are `make demo` and `make test` (see README.md).
# Both work on a fresh machine with Rust and Python: they create .venv and fetch crates.

VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
CARGO  ?= cargo
export CARGO_TERM_COLOR ?= never

.PHONY: demo test venv rust-test nostd py-test fixtures bench bench-anchor clean

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
	touch $(STAMP)

rust-test:
	$(CARGO) test --workspace

# The core must build for a bare-metal target, and a #![no_main] probe with no global
# allocator must link: that fails if anything in ivdyn-core reaches `alloc`.
nostd:
	rustup target add thumbv7em-none-eabihf
	$(CARGO) build -p ivdyn-core --target thumbv7em-none-eabihf
	$(CARGO) build --release --target thumbv7em-none-eabihf --manifest-path tools/nostd-check/Cargo.toml

py-test: venv
	$(PY) -m pytest -q python

## fixtures: regenerate fixtures/ from Pinocchio and the NumPy reference
fixtures: venv
	$(PY) python/reference/gen_fixtures.py

## bench: criterion benchmarks (numbers go to benches/README.md by hand)
bench:
	$(CARGO) bench -p ivdyn-benches --bench dynamics

clean:
	$(CARGO) clean
	rm -rf $(VENV)
