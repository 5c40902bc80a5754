#!/usr/bin/env bash
# Installs what the main job (scripts/run.sh) needs on a fresh Debian machine with the Rust
# toolchain: Debian's fonts-dejavu-core, the face the plots' labels are drawn with
# (crates/scenarios/src/plot.rs reads it at run time). Nothing else: the host's FMUs and the
# `inchworm` master are built by rustup's toolchain and linked, like crates/fmi-import's C
# logger is compiled, by the C compiler that toolchain already needs.
# Debian package names given as arguments are installed in the same apt run
# (scripts/setup.sh passes the tests' and the other platforms' ones).
# Idempotent: it reaches Debian's registry only for what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

if ! command -v cc >/dev/null; then
    echo "setup: no C compiler (cc): Rust links with it; on Debian: apt-get install gcc" >&2
    exit 1
fi

need=()
for pkg in fonts-dejavu-core "$@"; do
    dpkg -s "$pkg" >/dev/null 2>&1 || need+=("$pkg")
done
if [ ${#need[@]} -gt 0 ]; then
    echo "setup: installing Debian packages: ${need[*]}"
    SUDO=""
    [ "$(id -u)" -ne 0 ] && SUDO="sudo"
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq "${need[@]}" >/dev/null
fi
