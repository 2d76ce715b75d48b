#!/usr/bin/env bash
# The README's test command: set up (install missing packages, build), then run the whole ctest suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD_DIR=${BUILD_DIR:-build}
echo "== running the test suite"
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "${JOBS:-$(nproc)}" --timeout 900
