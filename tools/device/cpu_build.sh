#!/usr/bin/env bash
# Sourced by the device machine's CPU measurement scripts (tin_scaling.sh,
# builder3d_scaling.sh): the machine's description and the PCL-free, CUDA-free Release build
# they share. Expects DEPS (the carried .deps folder) and OUT to be set.

# device_machine_info FILE: CPU, memory, transparent huge pages and load, printed and kept in FILE.
device_machine_info() {
  { lscpu | grep -E "Model name|^CPU\(s\)|Thread|Socket|NUMA node\(s\)|MHz|L2|L3"; free -g | head -2;
    echo "THP: $(cat /sys/kernel/mm/transparent_hugepage/enabled)"; uptime; } | tee "$1"
}

# device_cpu_build SOURCE BUILD LOG_PREFIX TARGET...: configures SOURCE into BUILD (core only: no PCL,
# MPI, CUDA or benchmarks; Qhull from .deps) and builds the targets; logs go to $OUT/LOG_PREFIX_*.log.
# Returns non-zero, with the errors printed, when either step fails.
device_cpu_build() {
  local src=$1 build=$2 log=$3
  shift 3
  cmake -S "$src" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DDW_WITH_PCL=OFF -DDW_WITH_MPI=OFF \
    -DDW_WITH_CUDA=OFF -DDW_BUILD_BENCHMARKS=OFF -DQhull_DIR="$DEPS/qhull/lib/cmake/Qhull" ${DW_DEVICE_CMAKE_ARGS:-} \
    > "$OUT/${log}_configure.log" 2>&1 || { tail -30 "$OUT/${log}_configure.log"; return 1; }
  local t targets=()
  for t in "$@"; do targets+=(--target "$t"); done
  cmake --build "$build" "${targets[@]}" -j"$(nproc)" > "$OUT/${log}_build.log" 2>&1 \
    || { grep -E "error|FAILED" "$OUT/${log}_build.log" | head -30; return 1; }
}
