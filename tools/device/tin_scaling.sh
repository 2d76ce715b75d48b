#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried (Qhull for
# the core's reference tests): builds the PCL-free TIN targets, runs the TIN tests, and measures the
# parallel TIN's thread scaling on synthetic airborne tiles generated there (never carried). Logs go to
# $OUT (or ./out).
#   usage: tools/device/tin_scaling.sh [SIZE...]     (default: 2.1M 10M 21M)
#   DW_TIN_SWEEP=1: instead of the two-core and strip-count runs, sweep the strip count on 16 threads
#   for every size (to choose the automatic count).
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-tin}
SIZES=("$@")
[ ${#SIZES[@]} -gt 0 ] || SIZES=(2.1M 10M 21M)
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/tin_machine.txt"
device_cpu_build "$ROOT" "$BUILD" tin dw_tin_scaling test_core_tin || exit 1

timeout 120 "$BUILD/test/test_core_tin" > "$OUT/test_core_tin.log" 2>&1
echo "test_core_tin exit $? ($(grep -c '^\[       OK' "$OUT/test_core_tin.log") ok, $(grep -c '^\[  FAILED' "$OUT/test_core_tin.log") failed lines)"

S="$BUILD/bench/dw_tin_scaling"
rc=0
for n in "${SIZES[@]}"; do
  echo "== $n points, 1-16 threads (automatic strips), best of 3"
  timeout 200 "$S" -n "$n" --threads 1,2,4,8,16 --repeats 3 2>&1 | tee "$OUT/tin_scaling_$n.txt" || rc=1
done
if [ "${DW_TIN_SWEEP:-0}" = 1 ]; then
  for n in "${SIZES[@]}"; do
    echo "== $n points, 16 threads, strip counts, best of 3"
    timeout 100 "$S" -n "$n" --threads 16 --strips 0,16,48,64 --repeats 3 2>&1 | tee "$OUT/tin_sweep_$n.txt" || rc=1
  done
  exit $rc
fi
# Two otherwise idle cores of the device: the 1 -> 2 thread ratio without other users' load.
for n in 10M 21M; do
  echo "== $n points on 2 cores (taskset -c 2,3), best of 2"
  timeout 120 taskset -c 2,3 "$S" -n $n --threads 1,2 --repeats 2 2>&1 | tee "$OUT/tin_2cores_$n.txt" || rc=1
done
echo "== 21M points, 16 threads, strip counts"
timeout 90 "$S" -n 21M --threads 16 --strips 0,16,64 2>&1 | tee "$OUT/tin_strips_21M.txt" || rc=1
exit $rc
