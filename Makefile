# rockbench: `make demo` runs the main job, `make test` builds and passes every test.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/rockbench

.PHONY: all build demo test fmt clippy clean

all: build

build:
	$(CARGO) build --release

# The main job: the paper's two-block case with the native engine, and the slender block
# against the Housner engine. Outputs under out/demo/.
demo: build
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine native --out out/demo/two-block/native
	$(BIN) run validation/scenes/housner-slender.toml --engine housner --out out/demo/housner-slender/housner
	$(BIN) run validation/scenes/housner-slender.toml --engine native --out out/demo/housner-slender/native

# Every test, numerical ones in release mode.
test:
	$(CARGO) test --release

fmt:
	$(CARGO) fmt --all

clippy:
	$(CARGO) clippy --release --all-targets -- -D warnings

clean:
	rm -rf out target
