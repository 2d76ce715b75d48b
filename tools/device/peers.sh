#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried
# (tools/device/prepare.sh, run here first, puts Qhull, the peers' headers and the clouds there):
# builds the PCL-free dw_peers (bench/dw_peers.cpp; the peers and the driver -O3 -march=native) and
# measures exact 1-NN on ICP-like sequences, queries in ICP order and shuffled, on 1, 2, 4, 8 and 16
# threads, the walk against pico_tree, nanoflann 1.12.1, Debian's nanoflann 1.4.3 and small_gicp's
# KdTree (no PCL FLANN here); then self-kNN k = 16 and radius on 1 and 16 threads. Prints one markdown
# table per data set (ns/query, and the fastest peer's time over each method's); CSV and logs go to
# $OUT (or ./out). About 3 minutes.
#   usage: tools/device/peers.sh [DATASET...]   (default: dragon-100k kitti autzen uniform-1M)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-peers}
SETS=("$@")
[ ${#SETS[@]} -gt 0 ] || SETS=(dragon-100k kitti autzen uniform-1M)
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/peers_machine.txt"
[ -d "$DEPS/peers" ] || echo "peers.sh: no $DEPS/peers (run tools/device/prepare.sh here first): walks only"
DW_DEVICE_CMAKE_ARGS="-DDW_PEERS_DIR=$DEPS/peers -DNANOFLANN_INCLUDE_DIR=$DEPS/nanoflann ${DW_DEVICE_CMAKE_ARGS:-}" \
  device_cpu_build "$ROOT" "$BUILD" peers dw_peers || exit 1
export DW_DATA_DIR=$DEPS/data DW_BENCH_CACHE=$BUILD/bench-data
P="$BUILD/bench/dw_peers"
rc=0
for d in "${SETS[@]}"; do
  echo "== $d: exact 1-NN, 1-16 threads"
  timeout 150 "$P" --sections nn --datasets "$d" --threads 1,2,4,8,16 --iterations 8 --repeats 2 \
    --out "$OUT/peers/nn_$d" > "$OUT/peers_nn_$d.log" 2>&1 || { rc=1; tail -5 "$OUT/peers_nn_$d.log"; }
  sed -n '/^exact 1-NN/,/^(ns per query/p' "$OUT/peers_nn_$d.log"
done
for d in dragon-100k kitti; do
  echo "== $d: self-kNN k = 16 and radius, 1 and 16 threads"
  timeout 90 "$P" --sections knn --datasets "$d" --k 16 --threads 1,16 --knn-queries 100000 --repeats 2 \
    --out "$OUT/peers/knn_$d" > "$OUT/peers_knn_$d.log" 2>&1 || { rc=1; tail -5 "$OUT/peers_knn_$d.log"; }
  sed -n '/^kNN and radius/,/^(ns per query/p' "$OUT/peers_knn_$d.log"
  grep -E "x16 " "$OUT/peers_knn_$d.log" | sed 's/^ */    /'
done
exit $rc
