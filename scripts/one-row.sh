#!/usr/bin/env bash
# A parameter is one row of its model's variable table: everything else comes from the
# table. This adds one row to the plant's table in a scratch copy of the tracked files,
# and nothing else, then checks that the new parameter is in the plant FMUs' model descriptions,
# in the SSP parameter sets, settable with `inchworm run --param` and sweepable with
# `inchworm sweep`, and that it reaches the physics.
#
# The row, `one_row_stiffness`, is the environment stiffness `k_e` under a second name, so
# that its effect is known: a run with it set must equal a run with `k_e` set.
#
# Builds in its own target folder (default target/one-row), so that nothing of the
# project's own build is replaced. A first run seeds it with a copy of the project's release
# build: the registry's crates are reused, and the workspace's crates rebuild, since every
# file of the scratch copy is newer than what was built from the tracked ones.
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
target=${ONE_ROW_TARGET:-$root/target/one-row}
project_target=${CARGO_TARGET_DIR:-$root/target}
if [ ! -d "$target/release" ] && [ -d "$project_target/release" ]; then
    mkdir -p "$target"
    cp -a --reflink=auto "$project_target/release" "$target/"
fi
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

git ls-files -z | xargs -0 cp --parents -t "$scratch"
table=crates/fmu-models/src/plant/table.rs
python3 - "$scratch/$table" <<'EOF'
import sys
path = sys.argv[1]
text = open(path).read()
anchor = "        NOISE_SEED: "
row = (
    '        ONE_ROW_STIFFNESS: Variable::parameter("one_row_stiffness", 133, 2.0e4, Some("N/m"), '
    '"The environment stiffness k_e under a second name (scripts/one-row.sh)")'
    ".with_range(0.0, 1e9).real(|m| m.params.k_e, |m, x| m.params.k_e = x),\n"
)
at = text.index(anchor)
open(path, "w").write(text[:at] + row + text[at:])
EOF
cd "$scratch"
echo "one-row: the added row:"
git -C "$root" diff --no-index --stat -- "$root/$table" "$scratch/$table" || true
export CARGO_TARGET_DIR=$target
cargo build --release -q --locked -p inchworm
cargo run --release -q --locked -p fmu-build
inchworm=$target/release/inchworm

fail() {
    echo "one-row: $*" >&2
    exit 1
}
for md in modelDescription/{,fmi3/}InchwormPlant{,Full}.xml; do
    [ -f "$md" ] || fail "no $md in the scratch build"
    grep -q 'name="one_row_stiffness"' "$md" || fail "$md does not declare one_row_stiffness"
done
for set in default fia20 fia6; do
    ssv=modelDescription/ssp/InchwormSystem/resources/plant.$set.ssv
    grep -q 'name="one_row_stiffness"><ssv:Real value="20000"/>' "$ssv" ||
        fail "the parameter set $set ($ssv) has no one_row_stiffness of 20000"
done

# --param: the new name sets k_e, so the two runs agree to the byte, and differ from the
# default run.
run() {
    "$inchworm" run dist/InchwormSystem.ssp --stop-time 0.6 --out "$1" \
        --output plant.encoder_counts --output plant.runner_position "${@:2}" >/dev/null
}
run base.csv
run new.csv --param plant.one_row_stiffness=2e6
run k_e.csv --param plant.k_e=2e6
cmp -s new.csv k_e.csv || fail "--param plant.one_row_stiffness=2e6 differs from --param plant.k_e=2e6"
cmp -s new.csv base.csv && fail "--param plant.one_row_stiffness=2e6 changed nothing"

# The sweep: the same two points by either name, the same metrics.
sweep() {
    "$inchworm" sweep dist/InchwormSystem.ssp --stop-time 0.6 --jobs 1 --json \
        --metric final:plant.encoder_position --grid "$1" | sed 's/"plant\.[a-z_]*"/"p"/g'
}
a=$(sweep 'plant.one_row_stiffness=2e4;2e6')
b=$(sweep 'plant.k_e=2e4;2e6')
[ "$a" = "$b" ] || fail "the sweep over one_row_stiffness differs from the sweep over k_e:
$a
$b"
[ "$(echo "$a" | sort -u | wc -l)" = 2 ] || fail "the sweep's two points gave the same result: $a"
echo "one-row: one_row_stiffness, added as one table row, is in both model descriptions, the SSP parameter sets, --param and the sweep"
