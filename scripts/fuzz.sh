#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang + ASan + UBSan (build dir: build-fuzz) and runs each
# for a bounded time.
#
#   scripts/fuzz.sh                 CI run: 60 s per target (about 6 min with 5 targets, plus the build)
#   scripts/fuzz.sh 3600            longer run: one hour per target
#   scripts/fuzz.sh 3600 fuzz_search -jobs=2 -workers=2     one target, two processes in parallel
#   scripts/fuzz.sh 0               replay the seed corpus and fuzz/regressions/ only (seconds): inputs
#                                   that once found a bug; each must pass once its bug is fixed
#
# Each target grows its working corpus in build-fuzz/fuzz-corpus/<target> (seeded from the repo's
# fuzz/corpus/<name>; copy interesting new inputs back by hand) and writes crashing inputs to
# build-fuzz/fuzz-artifacts/<target>/. Reproduce one with: build-fuzz/fuzz/<target> <file>.
# Exit status: 0 when no target found a crash, hang (> 10 s on one input), leak or oversized
# allocation (> 1 GiB at once), 1 otherwise. UBSan findings already reported are suppressed by
# fuzz/known_bugs.supp so a run keeps searching past them.
set -uo pipefail
cd "$(dirname "$0")/.."
SECONDS_PER_TARGET=${1:-60}
ONLY=${2:-}
shift $(( $# > 2 ? 2 : $# ))
EXTRA_ARGS=("$@")
BUILD_DIR=${FUZZ_BUILD_DIR:-build-fuzz}
JOBS=${JOBS:-2}

command -v clang++ >/dev/null || { echo "fuzz.sh: clang++ not found (apt-get install clang libclang-rt-14-dev)"; exit 2; }
export CCACHE_BASEDIR="$PWD"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DDW_BUILD_FUZZERS=ON -DDW_SANITIZE=address,undefined \
  -DDW_WITH_PCL=OFF -DDW_WITH_CUDA=OFF -DDW_WITH_MPI=OFF -DDW_BUILD_APPS=OFF -DDW_BUILD_BENCHMARKS=OFF \
  -DBUILD_TESTING=OFF >/dev/null || exit 2
cmake --build "$BUILD_DIR" --target fuzzers -j "$JOBS" || exit 2

export UBSAN_OPTIONS="halt_on_error=1:print_stacktrace=1:suppressions=$PWD/fuzz/known_bugs.supp"
export ASAN_OPTIONS="detect_leaks=1:allocator_may_return_null=0"
failed=()
for bin in "$BUILD_DIR"/fuzz/fuzz_*; do
  [ -x "$bin" ] || continue
  target=$(basename "$bin")
  [ -n "$ONLY" ] && [ "$ONLY" != "$target" ] && continue
  name=${target#fuzz_}
  corpus="$BUILD_DIR/fuzz-corpus/$name"
  artifacts="$BUILD_DIR/fuzz-artifacts/$name"
  mkdir -p "$corpus" "$artifacts"
  seeds=()
  [ -d "fuzz/corpus/$name" ] && seeds=("fuzz/corpus/$name")
  dict=()
  [ -f "fuzz/$name.dict" ] && dict=(-dict="fuzz/$name.dict")
  if [ "$SECONDS_PER_TARGET" = 0 ]; then
    [ -d "fuzz/regressions/$name" ] && seeds+=("fuzz/regressions/$name")
    args=(-runs=0 "${seeds[@]}")
  else
    args=(-max_total_time="$SECONDS_PER_TARGET" -print_final_stats=1 "$corpus" "${seeds[@]}")
  fi
  echo "== $target (${SECONDS_PER_TARGET}s)"
  log="$BUILD_DIR/fuzz-artifacts/$name.log"
  "$bin" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 -artifact_prefix="$artifacts/" \
    "${dict[@]}" "${EXTRA_ARGS[@]}" "${args[@]}" >"$log" 2>&1
  rc=$?
  grep -E "^stat::number_of_executed_units|^Done [0-9]+ runs" "$log" | tail -1
  if [ $rc -ne 0 ]; then
    echo "!! $target failed (exit $rc); log: $log; artifacts: $artifacts"
    grep -m3 -E "ERROR:|DW_FUZZ_CHECK|runtime error|terminate called|refused|brute force|out-of-memory|timeout" "$log"
    failed+=("$target")
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "== fuzz.sh: findings in: ${failed[*]}"
  exit 1
fi
echo "== fuzz.sh: no findings"
