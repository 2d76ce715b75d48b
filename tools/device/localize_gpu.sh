#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (CUDA 13, CMake, ninja, Eigen, GoogleTest; no PCL) from the repository
# root, with .deps carried (tools/device/prepare.sh: Qhull): builds the PCL-free GPU module, test_gpu
# and bench_gpu_localize, runs the GPU localizer's tests (dw::gpu::Localizer against the CPU
# dw::Localizer: poses within 1e-5, per-frame statuses, warm starts) and the rest of test_gpu, then
# the small localization benchmark (CPU and GPU per-frame latency on the same scans). Writes ONE
# summary, $OUT/localize_gpu.txt; build logs stay in /tmp/dw-localize-gpu-logs. A few minutes.
# With DW_STREET="MAP_POINTS SCAN_POINTS [FRAMES]" it adds the benchmark on the generated street
# (bench_gpu_localize --street; a 10M-point map takes about a minute to build and cut).
#   usage: tools/device/localize_gpu.sh [FRAMES=40]
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-localize-gpu}
LOGS=/tmp/dw-localize-gpu-logs
FRAMES=${1:-40}
SUMMARY=$OUT/localize_gpu.txt
mkdir -p "$OUT" "$LOGS"
export PATH=$PATH:/usr/local/cuda/bin
{
  echo "== localize_gpu.sh $(date -u +%FT%TZ) commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo '?')"
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
  echo "CPU: $(lscpu | sed -n 's/^Model name: *//p'), $(nproc) threads"
} > "$SUMMARY"
QHULL=()
[ -d "$DEPS/qhull/lib/cmake/Qhull" ] && QHULL=(-DQhull_DIR="$DEPS/qhull/lib/cmake/Qhull")
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDW_WITH_PCL=OFF -DDW_WITH_MPI=OFF \
  -DDW_BUILD_APPS=OFF -DDW_BUILD_BENCHMARKS=OFF -DCMAKE_CUDA_ARCHITECTURES=90 "${QHULL[@]}" \
  > "$LOGS/configure.log" 2>&1 || { echo "configure failed:"; tail -20 "$LOGS/configure.log"; } >> "$SUMMARY"
if ! cmake --build "$BUILD" --target test_gpu bench_gpu_localize -j"$(nproc)" > "$LOGS/build.log" 2>&1; then
  { echo "build failed:"; grep -E "error|FAILED" "$LOGS/build.log" | head -20; } >> "$SUMMARY"
  cat "$SUMMARY"
  exit 1
fi
rc=0
timeout 200 "$BUILD/gpu/test_gpu" --gtest_filter='GpuLocalizer.*' > "$LOGS/test_localizer.log" 2>&1 || rc=$?
{
  echo "-- test_gpu GpuLocalizer.* exit $rc"
  grep -E "^\[ *(OK|FAILED|SKIPPED) *\]|Failure|Expected|Which is|frame" "$LOGS/test_localizer.log" | head -40
} >> "$SUMMARY"
r=0
timeout 200 "$BUILD/gpu/test_gpu" --gtest_filter='-GpuLocalizer.*' > "$LOGS/test_rest.log" 2>&1 || r=$?
[ $r = 0 ] || rc=$r
echo "-- test_gpu (the rest) exit $r: $(grep -E '^\[  (PASSED|FAILED|SKIPPED)' "$LOGS/test_rest.log" | tr '\n' ' ')" >> "$SUMMARY"
r=0
{ echo "-- bench_gpu_localize $FRAMES frames"; timeout 200 "$BUILD/gpu/bench_gpu_localize" "$FRAMES" 2>&1; } \
  >> "$SUMMARY" || r=$?
echo "-- bench exit $r" >> "$SUMMARY"
[ $r = 0 ] || rc=$r
if [ -n "${DW_STREET:-}" ]; then
  r=0
  # shellcheck disable=SC2086  # MAP_POINTS SCAN_POINTS [FRAMES] as separate arguments
  { echo "-- bench_gpu_localize --street $DW_STREET"; timeout 300 "$BUILD/gpu/bench_gpu_localize" --street $DW_STREET 2>&1; } \
    >> "$SUMMARY" || r=$?
  echo "-- street bench exit $r" >> "$SUMMARY"
  [ $r = 0 ] || rc=$r
fi
cat "$SUMMARY"
exit $rc
