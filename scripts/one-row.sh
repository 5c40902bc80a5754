#!/usr/bin/env bash
# A parameter is declared once, on its field. This adds one field, with its doc comment,
# unit, start value and range, to `PlantParams` in a scratch copy of the tracked files, and
# changes nothing else; then it checks that everything that lists the plant's parameters
# took it up: both plant FMUs' model descriptions (FMI 2.0 and 3.0, with the next value
# reference, its unit and range), the SSP parameter sets, the Python packages' variable
# names, the instance's accessors (`inchworm run --param` sets it and `--output` reads it
# back), the range check (a value outside it is refused, naming the parameter), the sweep,
# and the tests that derive their expectations from the declarations (the plant crate's and
# the FMU models').
#
# The physics does not read the new field, so a run with it set must equal the default run
# to the byte: adding a parameter disturbs nothing else.
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

fail() {
    echo "one-row: $*" >&2
    exit 1
}

git ls-files -z | xargs -0 cp --parents -t "$scratch"
params=crates/plant/src/params.rs
python3 - "$scratch/$params" <<'PY'
import sys
path = sys.argv[1]
text = open(path).read()
anchor = "    pub noise_seed: u64,\n"
field = (
    "    /// Stiffness of a mount the physics does not read (scripts/one-row.sh)\n"
    '    #[var(unit = "N/m", start = 2.0e4, min = 0.0, max = 1e9)]\n'
    "    pub one_row_stiffness: f64,\n"
)
if text.count(anchor) != 1:
    sys.exit(f"one-row: {path} has no single line {anchor.strip()!r} to add the field after")
at = text.index(anchor) + len(anchor)
open(path, "w").write(text[:at] + field + text[at:])
PY
cd "$scratch"
echo "one-row: the added field:"
git -C "$root" diff --no-index --stat -- "$root/$params" "$scratch/$params" || true
export CARGO_TARGET_DIR=$target
cargo build --release -q --locked -p inchworm
cargo run --release -q --locked -p fmu-build
inchworm=$target/release/inchworm

# The declaration's value reference: the plant's parameters are numbered from 100 in the
# order of their fields (an array takes one per element), and the new field comes after the
# last, noise_seed, in the tracked description.
last=$(grep -o 'name="noise_seed" valueReference="[0-9]*"' "$root/modelDescription/InchwormPlant.xml" |
    grep -o '[0-9]*"$' | tr -d '"') || fail "the tracked InchwormPlant.xml has no noise_seed"
vr=$((last + 1))
for md in modelDescription/{,fmi3/}InchwormPlant{,Full}.xml; do
    [ -f "$md" ] || fail "no $md in the scratch build"
    row=$(grep -A3 'name="one_row_stiffness"' "$md" | tr -s ' \n' ' ') ||
        fail "$md does not declare one_row_stiffness"
    for want in "valueReference=\"$vr\"" 'unit="N/m"' 'min="0"' 'max="1e9"' \
        'start="20000"' 'causality="parameter"' "a mount the physics does not read"; do
        case $row in *"$want"*) ;; *) fail "$md: one_row_stiffness lacks $want: $row" ;; esac
    done
done
for set in default fia20 fia6; do
    ssv=modelDescription/ssp/InchwormSystem/resources/plant.$set.ssv
    grep -q 'name="one_row_stiffness"><ssv:Real value="20000"/>' "$ssv" ||
        fail "the parameter set $set ($ssv) has no one_row_stiffness of 20000"
done
py=python/inchworm_variables/inchworm_variables/__init__.py
[ "$(grep -c '^    ONE_ROW_STIFFNESS = "one_row_stiffness"$' "$py")" = 2 ] ||
    fail "$py does not name one_row_stiffness in both plant classes"

# --param sets it on the instance, --output reads it back; the physics is undisturbed.
run() {
    "$inchworm" run dist/InchwormSystem.ssp --stop-time 0.6 --out "$1" \
        --output plant.encoder_counts --output plant.runner_position "${@:2}" >/dev/null
}
run base.csv
run new.csv --param plant.one_row_stiffness=2e6
cmp -s new.csv base.csv || fail "--param plant.one_row_stiffness=2e6 changed the physics"
"$inchworm" run dist/InchwormSystem.ssp --stop-time 0.01 --out read.csv \
    --output plant.one_row_stiffness --param plant.one_row_stiffness=2e6 >/dev/null
[ "$(tail -1 read.csv)" = "0.01,2000000" ] ||
    fail "--param plant.one_row_stiffness=2e6 did not reach the instance: $(tail -1 read.csv)"

# Out of its declared range: refused, naming the parameter and the range.
if "$inchworm" run dist/InchwormSystem.ssp --stop-time 0.01 --out refused.csv \
    --param plant.one_row_stiffness=-1 >refused.log 2>&1; then
    fail "--param plant.one_row_stiffness=-1 (below its declared 0) was accepted"
fi
grep -q 'one_row_stiffness: must be within \[0e0, 1e9\] N/m' refused.log ||
    fail "the refusal of one_row_stiffness=-1 does not name it and its range: $(cat refused.log)"
[ ! -e refused.csv ] || fail "the refused run wrote refused.csv"

# The sweep: two points, each reading back the value it set.
sweep=$("$inchworm" sweep dist/InchwormSystem.ssp --stop-time 0.01 --jobs 1 --json \
    --metric final:plant.one_row_stiffness --grid 'plant.one_row_stiffness=2e4;2e6')
for v in 20000 2000000; do
    echo "$sweep" | grep -q "\"final:plant.one_row_stiffness\":$v}" ||
        fail "the sweep has no point reading one_row_stiffness = $v: $sweep"
done

# The tests whose expectations come from the declarations: counts, value references,
# starts and ranges of every parameter, the new one included.
cargo test --release -q --locked -p inchworm-plant --lib
cargo test --release -q --locked -p inchworm-fmu-models --lib
echo "one-row: one_row_stiffness, added as one declared field, is in both model descriptions (vr $vr), the SSP parameter sets, the accessors, the range check, --param and the sweep, and the declaration tests pass"
