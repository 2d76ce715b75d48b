#!/usr/bin/env bash
# The README's test command: set up (install missing packages, build), then
#   1. AddressSanitizer+UndefinedBehaviorSanitizer and ThreadSanitizer over the PCL-free suite
#      (scripts/sanitize.sh; the whole instrumented suite, PCL included, is `scripts/sanitize.sh all`,
#      ~30 min on 2 cores),
#   2. a short bounded fuzz run of every libFuzzer target (scripts/fuzz.sh, 15 s each),
#   3. the whole ctest suite.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
BUILD_DIR=${BUILD_DIR:-build}
if [ "${DW_SKIP_SANITIZERS:-0}" != 1 ]; then
  echo "== sanitizers over the PCL-free suite"
  SANITIZE_SCOPE=core bash scripts/sanitize.sh all
  echo "== bounded fuzz run"
  bash scripts/fuzz.sh "${DW_FUZZ_SECONDS:-15}"
fi
echo "== running the test suite"
ctest --test-dir "$BUILD_DIR" --output-on-failure -j "${JOBS:-$(nproc)}" --timeout 900
