#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL, no GDAL) from the repository root, with .deps carried
# (Qhull for the core build): the DEM at scale (issue 34, docs/dem.md "Scale"). Builds the PCL- and
# GDAL-free targets (dw_lidar_gen, dw_dem_scale, test_core_dem), runs the core DEM tests, generates a
# synthetic airborne survey of POINTS points as LAS tiles of TILE points (point format 0: 20 bytes a
# point; tiles written in parallel, one process each, timed apart), then times, each as one process
# under /usr/bin/time -v (peak RSS of the child; getrusage inside too):
#   1. the in-memory DEM (dw_dem's path) on the first INMEM points' tiles;
#   2. the streamed DEM (dw_dem --stream's path) on the same tiles, its raster compared byte for byte;
#   3. the streamed DEM on all tiles, 1 m cells, THREADS threads, --memory-limit MEMORY_MB.
# The DEMs are written as raw Float32 + ENVI header (core/dem/envi_writer.h). Wall time includes all
# reading (both passes), the spill files and the writing. The tiles are deleted at the end, however it
# ends. Prints progress; one summary goes to $OUT/dem_scale.txt.
#   usage: tools/device/dem_scale.sh [POINTS]     (default 1000M; suffixes k, M, G)
#   environment: DEM_SCALE_TILE (20M), DEM_SCALE_INMEM (100M; 0: skip 1 and 2), DEM_SCALE_THREADS (nproc),
#     DEM_SCALE_MEMORY_MB (6144), DEM_SCALE_DIR (/tmp/dw-dem-scale), DW_DEVICE_BUILD (/tmp/dw-build-dem),
#     DW_DEVICE_PREBUILT=1: use the binaries already in DW_DEVICE_BUILD (no configure, no build),
#     DEM_SCALE_STAGE: all (default), gen (build, test and generate, keep the tiles, stop) or dem (the DEM
#     runs on the tiles an earlier gen call left): two calls of the device's per-command limit each.
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-dem}
DIR=${DEM_SCALE_DIR:-/tmp/dw-dem-scale}
THREADS=${DEM_SCALE_THREADS:-$(nproc)}
MEM=${DEM_SCALE_MEMORY_MB:-6144}
mkdir -p "$OUT" "$DIR"
S="$OUT/dem_scale.txt"
: > "$S"
say() { echo "$*" | tee -a "$S"; }

count() {  # 20M -> 20000000
  local v=${1^^} m=1
  case $v in *K) m=1000 ;; *M) m=1000000 ;; *G) m=1000000000 ;; esac
  v=${v%[KMG]}
  [[ $v =~ ^[0-9]+$ ]] || { echo "bad count '$1'" >&2; exit 2; }
  echo $((v * m))
}
N=$(count "${1:-1000M}")
TILE=$(count "${DEM_SCALE_TILE:-20M}")
INMEM=$(count "${DEM_SCALE_INMEM:-100M}")
((TILE > N)) && TILE=$N
TILES=$((N / TILE))
N=$((TILES * TILE))
# A rectangle of tiles W x 2W each: ROWS the divisor of TILES nearest sqrt(TILES / 2), about square.
COLS=$(python3 -c "import math; t = $TILES; r = min((d for d in range(1, t + 1) if t % d == 0),
  key=lambda d: abs(d - math.sqrt(t / 2))); print(t // r)")
INMEM_TILES=$((INMEM / TILE))
((INMEM_TILES > TILES)) && INMEM_TILES=$TILES

STAGE=${DEM_SCALE_STAGE:-all}
case $STAGE in all | gen | dem) ;; *) echo "bad DEM_SCALE_STAGE '$STAGE'" >&2; exit 2 ;; esac
cleanup() { rm -rf "$DIR"; }
[[ $STAGE == gen ]] || trap cleanup EXIT

. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/dem_scale_machine.txt" > /dev/null
cat "$OUT/dem_scale_machine.txt" >> "$S"
say "== $N points: $TILES tiles of $TILE points, $COLS tile columns; $THREADS threads, memory limit $MEM MB"
# Disk: 20 bytes a point for the tiles, 20 for the spill files (kept points), plus the rasters.
need_kb=$((N / 1024 * 42))
[[ $STAGE == dem ]] && need_kb=$((N / 1024 * 22))  # the tiles are there already
free_kb=$(df -Pk "$DIR" | awk 'NR == 2 { print $4 }')
say "disk: needs about $((need_kb / 1024)) MiB in $DIR, $((free_kb / 1024)) MiB free"
((need_kb < free_kb)) || { say "not enough disk for $N points: run fewer"; exit 1; }

t=$(date +%s.%N)
if [[ ${DW_DEVICE_PREBUILT:-0} != 1 && $STAGE != dem ]]; then
  echo "building dw_lidar_gen dw_dem_scale test_core_dem in $BUILD ..."
  device_cpu_build "$ROOT" "$BUILD" demscale dw_lidar_gen dw_dem_scale test_core_dem || exit 1
fi
say "build: $(python3 -c "import time; print(f'{time.time() - $t:.1f}')") s"
G="$BUILD/apps/dw_lidar_gen"
D="$BUILD/bench/dw_dem_scale"
if [[ $STAGE != dem ]]; then
  timeout 120 "$BUILD/test/test_core_dem" > "$OUT/dem_scale_tests.log" 2>&1
  say "test_core_dem exit $? ($(grep -c '^\[       OK' "$OUT/dem_scale_tests.log") ok, $(grep -c '^\[  FAILED' "$OUT/dem_scale_tests.log") failed lines)"
fi

TIMEV=()
[[ -x /usr/bin/time ]] && TIMEV=(/usr/bin/time -v)

# run_dem LABEL OUTPUT ARGS...: one DEM process; its result line and peak RSS into the summary.
run_dem() {
  local label=$1 out=$2
  shift 2
  say "-- $label"
  # stdout to the log; stderr (progress, time -v) through tee, its progress lines shown as they come.
  "${TIMEV[@]}" "$D" "$@" -o "$out" --resolution 1 --threads "$THREADS" 2>&1 > "$OUT/dem_scale_$label.log" |
    tee "$OUT/dem_scale_$label.err" | grep --line-buffered -E "^\s*\[|rror" >&2
  local rc=${PIPESTATUS[0]}
  grep -E "^(read|scan|strips|raster|result)" "$OUT/dem_scale_$label.log" | tee -a "$S"
  grep -E "Maximum resident|Elapsed \(wall|User time|System time" "$OUT/dem_scale_$label.err" | sed 's/^\s*/  time -v: /' | tee -a "$S"
  ((rc == 0)) || say "   FAILED (exit $rc)"
  return $rc
}

if [[ $STAGE != dem ]]; then
  echo "generating $TILES tiles in $DIR ..."
  t=$(date +%s.%N)
  seq 0 $((TILES - 1)) | xargs -P "$(nproc)" -I{} bash -c \
    'i={}; "$0" -n "$1" --format 0 --tile $((i % $2)) $((i / $2)) -o "$3/tile_$(printf %05d $i).las" 2> /dev/null ||
     { echo "tile $i failed"; exit 255; }' "$G" "$TILE" "$COLS" "$DIR" || { say "generation failed"; exit 1; }
  gen_s=$(python3 -c "import time; print(f'{time.time() - $t:.1f}')")
  bytes=$(du -sb "$DIR" | cut -f1)
  say "generation: $N points in $gen_s s ($(python3 -c "print(f'{$N / $gen_s / 1e6:.1f}')") M points/s), $((bytes / 1048576)) MiB of LAS"
fi
[[ $STAGE == gen ]] && { say "tiles kept in $DIR for DEM_SCALE_STAGE=dem"; exit 0; }
mapfile -t ALL < <(ls "$DIR"/tile_*.las)
rc=0
if ((INMEM_TILES > 0)); then
  SUB=("${ALL[@]:0:INMEM_TILES}")
  run_dem inmemory "$DIR/inmemory.raw" "${SUB[@]}" || rc=1
  run_dem stream_small "$DIR/stream_small.raw" "${SUB[@]}" --stream --memory-limit "$MEM" || rc=1
  if cmp -s "$DIR/inmemory.raw" "$DIR/stream_small.raw"; then
    say "   streamed raster == in-memory raster, byte for byte ($(stat -c %s "$DIR/inmemory.raw") bytes)"
  else
    say "   streamed raster DIFFERS from the in-memory raster"
    rc=1
  fi
  rm -f "$DIR"/inmemory.raw "$DIR"/stream_small.raw
fi
run_dem stream "$DIR/stream.raw" "${ALL[@]}" --stream --memory-limit "$MEM" || rc=1
cp "$DIR/stream.hdr" "$OUT/dem_scale_stream.hdr" 2> /dev/null
say "== summary (result lines above: wall_s includes every read, the spill and the write)"
exit $rc
