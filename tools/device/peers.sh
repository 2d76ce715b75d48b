#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried
# (tools/device/prepare.sh, run here first, puts Qhull, the peers' headers and the clouds there):
# builds the PCL-free dw_peers (bench/dw_peers.cpp; the peers and the driver -O3 -march=native) and
# measures exact 1-NN on ICP-like sequences, queries in ICP order and shuffled, on 1, 2, 4, 8 and 16
# threads, the walk against pico_tree, nanoflann 1.12.1, Debian's nanoflann 1.4.3 and small_gicp's
# KdTree (no PCL FLANN here); then self-kNN k = 16 and radius on 1 and 16 threads. Prints one markdown
# table per data set (ns/query, and the fastest peer's time over each method's); CSV and logs go to
# $OUT (or ./out). Each run has its own timeout.
#   usage: tools/device/peers.sh [DATASET...]   (default: dragon-100k kitti autzen uniform-1M; about
#          3-4 minutes: build ~1.5, runs ~2)
#   scene-10M (10M generated airborne returns, bench/dw_peers.cpp): also the build table (one thread,
#          peak memory); ICP order only, 2 ICP iterations over every 5th source point (2M queries per
#          iteration, still in acquisition order), one repeat. `DW_PEERS_KNN_SETS=fastgicp
#          tools/device/peers.sh fastgicp scene-10M` is the one-call 10M + fast_gicp run (~6-7 minutes).
#   DW_PEERS_KNN_SETS: the data sets of the kNN/radius part (default "dragon-100k kitti"; "" skips it).
#   What it prints: per data set a markdown table "exact 1-NN, <set>" (rows: methods; columns: ICP
#   order / shuffled x 1, 2, 4, 8, 16 threads; cells: ns/query with the fastest peer's time over the
#   method's in brackets), for scene-10M first its build lines (CPU ms, peak and held bytes per point),
#   then "kNN and radius, <set>" at 1 thread and the 16-thread lines.
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
export OMP_NUM_THREADS=1  # dw_peers splits batches over its own pool
for d in "${SETS[@]}"; do
  SECTIONS=nn ARGS=(--iterations 5 --repeats 2) LIMIT=80
  case "$d" in
    uniform-1M) ARGS=(--iterations 2 --repeats 1 --orders icp) ;;  # its own order is random
    scene-10M)
      # Three 10M graph builds (timed, peak in a forked child, the nn section's) dominate: ~3 x 40 s.
      SECTIONS=build,nn ARGS=(--iterations 2 --repeats 1 --orders icp --max-queries 2000000) LIMIT=420 ;;
  esac
  echo "== $d: exact 1-NN, 1-16 threads"
  timeout "$LIMIT" "$P" --sections "$SECTIONS" --datasets "$d" --threads 1,2,4,8,16 "${ARGS[@]}" \
    --out "$OUT/peers/nn_$d" > "$OUT/peers_nn_$d.log" 2>&1 || { rc=1; tail -5 "$OUT/peers_nn_$d.log"; }
  awk '/^  build \(CPU/ {b = 1; print; next} b && /^    / {print; next} {b = 0}' "$OUT/peers_nn_$d.log"
  sed -n '/^exact 1-NN/,/^(ns per query/p' "$OUT/peers_nn_$d.log"
done
KNN_SETS=${DW_PEERS_KNN_SETS-dragon-100k kitti}
for d in $KNN_SETS; do
  echo "== $d: self-kNN k = 16 and radius, 1 and 16 threads"
  timeout 45 "$P" --sections knn --datasets "$d" --k 16 --threads 1,16 --knn-queries 50000 --repeats 2 \
    --out "$OUT/peers/knn_$d" > "$OUT/peers_knn_$d.log" 2>&1 || { rc=1; tail -5 "$OUT/peers_knn_$d.log"; }
  sed -n '/^kNN and radius/,/^(ns per query/p' "$OUT/peers_knn_$d.log"
  grep -E "x16 " "$OUT/peers_knn_$d.log" | sed 's/^ */    /'
done
exit $rc
