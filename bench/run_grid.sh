#!/usr/bin/env bash
# Runs the seed's ICP protocol (Anderson et al. 2022, §5: the 124-rotation grid, without and with noise
# on the target) for every data set at its base fidelity and downsampled by 2, plus the build and
# per-query NN sections, as many single-threaded dw_bench processes sharing one queue of jobs. Each job
# is one (data set, noise) and a round-robin shard of the rotations (dw_bench --shard), so the jobs
# balance over the workers and a run cut off by the deadline still covers the whole grid thinly
# rather than some data sets fully and others not at all. Results: OUT/jobs/<job>/*.csv, merged by
# scripts/plot_benchmarks.py.
#
#   bench/run_grid.sh [--bin DIR] [--out DIR] [--workers N] [--deadline SECONDS] [--plan NAME]
#     --bin       folder holding dw_bench (default build-bench/bench)
#     --workers   parallel processes (default: the number of cores)
#     --deadline  wall seconds from now after which no job starts and running jobs are stopped
#                 (default: none). Rows are flushed as they are measured; a stopped job keeps its rows.
#     --plan      main (the grid on the data sets below; default), extra (dragon-100k and the full LiDAR
#                 frame on the 12 single-axis rotations, dragon-5k on the grid), all (main then extra),
#                 or smoke (two tiny jobs, to test the driver)
#     --methods   keep only these methods (comma list) in every job of the plan
#     --jobs FILE run the job lines of FILE (e.g. from tools/device/grid_resume.py) after the plan's; with
#                 --plan none, only those
#     --dry-run   write OUT/jobs.txt and print it, run nothing
#
# Base fidelities (why: the whole plan must fit one device call of ~6 minutes on 15 cores, see
# docs/benchmarks.md): teapot 792 + 396, bunny 8,171 + 4,086 (Stanford's res2 and every second point of
# it), dragon 22,998 + 11,499, LiDAR frame every second point (34,544) + every fourth (17,272).
# pcl-octree is left out of the LiDAR grid: ~27 µs per query there makes one registration ~35 s.
set -uo pipefail
cd "$(dirname "$0")/.."

BIN=build-bench/bench
OUT=build-bench/bench-results/grid
WORKERS=$(nproc)
DEADLINE=0
PLAN=main
KEEP=
JOBS_FILE=
DRY=0
while [ $# -gt 0 ]; do
  case "$1" in
    --bin) BIN=$2; shift ;;
    --out) OUT=$2; shift ;;
    --workers) WORKERS=$2; shift ;;
    --deadline) DEADLINE=$2; shift ;;
    --plan) PLAN=$2; shift ;;
    --methods) KEEP=$2; shift ;;
    --jobs) JOBS_FILE=$2; shift ;;
    --dry-run) DRY=1 ;;
    -h|--help) sed -n 2,22p "$0"; exit 0 ;;
    *) echo "run_grid.sh: unknown argument '$1' (try --help)" >&2; exit 2 ;;
  esac
  shift
done
[ "$DRY" = 1 ] || [ -x "$BIN/dw_bench" ] || { echo "run_grid.sh: no dw_bench in '$BIN'" >&2; exit 1; }
[ -z "$JOBS_FILE" ] || [ -f "$JOBS_FILE" ] || { echo "run_grid.sh: no job file '$JOBS_FILE'" >&2; exit 1; }
case "$WORKERS" in ''|*[!0-9]*|0) echo "run_grid.sh: --workers needs a positive integer" >&2; exit 2 ;; esac
case "$DEADLINE" in ''|*[!0-9]*) echo "run_grid.sh: --deadline needs whole seconds" >&2; exit 2 ;; esac

ALL="brute-force,pcl-kdtree,nanoflann,pcl-octree,walk-zero,walk-kd-ann,walk-pnn,walk-pnn-optimized,walk-pnn-optimized-prefetch,dw-estimator"
NO_OCTREE=${ALL/pcl-octree,/}
# --methods: the plan's method lists intersected with it (a job left with none is dropped).
keep() {
  if [ -z "$KEEP" ]; then echo "$1"; return; fi
  local out= m
  for m in ${1//,/ }; do
    case ",$KEEP," in *",$m,"*) out=${out:+$out,}$m ;; esac
  done
  echo "$out"
}
JOB_SECONDS=40  # target length of one job: long enough that loading and building (~1 s) stay small

# data set | methods | rotation set (grid: 124, axes: 12) | estimated CPU seconds per rotation and
# noise level for all its methods (measured on the 2-core development machine, single-axis rotations,
# x1.5 for the grid's larger compound rotations): decides how many shards a data set is cut into.
plan_main() {
  cat <<EOF
lidar-69k:half|$NO_OCTREE|grid|6.0
dragon-23k|$ALL|grid|4.7
bunny-8k|$ALL|grid|3.4
lidar-69k:quarter|$NO_OCTREE|grid|2.8
dragon-23k:half|$ALL|grid|2.2
bunny-8k:half|$ALL|grid|0.9
teapot-792|$ALL|grid|0.05
teapot-792:half|$ALL|grid|0.03
EOF
}
plan_extra() {
  cat <<EOF
dragon-100k|$ALL|axes|45
lidar-69k|$NO_OCTREE|axes|13
dragon-5k|$ALL|grid|1.25
EOF
}
plan_smoke() {
  cat <<EOF
teapot-792:quarter|nanoflann,walk-pnn|axes|0.01
EOF
}

# Jobs, one line each: "<name> <dw_bench arguments...>". Build and per-query NN sections first (one job
# per data set: walk statistics and histograms at every fidelity), then the ICP shards interleaved
# across data sets, so that a deadline trims every data set a little instead of dropping the last.
make_jobs() {
  local plan_fn=$1 sections_nn=$2
  local specs
  specs=$($plan_fn)
  if [ "$sections_nn" = 1 ]; then
    local sets
    sets=$(echo "$specs" | cut -d'|' -f1 | paste -sd, -)
    echo "build --sections build --repeats 2 --datasets $sets,lidar-69k,dragon-100k"
    echo "nn-dragon-100k --sections nn --threads 1 --repeats 2 --datasets dragon-100k --methods $(keep "$ALL")"
    while IFS='|' read -r d m r c; do
      m=$(keep "$m")
      [ -n "$m" ] && echo "nn-${d/:/-} --sections nn --threads 1 --repeats 2 --datasets $d --methods $m"
    done <<< "$specs"
  fi
  local max_shards=0 lines=()
  while IFS='|' read -r d m r c; do
    m=$(keep "$m")
    [ -n "$m" ] || continue
    local nrot=124
    [ "$r" = axes ] && nrot=12
    local shards
    shards=$(awk -v n=$nrot -v c="$c" -v j=$JOB_SECONDS 'BEGIN { s = int(n * c / j + 0.5); if (s < 1) s = 1; if (s > n) s = n; print s }')
    [ "$shards" -gt "$max_shards" ] && max_shards=$shards
    lines+=("$d|$m|$r|$shards")
  done <<< "$specs"
  for ((k = 0; k < max_shards; ++k)); do
    for noise in 0 1; do
      for l in "${lines[@]}"; do
        IFS='|' read -r d m r s <<< "$l"
        [ "$k" -lt "$s" ] || continue
        echo "icp-${d/:/-}-n$noise-$k-of-$s --sections icp --rotations $r --noise $noise --shard $k/$s --datasets $d --methods $m"
      done
    done
  done
}

mkdir -p "$OUT/jobs"
case "$PLAN" in
  main) make_jobs plan_main 1 ;;
  extra) make_jobs plan_extra 0 ;;
  all) make_jobs plan_main 1; make_jobs plan_extra 0 ;;
  smoke) make_jobs plan_smoke 0 ;;
  none) ;;
  *) echo "run_grid.sh: unknown plan '$PLAN'" >&2; exit 2 ;;
esac > "$OUT/jobs.txt"
[ -z "$JOBS_FILE" ] || grep -v '^[[:space:]]*\(#\|$\)' "$JOBS_FILE" >> "$OUT/jobs.txt"
if [ "$DRY" = 1 ]; then
  cat "$OUT/jobs.txt"
  exit 0
fi

START=$(date +%s)
export BIN OUT DEADLINE START
run_job() {
  local name=$1; shift
  local limit=0
  if [ "$DEADLINE" -gt 0 ]; then
    limit=$((START + DEADLINE - $(date +%s)))
    if [ "$limit" -le 0 ]; then
      echo "skipped (deadline): $name" >> "$OUT/skipped.txt"
      return 0
    fi
  fi
  mkdir -p "$OUT/jobs/$name"
  local t0=$(date +%s)
  if [ "$limit" -gt 0 ]; then
    timeout "$limit" "$BIN/dw_bench" --out "$OUT/jobs/$name" "$@" > "$OUT/jobs/$name/log.txt" 2>&1
  else
    "$BIN/dw_bench" --out "$OUT/jobs/$name" "$@" > "$OUT/jobs/$name/log.txt" 2>&1
  fi
  local rc=$?
  echo "$name $(( $(date +%s) - t0 ))s rc=$rc" >> "$OUT/done.txt"
}
export -f run_job
echo "run_grid.sh: $(wc -l < "$OUT/jobs.txt") jobs on $WORKERS workers, deadline ${DEADLINE}s (0: none), plan $PLAN"
xargs -P "$WORKERS" -L 1 bash -c 'run_job "$@"' _ < "$OUT/jobs.txt"
count() { if [ -f "$2" ]; then grep -c "$1" "$2"; else echo 0; fi; }
echo "run_grid.sh: finished in $(( $(date +%s) - START )) s; $(count 'rc=0$' "$OUT/done.txt") jobs complete," \
  "$(count 'rc=[1-9]' "$OUT/done.txt") stopped or failed, $(count . "$OUT/skipped.txt") skipped"
