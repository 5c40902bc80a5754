#!/usr/bin/env bash
# The co-phasing scenario (docs/segments.md, "Co-phasing on the engine"): a 37-segment
# mirror, every segment from a seeded random error (piston ±10 µm, tip and tilt ±5 µrad) to
# the phased mirror, then regulation; once with each controller (the paper's stepping gait,
# the deadband, analog mode). For each: `fmu-build segmented --cophase --controller C`,
# `inchworm run --jobs 2 --poses`, the optics of python/inchworm_segments (frames on 2
# processes); then the three side by side: the table printed and written, the figure.
#
#   bash scripts/cophase.sh              # after `bash scripts/setup.sh`; writes out/cophase/
#
# Settings (environment): RINGS (3), SEED (1), STOP (10 s), REGULATION (6 s: the regulation
# window's start), PUPIL (64 pixels across D), FRAME_MS (50), WORKERS (2), OUT (out/cophase).
set -euo pipefail
cd "$(dirname "$0")/.."
RINGS=${RINGS:-3} SEED=${SEED:-1} STOP=${STOP:-10} REGULATION=${REGULATION:-6}
PUPIL=${PUPIL:-64} FRAME_MS=${FRAME_MS:-50} WORKERS=${WORKERS:-2} OUT=${OUT:-out/cophase}
PY=.venv/bin/python
[ -x "$PY" ] || { echo "cophase.sh: no $PY: run bash scripts/setup.sh first" >&2; exit 2; }

# dist/'s FMUs from this tree (the mount's offsets are what --cophase binds), and the master.
cargo run --release -q -p fmu-build
cargo build --release -q -p inchworm

segments=$((3 * RINGS * (RINGS + 1) + 1))
# What --poses reads: every mount's pose and every controller's DAC outputs.
outputs=()
for ((k = 0; k < segments; k++)); do
  for v in piston tip tilt; do outputs+=(--output "seg${k}_mount.$v"); done
  for x in a b c; do
    for v in dac_earth dac_nonearth dac_extension; do outputs+=(--output "seg${k}_controller_$x.$v"); done
  done
done

runs=()
for c in stepping deadband analog; do
  dir=$OUT/$c
  mkdir -p "$dir"
  echo "== $c"
  target/release/fmu-build segmented --rings "$RINGS" --seed "$SEED" --cophase --controller "$c" --out "$dir/mirror.ssp"
  target/release/inchworm run "$dir/mirror.ssp" --jobs 2 --stop-time "$STOP" "${outputs[@]}" \
    --out "$dir/run.csv" --poses "$dir/poses.csv"
  PYTHONPATH=python/inchworm_segments "$PY" -m inchworm_segments --poses "$dir/poses.csv" --out "$dir" \
    --pupil-px "$PUPIL" --frame-ms "$FRAME_MS" --workers "$WORKERS" --regulation-from "$REGULATION"
  runs+=("$c=$dir")
done
echo "== side by side"
PYTHONPATH=python/inchworm_segments "$PY" -m inchworm_segments.compare "${runs[@]}" --out "$OUT"
