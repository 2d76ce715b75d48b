#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried (Qhull for
# the core): builds dw_urban_gen and the simulator's tests, runs the tests, and generates the full-size
# localization data set there (never carried): a 10M-point prior map and 100 HDL-64-like scans, timed on
# 16 threads and on one. The data stay in $DW_URBAN_DIR (default /tmp/dw-urban) for later runs on the same
# machine; logs go to $OUT (or ./out). About a minute after the build.
#   usage: tools/device/urban_gen.sh [SCANS] [MAP_POINTS]      (default: 100 10M)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-urban}
DATA=${DW_URBAN_DIR:-/tmp/dw-urban}
SCANS=${1:-100}
POINTS=${2:-10M}
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/urban_machine.txt"
device_cpu_build "$ROOT" "$BUILD" urban dw_urban_gen test_core_sim || exit 1

timeout 120 "$BUILD/test/test_core_sim" > "$OUT/test_core_sim.log" 2>&1
echo "test_core_sim exit $? ($(grep -c '^\[       OK' "$OUT/test_core_sim.log") ok, $(grep -c '^\[  FAILED' "$OUT/test_core_sim.log") failed lines)"

G="$BUILD/apps/dw_urban_gen"
rc=0
echo "== $SCANS scans and a $POINTS-point map, 16 threads"
/usr/bin/time -f "wall %e s, user %U s, system %S s, peak %M kB" timeout 200 "$G" --out "$DATA" --seed 1 \
  --scans "$SCANS" --map-points "$POINTS" --threads 16 2>&1 | tr '\r' '\n' | grep -v "^map: *[0-9]*%$" \
  | tee "$OUT/urban_gen_16.txt" || rc=1
echo "== 10 scans, no map, 1 thread (the per-scan cost without parallelism)"
/usr/bin/time -f "wall %e s, user %U s, system %S s" timeout 100 "$G" --out "$DATA-1t" --seed 1 --scans 10 \
  --map-points 0 --threads 1 2>&1 | tr '\r' '\n' | tee "$OUT/urban_gen_1.txt" || rc=1
cmp -s "$DATA/scans/000009.bin" "$DATA-1t/scans/000009.bin" && echo "scan 9 identical on 1 and 16 threads" \
  || { echo "FAIL: scan 9 differs between 1 and 16 threads"; rc=1; }
cp "$DATA/info.txt" "$OUT/urban_info.txt"
du -sh "$DATA" | tee -a "$OUT/urban_gen_16.txt"
exit $rc
