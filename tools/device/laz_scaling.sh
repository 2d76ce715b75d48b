#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried (Qhull
# for the core build): builds the PCL-free LAZ targets, runs the core LAS/LAZ tests, and measures the
# LAZ decoder's thread scaling (bench/dw_laz_bench.cpp) on synthetic tiles our encoder writes there
# (never carried): 12M points of format 1 (50k-point chunks) on 1-16 threads, and 6M points of format
# 8 in variable chunks on 1 and 16 threads. Prints, per thread count, points/s, the speed-up over one
# thread, the peak memory growth and a checksum that must not change. About 2-3 minutes; logs go to
# $OUT (or ./out).
#   usage: tools/device/laz_scaling.sh [POINTS]     (default 12M)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-laz}
N=${1:-12M}
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/laz_machine.txt"
device_cpu_build "$ROOT" "$BUILD" laz dw_laz_bench test_core_las || exit 1

timeout 120 "$BUILD/test/test_core_las" --gtest_filter='Laz*:LasReader*' > "$OUT/test_core_las.log" 2>&1
echo "test_core_las exit $? ($(grep -c '^\[       OK' "$OUT/test_core_las.log") ok, $(grep -c '^\[  FAILED' "$OUT/test_core_las.log") failed lines)"

B="$BUILD/bench/dw_laz_bench"
rc=0
echo "== $N points, format 1, 50k-point chunks, 1-16 threads, best of 2"
timeout 150 "$B" -n "$N" --format 1 --threads 1,2,4,8,16 --repeats 2 --keep /tmp/dw_laz_scaling.laz 2>&1 \
  | tee "$OUT/laz_scaling_f1.txt" || rc=1
rm -f /tmp/dw_laz_scaling.laz
echo "== 6M points, format 8, variable chunks (12.5k-50k points), 1 and 16 threads, best of 2"
timeout 90 "$B" -n 6M --format 8 --variable-chunks --threads 1,16 --repeats 2 2>&1 \
  | tee "$OUT/laz_scaling_f8_variable.txt" || rc=1
exit $rc
