# rockbench: `make demo` runs the main job, `make test` builds and passes every test.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/rockbench

.PHONY: all build demo test test-no-default-features rapier-sweep fmt clippy clean

all: build

build:
	$(CARGO) build --release

# The main job: the paper's two-block case with the native engine, and the slender block
# against the Housner engine. Outputs under out/demo/.
demo: build
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine native --out out/demo/two-block/native
	$(BIN) run validation/scenes/housner-slender.toml --engine housner --out out/demo/housner-slender/housner
	$(BIN) run validation/scenes/housner-slender.toml --engine native --out out/demo/housner-slender/native
	$(BIN) run validation/scenes/housner-slender.toml --engine rapier --out out/demo/housner-slender/rapier
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine rapier --out out/demo/two-block/rapier

# Every test, numerical ones in release mode: first without the optional engines (the build
# must work and pass without them), then the default build (last, so target/release holds it).
test: test-no-default-features
	$(CARGO) test --release

test-no-default-features:
	$(CARGO) test --release --no-default-features

# The measurement behind the rapier engine's defaults (docs/engines-rapier.md), ~10 s.
rapier-sweep:
	$(CARGO) run --release --example rapier_sweep

fmt:
	$(CARGO) fmt --all

clippy:
	$(CARGO) clippy --release --all-targets -- -D warnings

clean:
	rm -rf out target
