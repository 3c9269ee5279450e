#!/usr/bin/env bash
# Run every fuzz target for FUZZ_SECONDS (default 600) each, one after the other.
# Usage: fuzz/run.sh [target ...]   (from the repository root; `make fuzz` calls it)
# Stable Rust is enough: RUSTC_BOOTSTRAP=1 lets cargo-fuzz pass its -Z flags.
set -euo pipefail
cd "$(dirname "$0")/.."
SECS="${FUZZ_SECONDS:-600}"
TARGETS=("$@")
[ ${#TARGETS[@]} -gt 0 ] || TARGETS=(scene_toml scene_json record_at2 record_csv trajectory_csv suite_manifest study_file gate_file checkpoint resume)
command -v cargo-fuzz >/dev/null || cargo install cargo-fuzz --locked
export RUSTC_BOOTSTRAP=1
# -s none: the code under test is safe Rust (no C), so coverage without a sanitizer runs
# faster; -a keeps debug assertions (integer overflow checks) on.

failed=()
for t in "${TARGETS[@]}"; do
    mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
    extra=()
    case "$t" in
        scene_*) extra=(-dict=fuzz/scene.dict) ;;
        suite_manifest | study_file | gate_file) extra=(-dict=fuzz/manifest.dict) ;;
        checkpoint) extra=(-dict=fuzz/checkpoint.dict) ;;
        # Its inputs are lists of five-byte changes: long enough for several from the start.
        resume) extra=(-max_len=256 -len_control=0) ;;
    esac
    echo "== fuzzing $t for $SECS s"
    cargo fuzz run --fuzz-dir fuzz -s none -a "$t" "fuzz/corpus/$t" "fuzz/seeds/$t" -- \
        -max_total_time="$SECS" -timeout=10 -rss_limit_mb=2048 -print_final_stats=1 \
        -artifact_prefix="fuzz/artifacts/$t/" "${extra[@]}" || failed+=("$t")
done
if [ ${#failed[@]} -gt 0 ]; then
    echo "fuzz: crashes in ${failed[*]}: inputs under fuzz/artifacts/; add each to tests/fuzz_regressions/<target>/" >&2
    exit 1
fi
echo "fuzz: no crash in ${TARGETS[*]} ($SECS s each)"
