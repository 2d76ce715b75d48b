#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16+ CPU cores, no PCL) from the repository root, with .deps carried (Qhull
# for the core build, the dragon): builds the PCL-free 3D builder's scaling tool and measures the 3D
# Delaunay graph builder's thread scaling on uniform points generated there and on the dragon,
# plus the ceiling of any partitioned scheme (--independent). Logs go to $OUT (or ./out).
#   usage: tools/device/builder3d_scaling.sh [THREADS]     (default: 1,2,4,8,16)
#   DW_SCALING_SIZES="1M 4M" (default), DW_SCALING_REPEATS=2 (default)
#   DW_SCALING_BASE=DIR: instead, alternate this tree's tool with the one built from the source tree
#   DIR (another commit, e.g. `git archive BASE | tar -x -C .deps/base` here, .deps carried), three
#   rounds per input (DW_SCALING_ROUNDS; odd rounds run the base first, even ones this tree's), and
#   print both tools' rows, tagged, into 3d_compare.txt.
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-3d}
THREADS=${1:-1,2,4,8,16}
REPEATS=${DW_SCALING_REPEATS:-2}
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/3d_machine.txt"
device_cpu_build "$ROOT" "$BUILD" 3d dw_delaunay3d_scaling || exit 1

S="$BUILD/bench/dw_delaunay3d_scaling"
D=$DEPS/data/models/dragon_vrip.ply
[ -f "$D" ] || gunzip -k "$D.gz"
rc=0
if [ -n "${DW_SCALING_BASE:-}" ]; then
  DW_DEVICE_CMAKE_ARGS=-DBUILD_TESTING=OFF device_cpu_build "$DW_SCALING_BASE" "$BUILD-base" 3d_base \
    dw_delaunay3d_scaling || exit 1
  B="$BUILD-base/bench/dw_delaunay3d_scaling"
  for input in ${DW_SCALING_SIZES:-1M 4M} dragon; do
    args=(-n "$input"); [ "$input" = dragon ] && args=(--file "$D")
    for round in $(seq "${DW_SCALING_ROUNDS:-3}"); do
      tools="base new"; [ $((round % 2)) = 0 ] && tools="new base"  # ABBA: drift favours neither
      for tool in $tools; do
        t=$S; [ $tool = base ] && t=$B
        timeout 120 "$t" "${args[@]}" --threads "$THREADS" --repeats "$REPEATS" 2>&1 \
          | awk -v tag="$input $tool $round" '$1 ~ /^[0-9]+$/ {print tag, $0}' | tee -a "$OUT/3d_compare.txt"
      done
    done
  done
  exit 0
fi
for n in ${DW_SCALING_SIZES:-1M 4M}; do
  echo "== uniform $n, threads $THREADS, best of $REPEATS, with the independent-kernel ceiling"
  timeout 240 "$S" -n "$n" --threads "$THREADS" --repeats "$REPEATS" --independent 2>&1 \
    | tee "$OUT/3d_scaling_$n.txt" || rc=1
done
echo "== dragon, threads $THREADS, best of $REPEATS"
timeout 120 "$S" --file "$D" --threads "$THREADS" --repeats "$REPEATS" 2>&1 | tee "$OUT/3d_scaling_dragon.txt" || rc=1
exit $rc
