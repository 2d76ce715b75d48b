#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried
# (tools/device/prepare.sh: Qhull, the peers nanoflann 1.12.1, pico_tree and small_gicp under
# .deps/peers, the KITTI frames): builds the PCL-free core, its registration tests and
# dw_localize_bench, runs the tests, then the localization benchmark on 16 threads: the KITTI pair, a
# generated 10M-point street map with 120k-point scans (walk vs nanoflann 1.12.1, pico_tree and
# small_gicp's KdTree in the same ICP loop, and small_gicp's own ICP with 16 OpenMP threads; per-frame
# times and ratios) and the sliding-window map's insert/remove rates beside nanoflann's incremental
# tree, and the odometries (ours, nanoflann's, small_gicp's voxel map; a second run, 1M map). About
# 5-7 minutes before the pico_tree and small_gicp rows were added (not yet timed with them). Logs go
# to $OUT.
#   usage: tools/device/localize.sh [MAP_POINTS]     (default 10M)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-localize}
MAP=${1:-10M}
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/localize_machine.txt"
DW_DEVICE_CMAKE_ARGS="-DDW_PEERS_DIR=$DEPS/peers" \
  device_cpu_build "$ROOT" "$BUILD" localize dw_localize_bench test_core_registration || exit 1

timeout 150 "$BUILD/test/test_core_registration" > "$OUT/test_core_registration.log" 2>&1
echo "test_core_registration exit $? ($(grep -c '^\[       OK' "$OUT/test_core_registration.log") ok," \
  "$(grep -c '^\[  FAILED' "$OUT/test_core_registration.log") failed lines)"

echo "== localization: KITTI pair and a $MAP-point map, 120k-point scans, 16 threads"
timeout 300 "$BUILD/bench/dw_localize_bench" --kitti "$DEPS/data/scans" --map-points "$MAP" --scan-points 120k \
  --frames 16 --threads 16 --graph-file /tmp/dw-localize-map.graph 2>&1 | tee "$OUT/localize_bench.txt"
# Map maintenance and odometry run on the scene's scans, not on its map: a small map keeps the
# second process's set-up short.
echo "== sliding-window map maintenance and odometry (120k-point scans)"
timeout 240 "$BUILD/bench/dw_localize_bench" --map-points 1M --scan-points 120k --frames 16 --threads 16 \
  --odometry 2>&1 | tee "$OUT/odometry_bench.txt"
