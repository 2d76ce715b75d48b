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
#   scripts/benchmark.sh TABLE [-- ARGS]  one table of docs/benchmarks.md against the 2026 peers
#                                       (bench/dw_peers.cpp, bench/dw_pcl_pipelines.cpp), CSV into
#                                       bench/results/TABLE, figures and tables.md from them:
#       peers-nn      exact 1-NN on ICP-like sequences, ICP order and shuffled, one thread
#       peers-knn     self- and foreign kNN (k = 8, 16, 32) and radius, one thread
#       peers-icp     point-to-point ICP scan-to-scan / scan-to-model, small_gicp ICP/GICP, stock PCL ICP
#       peers-build   build time and peak memory of every structure
#       peers-10M     exact 1-NN and build on the generated 10M-point scene (~2.5 GB, several minutes)
#       pipelines     PCL's NormalEstimationOMP, EuclideanClusterExtraction and GICP's covariances:
#                     DelaunayWalk vs KdTree vs a nanoflann 1.12.1 adaptor, one thread
#     The 16-core thread scaling is tools/device/peers.sh (on the device machine).
#
# Environment: BUILD_DIR (default build-bench), OUT (default $BUILD_DIR/bench-results), JOBS (default 2:
# build jobs, grid processes and the largest thread count), DW_DATA_DIR (the real data, default
# ../shared/data), FIGURES (default docs/figures), PYTHON.
set -euo pipefail
cd "$(dirname "$0")/.."

QUICK=0
TABLE=
EXTRA=()
while [ $# -gt 0 ]; do
  case "$1" in
    --quick) QUICK=1 ;;
    peers-nn|peers-knn|peers-icp|peers-build|peers-10M|pipelines) TABLE=$1 ;;
    --) shift; EXTRA=("$@"); break ;;
    -h|--help) sed -n 2,25p "$0"; exit 0 ;;
    *) echo "benchmark.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done

BUILD_DIR=${BUILD_DIR:-build-bench}
OUT=${OUT:-$BUILD_DIR/bench-results}
FIGURES=${FIGURES:-docs/figures}
JOBS=${JOBS:-2}
export CCACHE_BASEDIR="$PWD"

if [ -n "$TABLE" ]; then
  # One peer table: dw_peers / dw_pcl_pipelines, each comparison in one process, one thread.
  PEER_BUILD=${BUILD_DIR}
  RES=${OUT_TABLE:-bench/results/$TABLE}
  export CCACHE_BASEDIR="$PWD"
  cmake -S . -B "$PEER_BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release > "$PEER_BUILD.configure.log" 2>&1 ||
    { cat "$PEER_BUILD.configure.log"; exit 1; }
  rm -rf "$RES"
  mkdir -p "$RES"
  P="$PEER_BUILD/bench/dw_peers"
  case "$TABLE" in
    pipelines)
      cmake --build "$PEER_BUILD" --target dw_pcl_pipelines -j "$JOBS"
      # One thread, process CPU time: a 2-thread wall clock is not comparable on the shared 2-core box.
      OMP_NUM_THREADS=1 "$PEER_BUILD/bench/dw_pcl_pipelines" --datasets dragon-100k,kitti --threads 1 --repeats 2 \
        --out "$RES" "${EXTRA[@]}" | tee "$RES/run.log"
      "${PYTHON:-/usr/bin/python3}" scripts/plot_benchmarks.py --peers "$RES" --figures "$FIGURES" ;;
    *)
      cmake --build "$PEER_BUILD" --target dw_peers -j "$JOBS"
      export OMP_NUM_THREADS=1  # PCL's FLANN would otherwise start OpenMP teams per query
      run() { local sub=$1; shift; mkdir -p "$RES/$sub"; "$P" "$@" --out "$RES/$sub" "${EXTRA[@]}" | tee "$RES/$sub/run.log"; }
      case "$TABLE" in
        peers-nn)
          run a --sections nn --datasets dragon-100k,kitti,fastgicp,autzen --iterations 10 --repeats 2
          run b --sections nn --datasets dragon-437k,uniform-1M --iterations 3 --repeats 1 ;;
        peers-knn)
          for d in dragon-100k kitti autzen; do run "$d" --sections knn --datasets "$d" --knn-queries 1000000 --repeats 2; done ;;
        peers-icp) run a --sections icp --datasets kitti,fastgicp,dragon-100k --repeats 1 ;;
        peers-build) run a --sections build --datasets dragon-100k,dragon-437k,kitti,fastgicp,autzen,uniform-1M --repeats 1 ;;
        peers-10M) run a --sections build,nn --datasets scene-10M --iterations 3 --repeats 1 --orders icp ;;
      esac
      PYTHON=${PYTHON:-/usr/bin/python3}
      "$PYTHON" scripts/plot_benchmarks.py --peers "$RES" --figures "$FIGURES" ;;
  esac
  echo "== done: CSV in $RES"
  exit 0
fi

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
