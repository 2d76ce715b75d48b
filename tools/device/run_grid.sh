#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL) from the repository root, with .deps carried: the
# benchmark of docs/benchmarks.md that the 2-core development machine cannot do in time.
#   1. thread scaling (1, 2, 4, 8, 16 threads) of the walks, nanoflann and pcl::search::KdTree on the
#      ICP-like sequences of dragon-100k and the LiDAR frame, alone on the machine;
#   2. bench/run_grid.sh: the 124-rotation grid x {no noise, noise} on every data set at base and half
#      fidelity, plus the build and per-query sections, as WORKERS single-threaded processes sharing
#      the machine, stopped at the deadline.
# Results go to $OUT/results.tar.gz (unpack into build-bench/bench-results/device and run
# scripts/plot_benchmarks.py on it).
# Prepare HERE first: build dw_bench and bench_search in build-bench, then
#   tools/device/prepare.sh                 # Qhull, nanoflann, dragons, LiDAR frames into .deps
#   tools/device/bundle.sh bench build-bench/bench/dw_bench build-bench/bench/bench_search
#   mkdir -p .deps/benchdata/models && cp ../shared/data/models/{teapot_points,bun_zipper_res2}.ply .deps/benchdata/models/
# Environment: BUDGET (wall seconds for the whole script, default 450), WORKERS (default nproc - 1),
# PLAN (run_grid.sh plan, default all), JOBS_FILE (extra job lines for run_grid.sh --jobs, e.g. from
# tools/device/grid_resume.py; carry it in .deps), SCALING_SETS (default dragon-100k,lidar-69k),
# SCALING_METHODS (default the walks, nanoflann and pcl-kdtree).
set -uo pipefail
T0=$(date +%s)
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
BUDGET=${BUDGET:-450}
WORKERS=${WORKERS:-$(( $(nproc) - 1 ))}
PLAN=${PLAN:-all}
R=/tmp/dw-bench-results
mkdir -p "$OUT" "$R" /tmp/dwb /tmp/dwdata/models /tmp/dwdata/scans /tmp/dwcache
tar -xJf "$ROOT/.deps/bundle/bench.tar.xz" -C /tmp/dwb || exit 1
export LD_LIBRARY_PATH=/tmp/dwb/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}
for f in "$ROOT"/.deps/data/models/* "$ROOT"/.deps/benchdata/models/*; do ln -sf "$f" /tmp/dwdata/models/; done
for f in "$ROOT"/.deps/data/scans/*; do ln -sf "$f" /tmp/dwdata/scans/; done
export DW_DATA_DIR=/tmp/dwdata DW_BENCH_CACHE=/tmp/dwcache
gzip -dc /tmp/dwdata/models/dragon_vrip_res2.ply.gz > /tmp/dwcache/dragon_vrip_res2.ply
{ date -u; nproc; lscpu; free -g; uptime; } > "$R/machine.txt" 2>&1
/tmp/dwb/bin/dw_bench --help > /dev/null || { echo "dw_bench does not start"; ldd /tmp/dwb/bin/dw_bench | grep "not found"; exit 1; }

echo "== thread scaling ($(( $(date +%s) - T0 )) s)"
timeout 150 /tmp/dwb/bin/dw_bench --sections nn --datasets "${SCALING_SETS:-dragon-100k,lidar-69k}" \
  --methods "${SCALING_METHODS:-pcl-kdtree,nanoflann,walk-kd-ann,walk-pnn,walk-pnn-optimized,walk-pnn-optimized-prefetch}" \
  --threads 1,2,4,8,16 --repeats 2 --out "$R/scaling" > "$R/scaling.log" 2>&1
echo "scaling exit $? after $(( $(date +%s) - T0 )) s"; grep -E "^==|x16" "$R/scaling.log" | head -20

LEFT=$(( BUDGET - ($(date +%s) - T0) - 15 ))
echo "== grid: $WORKERS workers, $LEFT s"
bash "$ROOT/bench/run_grid.sh" --bin /tmp/dwb/bin --out "$R/grid" --workers "$WORKERS" --deadline "$LEFT" --plan "$PLAN" \
  ${JOBS_FILE:+--jobs "$JOBS_FILE"}
uptime >> "$R/machine.txt"
tar -czf "$OUT/results.tar.gz" -C "$R" .
ls -la "$OUT"; echo "total $(( $(date +%s) - T0 )) s"
