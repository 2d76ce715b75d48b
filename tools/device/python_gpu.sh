#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (CUDA 13, CMake, ninja, Eigen, Python 3 with headers and NumPy; no PCL, no
# pybind11) from the repository root, with .deps carried (tools/device/prepare.sh: Qhull, Debian 13's
# pybind11 and pytest): configures the PCL-free build, builds the Python package (_native and the CUDA
# extension _gpu), and runs python/tests/test_gpu.py on the GPU (gpu.DelaunayWalk against the CPU
# NeighbourSearch and a brute force, gpu.icp against a host ICP with PCL's rules), then the rest of
# the pytest suite for information (tests needing SciPy, PCL or GDAL skip or fail where those are
# missing; their result does not change the exit status). Writes ONE summary, $OUT/python_gpu.txt;
# build logs stay in /tmp/dw-python-gpu-logs. About two minutes on a fresh machine.
#   usage: tools/device/python_gpu.sh
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=${DW_DEVICE_DEPS:-$ROOT/.deps}
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-python-gpu}
LOGS=/tmp/dw-python-gpu-logs
# The interpreter with NumPy: the first python3 on PATH that imports it (the device's is a venv's).
PY=${DW_PYTHON:-}
if [ -z "$PY" ]; then
  for p in $(which -a python3) /usr/bin/python3; do "$p" -c "import numpy" 2>/dev/null && { PY=$p; break; }; done
  PY=${PY:-/usr/bin/python3}
fi
SUMMARY=$OUT/python_gpu.txt
mkdir -p "$OUT" "$LOGS"
export PATH=$PATH:/usr/local/cuda/bin
[ -d "$DEPS/pybind11/lib/cmake/pybind11" ] || { echo "no $DEPS/pybind11: run tools/device/prepare.sh here first"; exit 2; }
{
  echo "== python_gpu.sh $(date -u +%FT%TZ) commit $(git -C "$ROOT" rev-parse --short HEAD 2>/dev/null || echo '?')"
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader
  echo "$("$PY" --version), NumPy $("$PY" -c 'import numpy; print(numpy.__version__)' 2>&1)"
} > "$SUMMARY"
QHULL=()
[ -d "$DEPS/qhull/lib/cmake/Qhull" ] && QHULL=(-DQhull_DIR="$DEPS/qhull/lib/cmake/Qhull")
cmake -S "$ROOT" -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDW_WITH_PCL=OFF -DDW_WITH_MPI=OFF \
  -DDW_WITH_GDAL=OFF -DDW_BUILD_APPS=OFF -DDW_BUILD_BENCHMARKS=OFF -DBUILD_TESTING=OFF \
  -DCMAKE_CUDA_ARCHITECTURES=90 -DPython3_EXECUTABLE="$PY" -Dpybind11_DIR="$DEPS/pybind11/lib/cmake/pybind11" \
  "${QHULL[@]}" > "$LOGS/configure.log" 2>&1 || { echo "configure failed:"; tail -20 "$LOGS/configure.log"; } >> "$SUMMARY"
grep -E "pcl_delaunay_walk: (Python|PCL=)|Found pybind11" "$LOGS/configure.log" >> "$SUMMARY"
if ! cmake --build "$BUILD" --target dw_python_native -j"$(nproc)" > "$LOGS/build.log" 2>&1; then
  { echo "build failed:"; grep -E "error|FAILED" "$LOGS/build.log" | head -20; } >> "$SUMMARY"
  cat "$SUMMARY"
  exit 1
fi
. "$BUILD/python/test_env.sh"
# The device's own pytest where it has one, else the carried one (pure Python).
"$PY" -c "import pytest" 2>/dev/null || export PYTHONPATH=$PYTHONPATH:$DEPS/pytest
echo "pytest $("$PY" -c 'import pytest; print(pytest.__version__, pytest.__file__)')" >> "$SUMMARY"
rc=0
timeout 300 "$PY" -m pytest -v -rs -p no:cacheprovider python/tests/test_gpu.py > "$LOGS/test_gpu.log" 2>&1 || rc=$?
{ echo "-- pytest python/tests/test_gpu.py exit $rc"; grep -E "PASSED|FAILED|SKIPPED|ERROR|Error|assert|passed|failed" "$LOGS/test_gpu.log" | head -40; } >> "$SUMMARY"
r=0
timeout 300 "$PY" -m pytest -q -rs -p no:cacheprovider python/tests --ignore=python/tests/test_gpu.py > "$LOGS/test_rest.log" 2>&1 || r=$?
{ echo "-- pytest python/tests (the rest, information only) exit $r"; tail -15 "$LOGS/test_rest.log"; } >> "$SUMMARY"
cat "$SUMMARY"
exit $rc
