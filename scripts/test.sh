#!/usr/bin/env bash
# Every test of the project, from a fresh clone: installs what it needs, builds the FMUs,
# runs the Rust tests (physics, FMI behaviour, FMU import) and the FMPy cross-tool tests.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo run --release -q -p fmu-build
cargo test --release --workspace
.venv/bin/python -m pytest tests/python -q -p no:cacheprovider
