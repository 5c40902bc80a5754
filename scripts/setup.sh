#!/usr/bin/env bash
# Installs what the tests (scripts/test.sh) and the five-platform build (`fmu-build
# --all-platforms`) need on a fresh Debian machine with the Rust toolchain, on top of what
# the main job needs (scripts/setup-run.sh, which this runs): Debian's libclang-dev
# (bindgen in fmi-sys, used by the FMU import tests), binutils (nm/readelf for the symbol
# check), libtbb12 (Ecos's runtime), and a Python venv in .venv with FMPy, pytest and the
# two other SSP masters the tests run the system in: Ecos (ecospy) and OSP libcosim
# (libcosimpy); dask for python/inchworm_dask, poppy for python/inchworm_optics and hcipy
# for python/inchworm_segments.
# For the FMUs' other platforms (docs/platforms.md): Debian's Rust for its browsers
# (rustc-web, cargo-web, rust-web-src: builds the standard library for another target),
# the MinGW-w64 and aarch64 cross compilers and glibc, and Wine and qemu-user, which run
# the cross tests; from PyPI, cargo-zigbuild and ziglang (zig links the Linux and macOS
# libraries against glibc 2.17 symbol versions and Apple's libSystem stubs).
# Idempotent: it only reaches the package registries for what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

bash scripts/setup-run.sh libclang-dev binutils libtbb12 \
    rustc-web cargo-web rust-web-src gcc-mingw-w64-x86-64 gcc-aarch64-linux-gnu \
    libc6-dev-arm64-cross wine64 qemu-user

PY_REQS="fmpy==0.3.32 pytest==9.2.0 pythonfmu==0.7.0 ecospy==0.7.2 libcosimpy==0.0.6 ziglang==0.15.2 cargo-zigbuild==0.20.1"
[ -x .venv/bin/python ] || python3 -m venv .venv
# Each pin checked on its installed version, so a venv made before a pin was added (or
# with another version) gets exactly the pinned one, and a complete venv is left alone.
install_pins() {
    local missing=() req have
    for req in "$@"; do
        have=$(.venv/bin/python -c "import importlib.metadata as m, sys; print(m.version(sys.argv[1]))" "${req%%==*}" 2>/dev/null || true)
        [ "$have" = "${req##*==}" ] || missing+=("$req")
    done
    if [ ${#missing[@]} -gt 0 ]; then
        echo "setup: installing into .venv: ${missing[*]}"
        .venv/bin/pip install -q --disable-pip-version-check "${missing[@]}"
    fi
}
install_pins $PY_REQS

# Sweeps on a dask.distributed cluster (python/inchworm_dask): dask, distributed and
# pandas pinned, then the local package itself (reinstalled every time, so the venv has
# this tree's version).
DASK_REQS="dask==2024.12.1 distributed==2024.12.1 pandas==2.2.3"
if ! .venv/bin/python -c "import dask, distributed, pandas" 2>/dev/null; then
    echo "setup: installing $DASK_REQS"
    .venv/bin/pip install -q --disable-pip-version-check $DASK_REQS
fi
.venv/bin/pip install -q --disable-pip-version-check --no-deps ./python/inchworm_dask

# The optical instrument model (python/inchworm_optics): poppy 1.1.2 (1.2.0 needs Python
# 3.12, the venv's is 3.11) and what it needs, pinned, then the local package itself
# (reinstalled every time, so the venv has this tree's version).
OPTICS_REQS="poppy==1.1.2 astropy==8.0.2 scipy==1.17.1 numexpr==2.14.2 matplotlib==3.11.2 numpy==2.4.6"
install_pins $OPTICS_REQS
.venv/bin/pip install -q --disable-pip-version-check --no-deps ./python/inchworm_optics

# The segmented telescope and its coronagraph (python/inchworm_segments): hcipy 0.7.1 and
# what it needs beyond the optics' pins, pinned, then the local package itself
# (reinstalled every time, so the venv has this tree's version).
SEGMENTS_REQS="hcipy==0.7.1 asdf==6.0.0 imageio==2.38.2 xxhash==4.1.0 tqdm==4.70.1 pyyaml==6.0.4 pillow==13.0.0 importlib-metadata==10.2.0"
install_pins $SEGMENTS_REQS
.venv/bin/pip install -q --disable-pip-version-check --no-deps ./python/inchworm_segments
