#!/bin/sh
# core.las.laz_perf_check: laz-perf (npm, LASzip compiled to WASM) decodes the shared LAZ file and the
# LAZ files our encoder writes (dw_lidar_gen, every format 0-3 and 6-8, fixed chunks, and variable
# chunks of formats 1, 3, 6 and 8) to the same records as the uncompressed twins. Skips (77) without node or without laz-perf, which is installed with
#   (mkdir -p .deps/lazperf && cd .deps/lazperf && npm init -y && npm install laz-perf)
# Usage: laz_perf_check.sh SCRIPT_DIR MODULE_DIR DW_LIDAR_GEN WORK_DIR SHARED_DATA_DIR
set -u
dir=$1 modules=$2 gen=$3 work=$4 shared=$5
command -v node >/dev/null 2>&1 || { echo "node not found: skipped"; exit 77; }
[ -d "$modules/node_modules/laz-perf" ] || { echo "laz-perf not installed under $modules: skipped"; exit 77; }
mkdir -p "$work"
status=0
if [ -f "$shared/airborne/las_with_several_extra_byte_bloc.laz" ]; then
  node "$dir/laz_perf_check.js" "$modules" "$shared/airborne/las_with_several_extra_byte_bloc.laz" \
    "$shared/airborne/las_with_several_extra_byte_bloc.las" || status=1
fi
for f in 0 1 2 3 6 7 8; do
  "$gen" -n 70k --seed $f --format $f -o "$work/gen$f.laz" 2>/dev/null || status=1
  "$gen" -n 70k --seed $f --format $f -o "$work/gen$f.las" 2>/dev/null || status=1
  node "$dir/laz_perf_check.js" "$modules" "$work/gen$f.laz" "$work/gen$f.las" || status=1
  rm -f "$work/gen$f.laz" "$work/gen$f.las"
done
# Variable chunks (LASzip's chunk size 0xFFFFFFFF: the chunk table holds every chunk's count).
for f in 1 3 6 8; do
  "$gen" -n 70k --seed $f --format $f --chunk 12k --variable-chunks -o "$work/var$f.laz" 2>/dev/null || status=1
  "$gen" -n 70k --seed $f --format $f -o "$work/var$f.las" 2>/dev/null || status=1
  node "$dir/laz_perf_check.js" "$modules" "$work/var$f.laz" "$work/var$f.las" || status=1
  rm -f "$work/var$f.laz" "$work/var$f.las"
done
exit $status
