# rockbench: `make demo` runs the main job, `make test` builds and passes every test.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/rockbench

.PHONY: all build demo test gates compare-demo chromium fmt clippy clean

all: build

build:
	$(CARGO) build --release

# The main job: the paper's two-block case with the native engine, and the slender block
# against the Housner engine. Outputs under out/demo/.
demo: build
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine native --out out/demo/two-block/native
	$(BIN) run validation/scenes/housner-slender.toml --engine housner --out out/demo/housner-slender/housner
	$(BIN) run validation/scenes/housner-slender.toml --engine native --out out/demo/housner-slender/native

# Every test, numerical ones in release mode, then the accuracy gates. Headless Chromium
# (Debian's package) renders report.html in a test, so it is installed first.
test: chromium
	$(CARGO) test --release
	$(MAKE) gates

# Headless Chromium for the report-rendering test.
chromium:
	command -v chromium >/dev/null || (apt-get update && apt-get install -y chromium)

# Accuracy gates (validation/gates.toml); runs are cached in .cache/rockbench/.
gates: build
	$(BIN) gate validation/gates.toml --junit out/gates/junit.xml --quiet

# Cross-validation reports of the validation scenes (engines not built in are listed as skipped).
compare-demo: build
	$(BIN) compare validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet,housner --reference housner --out out/compare/housner-slender
	$(BIN) compare validation/scenes/housner-square.toml --engines native,rapier,mujoco,pybullet,housner --reference housner --out out/compare/housner-square
	$(BIN) compare validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet,housner --reference native --out out/compare/two-block-free-rocking

fmt:
	$(CARGO) fmt --all

clippy:
	$(CARGO) clippy --release --all-targets -- -D warnings

clean:
	rm -rf out target
