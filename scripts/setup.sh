#!/usr/bin/env bash
# Installs whatever the build needs that is missing (Debian 12 packages), then configures and builds.
# Used by scripts/demo.sh and scripts/test.sh; safe to run again (installs nothing when all is present).
set -euo pipefail
cd "$(dirname "$0")/.."

PACKAGES=(build-essential cmake ninja-build ccache pkg-config
  libpcl-dev libqhull-dev libeigen3-dev libflann-dev libboost-dev
  libgtest-dev libgmock-dev libbenchmark-dev libnanoflann-dev libcgal-dev
  libopenmpi-dev openmpi-bin xvfb xauth python3 python3-matplotlib
  pybind11-dev python3-pybind11 python3-dev python3-numpy python3-scipy python3-pytest
  clang libclang-rt-14-dev libgdal-dev gdal-bin)

missing=()
for p in "${PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "== installing: ${missing[*]}"
  SUDO=""
  [ "$(id -u)" -ne 0 ] && SUDO="sudo"
  $SUDO apt-get update -q
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -q --no-install-recommends "${missing[@]}"
fi

# The LAZ codec's independent check (ctest core.las.laz_perf_check) decodes with npm's laz-perf, LASzip
# compiled to WASM; a test-only tool, kept in the git-ignored .deps/ and never linked.
if command -v npm >/dev/null 2>&1 && [ ! -d .deps/lazperf/node_modules/laz-perf ]; then
  echo "== installing laz-perf 0.0.7 (npm) into .deps/lazperf"
  mkdir -p .deps/lazperf
  (cd .deps/lazperf && { [ -f package.json ] || npm init -y >/dev/null; } && npm install --no-audit --no-fund laz-perf@0.0.7) ||
    echo "!! laz-perf not installed: core.las.laz_perf_check will be skipped"
fi

BUILD_DIR=${BUILD_DIR:-build}
export CCACHE_BASEDIR="$PWD"
export CCACHE_DIR=${CCACHE_DIR:-$HOME/.cache/ccache}
JOBS=${JOBS:-$(nproc)}
echo "== configuring ($BUILD_DIR)"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release ${CMAKE_ARGS:-}
echo "== building with $JOBS jobs"
cmake --build "$BUILD_DIR" -j "$JOBS"
