#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried: builds
# dw_lidar_gen and dw_tin_scaling, writes one synthetic airborne tile as LAS and as its LAZ twin (our
# encoder), and times dw_tin's stages that differ between the two, reading the file and triangulating
# it, on 16 threads, 3 rounds, LAS and LAZ alternating. The PLY write that dw_tin adds is
# the same for both and left out, which can only raise the LAZ/LAS ratio. One summary goes to
# $OUT/tin_laz.txt.
#   usage: tools/device/tin_laz.sh [POINTS]     (default 20M)
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-tin}
N=${1:-20M}
TILE=/tmp/dw-tin-laz
mkdir -p "$OUT" "$TILE"
. "$ROOT/tools/device/cpu_build.sh"
S="$OUT/tin_laz.txt"
device_machine_info "$S"
device_cpu_build "$ROOT" "$BUILD" tinlaz dw_lidar_gen dw_tin_scaling || exit 1
G="$BUILD/apps/dw_lidar_gen"
T="$BUILD/bench/dw_tin_scaling"
{ /usr/bin/time -f "write LAS: %e s, %M KB peak" "$G" -n "$N" -o "$TILE/tile.las" &&
  /usr/bin/time -f "write LAZ: %e s, %M KB peak" "$G" -n "$N" -o "$TILE/tile.laz"; } 2>&1 | grep -E "write|rror" | tee -a "$S"
ls -l "$TILE" | tee -a "$S"
rc=0
for threads in 16; do
  for round in 1 2 3; do
    for f in las laz; do
      echo "== $f, $threads threads, round $round" | tee -a "$S"
      timeout 120 "$T" --las "$TILE/tile.$f" --threads "$threads" --repeats 1 2>&1 |
        grep -E "^input|^ +[0-9]+ +[0-9]+ |differ|rror" | tee -a "$S" || rc=1
    done
  done
done
exit $rc
