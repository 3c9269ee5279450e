# rockbench: `make demo` runs the main job, `make test` builds and passes every test.
SHELL := /bin/bash
CARGO ?= cargo
BIN := target/release/rockbench

# Python: a virtual environment with the pinned packages of python/requirements.txt (MuJoCo,
# PyBullet, numpy, pandas, maturin, pytest, mypy) and the extension rockbench._native built
# into it. Stamp files keep an unchanged tree from reinstalling or rebuilding.
PYTHON311 ?= python3.11
VENV := .venv
VPY := $(VENV)/bin/python
RUST_SOURCES := $(shell find src -name '*.rs') Cargo.toml Cargo.lock

.PHONY: all build demo test test-rust test-no-default-features test-python stubtest \
	settings-sweep rapier-sweep gates compare-demo chromium bench bench-steps fmt clippy clean .venv

all: build

build:
	$(CARGO) build --release

# The main job: the paper's two-block case on every engine, and the slender block against the
# Housner engine. Outputs under out/demo/.
demo: build .venv
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine native --out out/demo/two-block/native
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine rapier --out out/demo/two-block/rapier
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine mujoco --out out/demo/two-block/mujoco
	$(BIN) run validation/scenes/two-block-free-rocking.toml --engine pybullet --out out/demo/two-block/pybullet
	$(BIN) run validation/scenes/housner-slender.toml --engine housner --out out/demo/housner-slender/housner
	$(BIN) run validation/scenes/housner-slender.toml --engine native --out out/demo/housner-slender/native

# Every test, numerical ones in release mode: the build without optional engines, cargo's
# tests, pytest (warnings are errors, see pyproject.toml) including the stub check.
test: test-no-default-features test-rust test-python

test-no-default-features: chromium
	$(CARGO) test --release --no-default-features

test-rust: chromium
	$(CARGO) test --release
	$(MAKE) gates

test-python: .venv build
	$(VPY) -m pytest -q tests/python

# Headless Chromium (Debian's package) for the report-rendering test.
chromium:
	command -v chromium >/dev/null || (apt-get update && apt-get install -y chromium)

# Accuracy gates (validation/gates.toml); runs are cached in .cache/rockbench/.
gates: build
	$(BIN) gate validation/gates.toml --junit out/gates/junit.xml --quiet

# Cross-validation reports of the validation scenes.
compare-demo: build .venv
	$(BIN) compare validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet,housner --reference housner --out out/compare/housner-slender
	$(BIN) compare validation/scenes/housner-square.toml --engines native,rapier,mujoco,pybullet,housner --reference housner --out out/compare/housner-square
	$(BIN) compare validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet,housner --reference native --out out/compare/two-block-free-rocking

# The measurement behind the MuJoCo and PyBullet defaults (about a minute).
settings-sweep: .venv build
	$(VPY) -m rockbench.settings_sweep --out out/settings-sweep.md

# The measurement behind the rapier engine's defaults (docs/engines-rapier.md), ~10 s.
rapier-sweep:
	$(CARGO) run --release --example rapier_sweep

# The hand-written stubs against the built extension (also run by pytest).
stubtest: .venv
	$(VPY) -m mypy.stubtest rockbench._native

.venv: $(VENV)/.requirements.stamp $(VENV)/.native.stamp

$(VENV)/.requirements.stamp: python/requirements.txt
	command -v $(PYTHON311) >/dev/null || (apt-get update && apt-get install -y python3.11 python3.11-venv python3.11-dev)
	test -x $(VPY) || $(PYTHON311) -m venv $(VENV)
	$(VPY) -m pip install --disable-pip-version-check -q -r python/requirements.txt
	touch $@

$(VENV)/.native.stamp: $(VENV)/.requirements.stamp $(RUST_SOURCES) pyproject.toml
	cd $(CURDIR) && VIRTUAL_ENV=$(CURDIR)/$(VENV) $(VENV)/bin/maturin develop --release --quiet
	touch $@

fmt:
	$(CARGO) fmt --all

clippy:
	$(CARGO) clippy --release --all-targets -- -D warnings
	$(CARGO) clippy --release --lib --features python -- -D warnings

clean:
	rm -rf out target $(VENV) python/rockbench/_native*.so

# Per-step cost of the native engine for 1, 2, 10, 50 and 210 blocks and every back-end
# (criterion; a few minutes).
bench-steps:
	$(CARGO) bench --bench step_cost

# The work-precision benchmark of the slender block (every engine, step sizes, native variants).
bench: build .venv
	$(BIN) bench validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet,housner --dt 2e-3,1e-3,5e-4,1e-4,5e-5,2e-5 --repeat 3 --reference housner --set duration=3.0 --out out/bench/housner-slender
	$(BIN) bench validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet --dt 2e-3,1e-3,5e-4 --repeat 3 --reference native --set duration=4.0 --out out/bench/two-block
