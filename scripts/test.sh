#!/usr/bin/env bash
# Every test of the project, from a fresh clone: installs what it needs, checks formatting
# and lints, builds the FMUs for all five platforms, runs the Rust tests (physics, FMI
# behaviour, FMU import, HIL bridge, C API) and the FMPy cross-tool tests. Ends with how
# long each part took, one line each (also when a part fails).
set -euo pipefail
cd "$(dirname "$0")/.."

# `part NAME COMMAND...` runs COMMAND and records its wall-clock time under NAME.
times=() current="" started=${EPOCHREALTIME/./} pytest_log=$(mktemp)
part() {
    current=$1
    shift
    local start=${EPOCHREALTIME/./}
    "$@"
    times+=("$(elapsed "$current" "$start")")
    current=""
}
elapsed() { # NAME START_MICROSECONDS: "test.sh: time NAME  S.s s"
    local us=$((${EPOCHREALTIME/./} - $2))
    printf 'test.sh: time %-22s %6d.%d s' "$1" $((us / 1000000)) $((us / 100000 % 10))
}
report() {
    local rc=$?
    printf '%s\n' "${times[@]}"
    elapsed total "$started"
    echo
    if [ -n "$current" ]; then echo "test.sh: $current failed (exit $rc)"; fi
    # pytest's count again, as the run's last line, below the times.
    if [ -s "$pytest_log" ]; then tail -n 1 "$pytest_log"; fi
    rm -f "$pytest_log"
}
trap report EXIT

part setup bash scripts/setup.sh

# The repository stands on its own: nothing tracked may read the design inputs beside it.
if git grep -n '\.\./shared' -- . ':!scripts/test.sh' >/dev/null 2>&1; then
    echo "test.sh: tracked files read the design folder beside the repository, which its users do not have:" >&2
    git grep -n '\.\./shared' -- . ':!scripts/test.sh' >&2
    exit 1
fi

fmt() {
    cargo fmt --all --check
    # The C API and the fuzz target are workspaces of their own.
    cargo fmt --check --manifest-path crates/hil-protocol/ffi/Cargo.toml
    cargo fmt --check --manifest-path crates/hil-protocol/fuzz/Cargo.toml
}
part fmt fmt
part clippy cargo clippy --release --workspace --all-targets -- -D warnings
# The committed generated files (modelDescription/) against the variable tables, before
# fmu-build rewrites them: this is the step that fails when they drift.
part "fmu-build --check" cargo run --release -q -p fmu-build -- --check
# Every platform's binaries: tests/python (test_platforms, test_binaries, the reference
# results) and tests/cross load them, and dist/bin/inchworm against glibc 2.17.
part "fmu-build" cargo run --release -q -p fmu-build -- --all-platforms
# Every test target and the doc tests; the examples, which clippy has compiled above, are
# not linked again (the dos-actors examples alone took 44 s of a core).
cargo_test() {
    cargo test --release --workspace --tests
    cargo test --release --workspace --doc
}
part "cargo test" cargo_test
# The engine from outside the workspace (its own Cargo.lock, the same target folder).
part "engine-api test" cargo test --release --manifest-path tests/engine-api/Cargo.toml \
    --target-dir "${CARGO_TARGET_DIR:-target}"
# A parameter added as one row of a variable table reaches everything (scratch copy).
part "one-row" bash scripts/one-row.sh
# Two workers, each taking whole files (their module fixtures, such as the Modelica
# package's compilation, made once): the suite is mostly one core's work.
pytest_all() {
    .venv/bin/python -m pytest tests/python -q -p no:cacheprovider -n 2 --dist loadfile |
        tee "$pytest_log"
}
part pytest pytest_all
