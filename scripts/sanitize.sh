#!/usr/bin/env bash
# Sanitizer runs for CI (scripts/test.sh runs both).
#
#   scripts/sanitize.sh          both runs below
#   scripts/sanitize.sh asan     AddressSanitizer + UndefinedBehaviorSanitizer over the WHOLE ctest suite
#                                (build dir build-asan; every UB is fatal: -fno-sanitize-recover=all)
#   scripts/sanitize.sh tsan     ThreadSanitizer over the concurrency tests, PCL-free and PCL side
#                                (build dir build-tsan): concurrent queries on one graph / one
#                                pcl::search::DelaunayWalk, multi-threaded correspondence estimation
#                                and ICP, rebuilds beside queries, parallel builders and TIN strips
#                                (not OpenMP code: see run_tsan)
#
# What keeps the whole-suite ASan run affordable on 2 cores (docs/robustness.md, "CI cost"):
#   - -O1 -g1 instead of RelWithDebInfo's -O2 -g: the PCL-heavy translation units dominate the build and
#     full debug info of PCL's templates costs more than the code itself; -g1 still gives file:line in
#     every sanitizer report;
#   - only what the suite runs is built: every test binary plus exactly the apps that a ctest test runs
#     (read from ctest's own test list), so no benchmarks, no dw_bench, no CUDA;
#   - debug info is made path-independent (-fdebug-prefix-map, CCACHE_NOHASHDIR) so ccache hits across
#     clones.
#
# Bounded: every test has ctest's per-test timeout (SANITIZE_TEST_TIMEOUT, default 900 s) and each
# whole ctest run is cut at SANITIZE_CTEST_BUDGET seconds (default 2400). JOBS (default 2) sets both
# build and ctest parallelism. Extra ctest arguments: SANITIZE_CTEST_ARGS.
# SANITIZE_TSAN_TARGETS overrides the TSan binaries (default: each test_core_* binary and
# test_pcl_robustness, test_pcl_search, test_pcl_registration, those that exist).
# ASAN_BUILD_DIR / TSAN_BUILD_DIR override the build dirs (default build-asan, build-tsan).
# SANITIZE_SCOPE=core limits both runs to the PCL-free library and its tests (a quick local check).
# Exit status 0 only if every selected test passed.
set -uo pipefail
cd "$(dirname "$0")/.."
WHAT=${1:-all}
JOBS=${JOBS:-2}
TEST_TIMEOUT=${SANITIZE_TEST_TIMEOUT:-900}
BUDGET=${SANITIZE_CTEST_BUDGET:-2400}
export CCACHE_BASEDIR="$PWD"
export CCACHE_NOHASHDIR=1
SUPP_DIR="$PWD/test/core/robustness/sanitizer"
ASAN_DIR=${ASAN_BUILD_DIR:-build-asan}
TSAN_DIR=${TSAN_BUILD_DIR:-build-tsan}
status=0

# The install test builds a separate client project against the installed, instrumented library
# without the sanitizer runtime: it cannot link there, and it tests packaging, not memory safety
# (the Release suite runs it).
EXCLUDE='^install'

TSAN_CORE_TARGETS="test_core_graph test_core_search test_core_geometry test_core_builder3d test_core_tin test_core_las test_core_util test_core_robustness"
TSAN_PCL_TARGETS="test_pcl_robustness test_pcl_search test_pcl_registration"

# Options named explicitly both ways: a build dir keeps cached options from an earlier scope.
SCOPE_ARGS=(-DDW_WITH_PCL=ON -DDW_WITH_MPI=ON -DDW_BUILD_APPS=ON)
if [ "${SANITIZE_SCOPE:-all}" = core ]; then
  SCOPE_ARGS=(-DDW_WITH_PCL=OFF -DDW_WITH_MPI=OFF -DDW_BUILD_APPS=OFF)
  SANITIZE_TSAN_TARGETS=${SANITIZE_TSAN_TARGETS:-$TSAN_CORE_TARGETS}
fi

configure() {  # dir sanitizers multiversioning(ON|OFF)
  cmake -S . -B "$1" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DDW_SANITIZE="$2" "${SCOPE_ARGS[@]}" \
    -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" -DCMAKE_C_FLAGS_RELWITHDEBINFO="-O1 -g1 -DNDEBUG" \
    -DCMAKE_CXX_FLAGS="-fno-sanitize-recover=all -fdebug-prefix-map=$PWD=." \
    -DDW_WITH_CUDA=OFF -DDW_BUILD_BENCHMARKS=OFF -DDW_BUILD_FUZZERS=OFF -DDW_MULTIVERSIONING="$3" >/dev/null
}

# Targets the ctest suite of build dir $1 needs: every test_* binary, plus every other target whose
# output file a registered test runs or passes to a script (apps run by app tests: dw_graph, dw_icp,
# dw_tin, dw_viewer, ...). Read before the build: gtest's discovered tests appear only after it, but
# their binaries are the test_* targets.
suite_targets() {
  local dir=$1
  local available
  available=$(cmake --build "$dir" --target help 2>/dev/null | sed -n 's/^\([A-Za-z0-9_]*\): .*/\1/p')
  {
    grep -E '^test_' <<<"$available"
    ctest --test-dir "$dir" -N --show-only=json-v1 2>/dev/null |
      python3 -c '
import json, os, sys
names = set()
for t in json.load(sys.stdin).get("tests", []):
    for arg in t.get("command", []) or []:
        names.add(os.path.basename(arg.split("=", 1)[-1]))
print("\n".join(sorted(names)))' | grep -Fxf <(printf '%s\n' "$available")
    # In a fresh build dir ctest cannot resolve a test's executable before it is built and leaves it
    # out of the JSON above, so the apps are also read from the generated test files themselves.
    grep -rhoE '/(apps|bench)/dw_[A-Za-z0-9_]+' "$dir" --include=CTestTestfile.cmake 2>/dev/null | sed 's|.*/||' |
      grep -Fxf <(printf '%s\n' "$available")
  } | grep -E '^(test_|dw_)' | sort -u  # a test argument may share a name with a utility target (clean)
}

run_asan() {
  local t0=$SECONDS
  echo "== ASan+UBSan: configure and build the whole test suite ($ASAN_DIR)"
  # The 3D kernel's insertion in its baseline version only: the Release suite runs its x86-64-v3
  # version on any AVX2 machine, so this run keeps the other one tested.
  configure "$ASAN_DIR" address,undefined OFF || return 1
  local targets
  mapfile -t targets < <(suite_targets "$ASAN_DIR")
  [ ${#targets[@]} -gt 0 ] || { echo "!! no test targets found in $ASAN_DIR"; return 1; }
  echo "   targets: ${targets[*]}"
  # allocator_may_return_null: an oversized allocation becomes std::bad_alloc, which the tests report
  # as a failure of the code under test, instead of aborting the whole test process.
  export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=1:strict_string_checks=1:detect_stack_use_after_return=1"
  export UBSAN_OPTIONS="print_stacktrace=1:suppressions=$SUPP_DIR/ubsan.supp"
  # -k 0: one target that fails to build must not hide what every other test says (its tests then
  # show up as not run, and the step fails).
  cmake --build "$ASAN_DIR" -j "$JOBS" --target "${targets[@]}" -- -k 0
  local build_rc=$?
  local t1=$SECONDS
  echo "== ASan+UBSan: build took $((t1 - t0)) s (exit $build_rc); running ctest"
  # Two grid tests spend nearly all their time in the exact predicates, whose large stack frames
  # detect_stack_use_after_return moves to ASan's fake stack: alone, 375 s instead of 11 s
  # (CospericalGridAndQuantisedTies) and 179 s instead of 5 s (IntegerGrid), half of this stage. They
  # run with that one check off, ASan's other checks and UBSan on; every other test keeps it, and
  # the same kernel code runs under it in the other parallel-insertion tests.
  local uar_slow='^core[.]builder3d[.](PartitionedInsertion[.]CospericalGridAndQuantisedTies|BlockParallel[.]IntegerGrid)$'
  # Debian's libpcl 1.13 is compiled as C++14, where Eigen's EIGEN_MAKE_ALIGNED_OPERATOR_NEW gives
  # pcl::PointCloud a class operator new on std::malloc; in our C++17 code that macro is empty, so a
  # cloud the library news (CorrespondenceRejectorMedianDistance::setSourcePoints) is freed by the
  # shared_ptr deleter instantiated here with the global operator delete. glibc frees both alike; ASan
  # reports the pairing. Only the tests that drive such library-allocated clouds run without that check.
  local pcl_cxx14_new='^pcl[.]compat[.]RegistrationCompat[.]WithRejectors$'
  timeout "$BUDGET" ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -E "$EXCLUDE|^mpi[.]run[.]|$uar_slow|$pcl_cxx14_new" ${SANITIZE_CTEST_ARGS:-}
  local rc=$?
  ASAN_OPTIONS="$ASAN_OPTIONS:alloc_dealloc_mismatch=0" \
    timeout "$BUDGET" ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -R "$pcl_cxx14_new" -E "$EXCLUDE" ${SANITIZE_CTEST_ARGS:-} || rc=1
  ASAN_OPTIONS="${ASAN_OPTIONS/detect_stack_use_after_return=1/detect_stack_use_after_return=0}" \
    timeout "$BUDGET" ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -R "$uar_slow" -E "$EXCLUDE" ${SANITIZE_CTEST_ARGS:-} || rc=1
  # The mpirun tests without leak checking: OpenMPI's runtime (libopen-pal, libmpi and the MCA plugins
  # it dlopen()s and unloads before exit, so their frames cannot even be named in a suppression) leaks
  # at exit in every rank. Memory errors and UB in the ranks are still fatal.
  ASAN_OPTIONS="$ASAN_OPTIONS:detect_leaks=0" \
    timeout "$BUDGET" ctest --test-dir "$ASAN_DIR" --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -R "^mpi[.]run[.]" -E "$EXCLUDE" ${SANITIZE_CTEST_ARGS:-} || rc=1
  echo "== ASan+UBSan: ctest took $((SECONDS - t1)) s, total $((SECONDS - t0)) s (exit $rc)"
  [ $build_rc = 0 ] || rc=1
  return $rc
}

run_tsan() {
  local t0=$SECONDS
  echo "== TSan: configure and build the test binaries with concurrency tests ($TSAN_DIR)"
  configure "$TSAN_DIR" thread ON || return 1
  local targets=()
  local available
  available=$(cmake --build "$TSAN_DIR" --target help 2>/dev/null)
  for t in ${SANITIZE_TSAN_TARGETS:-$TSAN_CORE_TARGETS $TSAN_PCL_TARGETS}; do
    grep -q "^$t:" <<<"$available" && targets+=("$t")
  done
  # gtest_discover_tests runs each binary at build time, so TSan's options must already apply there.
  export TSAN_OPTIONS="halt_on_error=1:second_deadlock_stack=1:suppressions=$SUPP_DIR/tsan.supp"
  cmake --build "$TSAN_DIR" -j "$JOBS" --target "${targets[@]}" -- -k 0
  local build_rc=$?
  local t1=$SECONDS
  echo "== TSan: build took $((t1 - t0)) s (exit $build_rc); running the concurrency tests of: ${targets[*]}"
  # Names of the tests that run threads: concurrent queries, parallel builds/strips, multi-threaded ICP.
  local regex='[Cc]oncurren|[Tt]hread|[Pp]arallel|[Ss]trip|MultiThread|[Rr]ebuild'
  # Not the tests that run PCL's OpenMP algorithms (NormalEstimationOMP): GCC's libgomp is not built
  # with TSan, so the barrier that ends every parallel region is invisible to it and it reports the
  # accesses that barrier orders (docs/robustness.md, "Why no OpenMP test under TSan"). The same query
  # pattern runs on std::thread in the tests above (pcl.search.DelaunayWalkApi.ConcurrentQueriesAreExact,
  # pcl.robustness.PclConcurrency.*); ASan and the Release suite still run the OpenMP tests. Not the
  # apps' tests either (apps.dem.stream_*_strip): this build holds the test binaries above, no apps.
  timeout "$BUDGET" ctest --test-dir "$TSAN_DIR" --output-on-failure -j "$JOBS" --timeout "$TEST_TIMEOUT" \
      -R "$regex" -E "$EXCLUDE|NormalEstimationOmp|^apps[.]" ${SANITIZE_CTEST_ARGS:-}
  local rc=$?
  echo "== TSan: ctest took $((SECONDS - t1)) s, total $((SECONDS - t0)) s (exit $rc)"
  [ $build_rc = 0 ] || rc=1
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
