#!/usr/bin/env bash
# Reproduces the whole benchmark of docs/benchmarks.md in one command: builds the benchmark targets,
# runs the protocol runner (CSV), the Google Benchmark suites (JSON), then the plots and tables.
#
#   scripts/benchmark.sh --quick        a few minutes on 2 cores: small clouds, one rotation, and the
#                                       acceptance ratios on the 100k dragon
#   scripts/benchmark.sh                the seed's full protocol (124 rotations x 2 noise levels x every
#                                       data set at base and half fidelity, every peer; bench/run_grid.sh
#                                       on JOBS processes), thread scaling up to JOBS threads, the
#                                       acceptance run: about 3 CPU-hours (1.5-2 hours on 2 idle cores;
#                                       tools/device/run_grid.sh ran it on 15 cores in two 6-minute calls)
#   scripts/benchmark.sh --quick -- ARGS  extra arguments go to dw_bench (see build-bench/bench/dw_bench --help)
#
# Environment: BUILD_DIR (default build-bench), OUT (default $BUILD_DIR/bench-results), JOBS (default 2:
# build jobs, grid processes and the largest thread count), DW_DATA_DIR (the real data, default
# ../shared/data), FIGURES (default docs/figures), PYTHON.
set -euo pipefail
cd "$(dirname "$0")/.."

QUICK=0
EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK=1 ;;
    --) shift; EXTRA=("$@"); break ;;
    -h|--help) sed -n 2,13p "$0"; exit 0 ;;
    *) echo "benchmark.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done

BUILD_DIR=${BUILD_DIR:-build-bench}
OUT=${OUT:-$BUILD_DIR/bench-results}
FIGURES=${FIGURES:-docs/figures}
JOBS=${JOBS:-2}
export CCACHE_BASEDIR="$PWD"

echo "== configuring and building ($BUILD_DIR)"
cmake -S . -B "$BUILD_DIR" -G Ninja -DCMAKE_BUILD_TYPE=Release > "$BUILD_DIR.configure.log" 2>&1 ||
  { cat "$BUILD_DIR.configure.log"; exit 1; }
cmake --build "$BUILD_DIR" --target dw_bench bench_search bench_icp -j "$JOBS"
mkdir -p "$OUT"

if [ "$QUICK" = 1 ]; then
  DW_ARGS=(--quick)
  SEARCH_DATA=dragon-5k,dragon-23k
  ICP_DATA=dragon-23k
  MIN_TIME=0.05
else
  DW_ARGS=()
  SEARCH_DATA=dragon-23k,dragon-100k,dragon-437k
  ICP_DATA=dragon-23k,dragon-100k
  MIN_TIME=0.5
fi

# The plots merge every CSV under $OUT: clear what the other mode left there.
if [ "$QUICK" = 1 ]; then
  rm -rf "$OUT/grid" "$OUT/scaling" "$OUT/accept"
  echo "== dw_bench (protocol runner, CSV into $OUT)"
  "$BUILD_DIR/bench/dw_bench" "${DW_ARGS[@]}" --out "$OUT" "${EXTRA[@]}" | tee "$OUT/dw_bench.log"
else
  rm -f "$OUT"/*.csv
  rm -rf "$OUT/grid"
  THREADS=1
  for t in 2 4 8 16 32 64; do [ "$t" -le "$JOBS" ] && THREADS=$THREADS,$t; done
  echo "== thread scaling ($THREADS threads) into $OUT/scaling"
  "$BUILD_DIR/bench/dw_bench" --sections nn --datasets dragon-100k,lidar-69k --threads "$THREADS" --repeats 2 \
    --methods pcl-kdtree,nanoflann,walk-kd-ann,walk-pnn,walk-pnn-optimized,walk-pnn-optimized-prefetch \
    --out "$OUT/scaling" | tee "$OUT/scaling.log"
  echo "== the rotation grid on $JOBS processes into $OUT/grid (bench/run_grid.sh)"
  bench/run_grid.sh --bin "$BUILD_DIR/bench" --out "$OUT/grid" --workers "$JOBS" --plan all
  echo "== acceptance on dragon-100k into $OUT/accept"
  "$BUILD_DIR/bench/dw_bench" --sections accept --out "$OUT/accept" "${EXTRA[@]}" | tee "$OUT/accept.log"
fi

echo "== Google Benchmark: NN search ($SEARCH_DATA)"
DW_BENCH_DATASETS=$SEARCH_DATA "$BUILD_DIR/bench/bench_search" --benchmark_min_time=$MIN_TIME \
  --benchmark_out="$OUT/bench_search.json" --benchmark_out_format=json
echo "== Google Benchmark: ICP ($ICP_DATA)"
DW_BENCH_DATASETS=$ICP_DATA "$BUILD_DIR/bench/bench_icp" --benchmark_min_time=$MIN_TIME \
  --benchmark_out="$OUT/bench_icp.json" --benchmark_out_format=json

echo "== plots and tables"
# Debian's python3-matplotlib lives with /usr/bin/python3; a pyenv/venv python3 first in PATH may lack it.
PYTHON=${PYTHON:-}
for p in python3 /usr/bin/python3; do
  if [ -z "$PYTHON" ] && "$p" -c "import matplotlib" 2>/dev/null; then PYTHON=$p; fi
done
[ -n "$PYTHON" ] || { echo "benchmark.sh: no python3 with matplotlib (apt-get install python3-matplotlib)" >&2; exit 1; }
"$PYTHON" scripts/plot_benchmarks.py "$OUT" --figures "$FIGURES"
echo "== done: CSV/JSON and tables.md in $OUT, figures in $FIGURES"
