#!/usr/bin/env bash
# Sanitizer runs for CI.
#
#   scripts/sanitize.sh          both runs below
#   scripts/sanitize.sh asan     AddressSanitizer + UndefinedBehaviorSanitizer over the whole ctest suite
#                                (build dir build-asan; every UB is fatal: -fno-sanitize-recover=all)
#   scripts/sanitize.sh tsan     ThreadSanitizer over the concurrency tests (build dir build-tsan):
#                                concurrent queries, parallel builds, multi-threaded TIN strips and ICP
#
# Bounded: every test has ctest's per-test timeout (SANITIZE_TEST_TIMEOUT, default 900 s) and the
# whole ctest run is cut at SANITIZE_CTEST_BUDGET seconds (default 2400). JOBS (default 2) sets both
# build and ctest parallelism. Extra ctest arguments: SANITIZE_CTEST_ARGS (e.g. "-E Benchmark").
# SANITIZE_TSAN_TARGETS overrides the TSan binaries (default: every one of test_core test_robustness
# test_robustness_pcl test_search test_registration test_tin test_builder3d that exists).
# Exit status 0 only if every selected test passed.
set -uo pipefail
cd "$(dirname "$0")/.."
WHAT=${1:-all}
JOBS=${JOBS:-2}
TEST_TIMEOUT=${SANITIZE_TEST_TIMEOUT:-900}
BUDGET=${SANITIZE_CTEST_BUDGET:-2400}
export CCACHE_BASEDIR="$PWD"
status=0

# The install test builds a separate client project against the installed, instrumented library
# without the sanitizer runtime: it cannot link there, and it tests packaging, not memory safety.
EXCLUDE='^install'

# SANITIZE_SCOPE=core limits both runs to the PCL-free library and its tests (minutes instead of the
# ~30 min an instrumented PCL build takes on 2 cores): what CI runs on every submission.
SCOPE_ARGS=()
if [ "${SANITIZE_SCOPE:-all}" = core ]; then
  SCOPE_ARGS=(-DDW_WITH_PCL=OFF -DDW_WITH_MPI=OFF -DDW_BUILD_APPS=OFF)
  SANITIZE_TSAN_TARGETS=${SANITIZE_TSAN_TARGETS:-test_core test_robustness test_tin test_builder3d}
fi

configure() {  # dir sanitizers
  cmake -S . -B "$1" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDW_SANITIZE="$2" "${SCOPE_ARGS[@]}" \
    -DCMAKE_CXX_FLAGS="-fno-sanitize-recover=all" -DDW_WITH_CUDA=OFF -DDW_BUILD_BENCHMARKS=OFF \
    -DDW_BUILD_FUZZERS=OFF >/dev/null
}

run_asan() {
  local t0=$SECONDS
  echo "== ASan+UBSan: configure and build everything (build-asan)"
  configure build-asan address,undefined || return 1
  cmake --build build-asan -j "$JOBS" || return 1
  echo "== ASan+UBSan: build took $((SECONDS - t0)) s; running ctest"
  # allocator_may_return_null: an oversized allocation becomes std::bad_alloc, which the tests report
  # as a failure of the code under test, instead of aborting the whole test process.
  ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=1:strict_string_checks=1:detect_stack_use_after_return=1" \
  UBSAN_OPTIONS="print_stacktrace=1" \
    timeout "$BUDGET" ctest --test-dir build-asan --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -E "$EXCLUDE" ${SANITIZE_CTEST_ARGS:-}
  local rc=$?
  echo "== ASan+UBSan: finished in $((SECONDS - t0)) s (exit $rc)"
  return $rc
}

run_tsan() {
  local t0=$SECONDS
  echo "== TSan: configure and build the test binaries with concurrency tests (build-tsan)"
  configure build-tsan thread || return 1
  local targets=()
  local available
  available=$(cmake --build build-tsan --target help 2>/dev/null)
  for t in ${SANITIZE_TSAN_TARGETS:-test_core test_robustness test_robustness_pcl test_search test_registration test_tin test_builder3d}; do
    grep -q "^$t:" <<<"$available" && targets+=("$t")
  done
  # gtest_discover_tests runs each binary at build time, so TSan's options must already apply there.
  export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$PWD/test/robustness/sanitizer/tsan.supp"
  cmake --build build-tsan -j "$JOBS" --target "${targets[@]}" || return 1
  echo "== TSan: build took $((SECONDS - t0)) s; running the concurrency tests of: ${targets[*]}"
  # Names of the tests that run threads: concurrent queries, parallel builds/strips, multi-threaded ICP.
  local regex='[Cc]oncurren|[Tt]hread|[Pp]arallel|[Ss]trip|OMP|Omp|MultiThread|[Rr]ebuild'
  timeout "$BUDGET" ctest --test-dir build-tsan --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -R "$regex" -E "$EXCLUDE" ${SANITIZE_CTEST_ARGS:-}
  local rc=$?
  echo "== TSan: finished in $((SECONDS - t0)) s (exit $rc)"
  return $rc
}

case "$WHAT" in
  asan) run_asan || status=1 ;;
  tsan) run_tsan || status=1 ;;
  all)
    run_asan || status=1
    run_tsan || status=1
    ;;
  *) echo "usage: $0 [asan|tsan|all]"; exit 2 ;;
esac
exit $status
