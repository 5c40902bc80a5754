#!/usr/bin/env bash
# Proof on an older system (docs/platforms.md): makes a Debian 11 root (glibc 2.31) with
# debootstrap from the Debian package registry, builds tests/cross/harness.c there with
# its own gcc, and runs the check trace through dist/InchwormPlant.fmu and the Fig. 5
# loop (full control and feedback only) through both FMI 2.0 FMUs inside it and on this
# machine, then compares: the check trace within 1 count, the settle times equal.
#
#   bash scripts/debian11.sh           # after `cargo run --release -p fmu-build`
#
# Needs root (debootstrap, chroot). Slow the first time (the root is about 430 MB, made
# once under ${INCHWORM_DEBIAN11_ROOT:-~/.cache/inchworm/debian11}), so not in test.sh.
set -euo pipefail
cd "$(dirname "$0")/.."
root="${INCHWORM_DEBIAN11_ROOT:-${XDG_CACHE_HOME:-$HOME/.cache}/inchworm/debian11}"
[ -f dist/InchwormPlant.fmu ] && [ -f dist/InchwormController.fmu ] || {
    echo "debian11: dist/ has no FMUs: run cargo run --release -p fmu-build first" >&2
    exit 1
}
if [ ! -x "$root/usr/bin/gcc" ]; then
    if ! command -v debootstrap >/dev/null; then
        apt-get update -qq
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null
    fi
    rm -rf "$root"
    mkdir -p "$(dirname "$root")"
    echo "debian11: making a Debian 11 (bullseye) root in $root"
    debootstrap --variant=minbase --include=gcc,libc6-dev bullseye "$root" http://deb.debian.org/debian
fi
exec python3 tests/cross/cross.py debian11 "$root"
