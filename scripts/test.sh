#!/usr/bin/env bash
# Every test of the project, from a fresh clone: installs what it needs, checks formatting
# and lints, builds the FMUs, runs the Rust tests (physics, FMI behaviour, FMU import, HIL
# bridge, C API) and the FMPy cross-tool tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh

# The repository stands on its own: nothing tracked may read the design inputs beside it.
if git grep -n '\.\./shared' -- . ':!scripts/test.sh' >/dev/null 2>&1; then
    echo "test.sh: tracked files read the design folder beside the repository, which its users do not have:" >&2
    git grep -n '\.\./shared' -- . ':!scripts/test.sh' >&2
    exit 1
fi

cargo fmt --all --check
# The C API and the fuzz target are workspaces of their own.
cargo fmt --check --manifest-path crates/hil-protocol/ffi/Cargo.toml
cargo fmt --check --manifest-path crates/hil-protocol/fuzz/Cargo.toml
cargo clippy --release --workspace --all-targets -- -D warnings
# The committed generated files (modelDescription/) against the variable tables, before
# fmu-build rewrites them: this is the step that fails when they drift.
cargo run --release -q -p fmu-build -- --check
cargo run --release -q -p fmu-build
cargo test --release --workspace
# The engine from outside the workspace (its own Cargo.lock, the same target folder).
cargo test --release --manifest-path tests/engine-api/Cargo.toml --target-dir "${CARGO_TARGET_DIR:-target}"
.venv/bin/python -m pytest tests/python -q -p no:cacheprovider
