#!/usr/bin/env bash
# Configures (first time) and builds COLMAP 4.1.1 with colmap_ext into build/.
# The binary is build/colmap. Incremental: a second run rebuilds only what
# changed (ccache keeps COLMAP's objects across clean builds too).
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
# ccache's keys relative to the checkout, so that another clone reuses them.
export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$(pwd)}
if [ ! -f "$BUILD_DIR/build.ninja" ]; then
  cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release
fi
cmake --build "$BUILD_DIR" -j "${BUILD_JOBS:-$(nproc)}"
