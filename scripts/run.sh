#!/usr/bin/env bash
# The main job, from a fresh clone: builds the FMUs into dist/ and runs the default
# scenario through them, writing results (CSV) and a plot (PNG) into out/.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
cargo run --release -q -p fmu-build
cargo run --release -q -p inchworm -- scenario fig5 --dist dist --out out
