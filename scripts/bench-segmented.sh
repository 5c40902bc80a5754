#!/usr/bin/env bash
# The segmented mirrors of `fmu-build segmented` on one thread and on two, side by side
# in one run (docs/segmented.md §3): for each ring count, the runs alternate --jobs 1 and
# --jobs 2 REPEAT times; each row is one run's wall time (the whole process: unpacking,
# instantiation, initialisation, stepping and the CSV), its real-time factor, its CPU time
# (user + system, all threads), its largest resident set per actuator (/usr/bin/time) and
# the 1-minute load average after it; each ring count ends with the ratio of the fastest
# one-thread run to the fastest two-thread run. Each repeat also runs the two parts of
# `--jobs 2` alone as processes (`--part 1/2`, `--part 2/2`, jobs `p1`, `p2`), and prints
# the one-thread run's CPU time over the larger part's: what two idle cores could gain,
# read from CPU times, which a loaded host changes far less than wall times. Every run records each mount's piston, tip and tilt, and
# the two runs' CSVs are compared byte for byte.
#
# Usage: scripts/bench-segmented.sh [RINGS …]  (default: 1 3 16)
# Environment: STOP (simulated seconds, default 10), REPEAT (default 3), SEED (default 1),
# OUT (default out/bench-segmented). Needs `cargo run --release -p fmu-build` (dist/) and
# `cargo build --release -p fmu-build -p inchworm`.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
bin=${CARGO_TARGET_DIR:-$root/target}/release
stop=${STOP:-10}
repeat=${REPEAT:-3}
seed=${SEED:-1}
out=${OUT:-$root/out/bench-segmented}
rings=("$@")
[ ${#rings[@]} -gt 0 ] || rings=(1 3 16)
mkdir -p "$out"

echo "host: $(nproc) cores, $(uname -srm); load average at start: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "stop time ${stop} s, seed ${seed}, ${repeat} runs per thread count"
printf '%-6s %-9s %-10s %-5s %-9s %-8s %-8s %-14s %s\n' rings segments actuators jobs "wall (s)" "x real" "CPU (s)" "RSS/act (KiB)" "load"
for r in "${rings[@]}"; do
    ssp="$out/mirror$r.ssp"
    "$bin/fmu-build" segmented --rings "$r" --seed "$seed" --out "$ssp" >/dev/null
    segments=$((3 * r * (r + 1) + 1))
    actuators=$((3 * segments))
    outputs=()
    for ((k = 0; k < segments; k++)); do
        outputs+=(--output "seg${k}_mount.piston" --output "seg${k}_mount.tip" --output "seg${k}_mount.tilt")
    done
    declare -A best=()
    for ((i = 0; i < repeat; i++)); do
        declare -A cpu=()
        for jobs in 1 2 p1 p2; do
            csv="$out/mirror${r}_jobs$jobs.csv"
            case $jobs in
                p1) how=(--part 1/2) ;;
                p2) how=(--part 2/2) ;;
                *) how=(--jobs "$jobs") ;;
            esac
            stats=$( { /usr/bin/time -f '%e %U %S %M' "$bin/inchworm" run "$ssp" --stop-time "$stop" \
                "${how[@]}" "${outputs[@]}" --out "$csv" >/dev/null; } 2>&1 | tail -1)
            read -r wall user sys rss <<<"$stats"
            cpu[$jobs]=$(echo "$user + $sys" | bc -l)
            load=$(cut -d' ' -f1 /proc/loadavg)
            printf '%-6s %-9s %-10s %-5s %-9s %-8s %-8s %-14s %s\n' "$r" "$segments" "$actuators" "$jobs" "$wall" \
                "$(echo "$stop / $wall" | bc -l | xargs printf '%.3g')" "$(echo "$user + $sys" | bc -l)" \
                "$(echo "$rss / $actuators" | bc -l | xargs printf '%.0f')" "$load"
            if [ -z "${best[$jobs]:-}" ] || (($(echo "$wall < ${best[$jobs]}" | bc -l))); then
                best[$jobs]=$wall
            fi
        done
        larger=$(echo "if (${cpu[p1]} > ${cpu[p2]}) ${cpu[p1]} else ${cpu[p2]}" | bc -l)
        echo "rings $r, repeat $((i + 1)): one-thread CPU / larger part's CPU = $(echo "${cpu[1]} / $larger" | bc -l | xargs printf '%.2f')"
        unset cpu
        cmp -s "$out/mirror${r}_jobs1.csv" "$out/mirror${r}_jobs2.csv" \
            || { echo "rings $r: the CSVs of --jobs 1 and --jobs 2 differ" >&2; exit 1; }
    done
    echo "rings $r: fastest one-thread / fastest two-thread wall time = $(echo "${best[1]} / ${best[2]}" | bc -l | xargs printf '%.2f'); CSVs of --jobs 1 and 2 identical"
    unset best
done
echo "load average at end: $(cut -d' ' -f1-3 /proc/loadavg)"
