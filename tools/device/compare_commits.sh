#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE from the repository root, with .deps carried (tools/device/prepare.sh) and
# another commit's source tree unpacked in .deps/base (here: `git archive BASE | tar -x -C .deps/base`).
# Builds the PCL-free core of both trees and alternates their tools (ABBA: odd rounds run the base
# first) on the 3D builder (dw_delaunay3d_scaling), the TIN (dw_tin_scaling) and the walk
# (dw_walk_timing, compiled against each tree's core library). Rows go to $OUT/compare.txt, tagged
# "<what> <tree> <round>".
#   usage: tools/device/compare_commits.sh [ROUNDS]   (default 2)
#   DW_COMPARE_THREADS (default 1,16)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BASE_SRC=$DEPS/base
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-cmp}
ROUNDS=${1:-2}
THREADS=${DW_COMPARE_THREADS:-1,16}
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/compare_machine.txt"
export DW_DEVICE_CMAKE_ARGS=-DBUILD_TESTING=OFF
device_cpu_build "$ROOT" "$BUILD-new" new dw_delaunay3d_scaling dw_tin_scaling pcl_delaunay_walk_core || exit 1
device_cpu_build "$BASE_SRC" "$BUILD-base" base dw_delaunay3d_scaling dw_tin_scaling pcl_delaunay_walk_core || exit 1

# The walk driver: one source, compiled against each tree's headers and core library.
walk_driver() {  # tree_src build_dir out
  local lib
  lib=$(find "$2" -name libpcl_delaunay_walk_core.a | head -1)
  g++ -std=c++17 -O3 -DNDEBUG -ffp-contract=off -I"$1/include" -I/usr/include/eigen3 \
    "$ROOT/bench/dw_walk_timing.cpp" "$lib" "$DEPS/qhull/lib/libqhull_r.so.8.0" -lpthread -o "$3"
}
walk_driver "$ROOT" "$BUILD-new" "$BUILD-new/dw_walk_timing" || exit 1
walk_driver "$BASE_SRC" "$BUILD-base" "$BUILD-base/dw_walk_timing" || exit 1
export LD_LIBRARY_PATH=$DEPS/qhull/lib:${LD_LIBRARY_PATH:-}

tool() {  # tree name
  find "$BUILD-$1" -name "$2" -type f -perm -u+x | head -1
}
D=$DEPS/data/models/dragon_vrip.ply
[ -f "$D" ] || gunzip -k "$D.gz"
run() {  # what tree round command...
  local what=$1 tree=$2 round=$3
  shift 3
  timeout 300 "$@" 2>&1 | sed "s/^/$what $tree $round | /" | tee -a "$OUT/compare.txt"
}
for round in $(seq "$ROUNDS"); do
  trees="base new"; [ $((round % 2)) = 0 ] && trees="new base"
  for tree in $trees; do
    run 3d-1M "$tree" "$round" "$(tool "$tree" dw_delaunay3d_scaling)" -n 1M --threads "$THREADS" --repeats 2
    run 3d-dragon "$tree" "$round" "$(tool "$tree" dw_delaunay3d_scaling)" --file "$D" --threads "$THREADS" --repeats 2
    run tin-10M "$tree" "$round" "$(tool "$tree" dw_tin_scaling)" -n 10M --threads "$THREADS" --repeats 2
    run walk-dragon "$tree" "$round" "$BUILD-$tree/dw_walk_timing" --file "$D" --repeats 3
  done
done
