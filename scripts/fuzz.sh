#!/usr/bin/env bash
# Builds the libFuzzer targets of fuzz/ with clang + ASan + UBSan (build dir: build-fuzz) and runs each
# for a bounded time.
#
#   scripts/fuzz.sh                 60 s per target (about 6 min with 5 targets, plus the build);
#                                   CI (scripts/test.sh) runs 15 s per target
#   scripts/fuzz.sh 3600            longer run: one hour per target
#   scripts/fuzz.sh 3600 fuzz_search -jobs=2 -workers=2     one target, two processes in parallel
#   scripts/fuzz.sh 0               replay the seed corpus and fuzz/regressions/ only (seconds): inputs
#                                   that once found a bug; each must pass once its bug is fixed
#   DW_FUZZ_SEED=1 scripts/fuzz.sh 15   a fixed seed and a fresh working corpus (CI's mode, set by
#                                   scripts/test.sh): runs start alike; they still drift apart, since
#                                   comparisons of heap addresses (which differ per run) steer mutations
#
# Each target grows its working corpus in build-fuzz/fuzz-corpus/<target> (seeded from the repo's
# fuzz/corpus/<name>; copy interesting new inputs back by hand) and writes crashing inputs to
# build-fuzz/fuzz-artifacts/<target>/. Reproduce one with: build-fuzz/fuzz/<target> <file>.
# A finding's log lines and its input (base64, when under 4 KiB) also go to $BUILD_DIR/fuzz-findings.txt,
# which scripts/test.sh prints after its summary, so that CI's tail shows enough to reproduce it.
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
findings="$BUILD_DIR/fuzz-findings.txt"
rm -f "$findings"
seed=()
[ -n "${DW_FUZZ_SEED:-}" ] && seed=(-seed="$DW_FUZZ_SEED")
for bin in "$BUILD_DIR"/fuzz/fuzz_*; do
  [ -x "$bin" ] || continue
  target=$(basename "$bin")
  [ -n "$ONLY" ] && [ "$ONLY" != "$target" ] && continue
  name=${target#fuzz_}
  corpus="$BUILD_DIR/fuzz-corpus/$name"
  artifacts="$BUILD_DIR/fuzz-artifacts/$name"
  if [ -n "${DW_FUZZ_SEED:-}" ]; then rm -rf "$corpus"; fi  # same start as a clean clone
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
  touch "$artifacts/.run-start"  # this run's inputs are the newer ones
  "$bin" -timeout=10 -rss_limit_mb=2048 -malloc_limit_mb=1024 -artifact_prefix="$artifacts/" \
    "${seed[@]}" "${dict[@]}" "${EXTRA_ARGS[@]}" "${args[@]}" >"$log" 2>&1
  rc=$?
  grep -E "^stat::number_of_executed_units|^Done [0-9]+ runs" "$log" | tail -1
  if [ $rc -ne 0 ]; then
    echo "!! $target failed (exit $rc); log: $log; artifacts: $artifacts"
    {
      echo "$target (exit $rc):"
      grep -m4 -E "ERROR:|DW_FUZZ_CHECK|runtime error|terminate called|refused|brute force|out-of-memory|timeout|leak" "$log"
      grep -E "^ +#[0-9]+ 0x" "$log" | grep -v -E "fuzzer::|__sanitizer|__interceptor|__libc|_start" | head -8
      find "$artifacts" -type f -newer "$artifacts/.run-start" ! -name ".*" | while read -r a; do
        if [ "$(stat -c %s "$a")" -lt 4096 ]; then
          echo "input $(basename "$a") (base64 -d > in; build-fuzz/fuzz/$target in): $(base64 -w0 "$a")"
        fi
      done
    } | tee -a "$findings"
    failed+=("$target")
  fi
done
if [ ${#failed[@]} -gt 0 ]; then
  echo "== fuzz.sh: findings in: ${failed[*]}"
  exit 1
fi
echo "== fuzz.sh: no findings"
