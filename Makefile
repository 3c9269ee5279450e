# rockbench: `make demo` runs the main job, `make test` builds and passes every test.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/rockbench

.PHONY: all build demo test stress proptest fuzz fmt clippy clean

all: build

build:
	$(CARGO) build --release

# The main job: the paper's two-block case with the native engine, and the slender block
# against the Housner engine. Outputs under out/demo/.
demo: build
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine native --out out/demo/two-block/native
	$(BIN) run validation/scenes/housner-slender.toml --engine housner --out out/demo/housner-slender/housner
	$(BIN) run validation/scenes/housner-slender.toml --engine native --out out/demo/housner-slender/native

# Every test, numerical ones in release mode; then the quick stability map, which fails on
# any invariant violation or failed run not explained in validation/stress-known.toml.
test: build
	$(CARGO) test --release
	$(BIN) stress --quick --out out/stress-quick

# The full stability map (every engine built in; about 15-30 min on 2 cores).
stress: build
	$(BIN) stress --out out/stress

# Random scenes, nightly-sized: PROPTEST_CASES (default 10000) cases.
PROPTEST_CASES ?= 10000
proptest:
	PROPTEST_CASES=$(PROPTEST_CASES) $(CARGO) test --release --test proptest_scenes

# Fuzz the scene parser and the record readers, FUZZ_SECONDS (default 600) per target.
# Installs cargo-fuzz if missing; runs on stable Rust (RUSTC_BOOTSTRAP=1, see fuzz/run.sh).
FUZZ_SECONDS ?= 600
fuzz:
	FUZZ_SECONDS=$(FUZZ_SECONDS) fuzz/run.sh

fmt:
	$(CARGO) fmt --all

clippy:
	$(CARGO) clippy --release --all-targets -- -D warnings

clean:
	rm -rf out target
