#!/usr/bin/env bash
# The README's test command (and CI's, through .ci/run). In order:
#   1. set up: install missing packages, Release build of everything (scripts/setup.sh, build dir
#      BUILD_DIR, default build): apps, benchmarks and the GPU module must at least compile;
#   2. AddressSanitizer + UndefinedBehaviorSanitizer over the WHOLE ctest suite (scripts/sanitize.sh asan);
#   3. ThreadSanitizer over every concurrency test, PCL-free and PCL side (scripts/sanitize.sh tsan);
#   4. a short bounded fuzz run of every libFuzzer target (scripts/fuzz.sh, DW_FUZZ_SECONDS, default 15 s);
#   5. the whole ctest suite in the Release build (optimised code is what users run: exactness must
#      hold there too, and the install test runs only here).
# Every step runs even when an earlier one failed; the exit status is 0 only if all passed, and a
# summary with each step's time ends the log. DW_SKIP_SANITIZERS=1 skips steps 2-4.
# Cost on the 2-core dev machine (cold and warm ccache): docs/robustness.md, "CI cost".
set -uo pipefail
cd "$(dirname "$0")/.."
BUILD_DIR=${BUILD_DIR:-build}
export JOBS=${JOBS:-$(nproc)}
summary=()
failed=0
step() {  # name command...
  local name=$1 t0=$SECONDS rc
  shift
  echo "== [$name] $*"
  "$@"
  rc=$?
  summary+=("$(printf '%-14s %5d s  %s' "$name" $((SECONDS - t0)) "$([ $rc = 0 ] && echo ok || echo "FAILED ($rc)")")")
  [ $rc = 0 ] || failed=1
  return 0
}

findings="${FUZZ_BUILD_DIR:-build-fuzz}/fuzz-findings.txt"
rm -f "$findings"  # only this run's findings are printed at the end
step setup bash scripts/setup.sh
if [ "$failed" = 0 ]; then
  if [ "${DW_SKIP_SANITIZERS:-0}" != 1 ]; then
    step asan+ubsan bash scripts/sanitize.sh asan
    step tsan bash scripts/sanitize.sh tsan
    # A fixed seed and a fresh corpus, so runs start alike (scripts/fuzz.sh); long runs are separate.
    DW_FUZZ_SEED=${DW_FUZZ_SEED:-1} step fuzz bash scripts/fuzz.sh "${DW_FUZZ_SECONDS:-15}"
  fi
  step ctest ctest --test-dir "$BUILD_DIR" --output-on-failure -j "$JOBS" --timeout 900
  # The Python package's tests (python/tests); pytest's exit 5 (no test collected) fails the step too.
  step pytest bash -c ". '$BUILD_DIR/python/test_env.sh' && \"\$DW_PYTHON\" -m pytest -q python/tests"
fi

echo "== summary"
printf '%s\n' "${summary[@]}"
# A fuzz finding's details, last, where a truncated CI log still shows them.
if [ -s "$findings" ]; then
  echo "== fuzz findings"
  cat "$findings"
fi
exit $failed
