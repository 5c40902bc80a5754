#!/usr/bin/env bash
# The main job, from a fresh clone: builds the FMUs for this machine's platform into dist/
# and runs the default scenario (Fig. 5) through them, writing results (CSV) and a plot
# (PNG) into out/. It needs only the Rust toolchain and the plot's font
# (scripts/setup-run.sh); the FMUs for all five platforms, with their toolchains, are
# scripts/test.sh's (`fmu-build --all-platforms`, docs/platforms.md).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup-run.sh
cargo run --release -q -p fmu-build
cargo run --release -q -p inchworm -- scenario fig5 --dist dist --out out
