#!/usr/bin/env bash
# Run ON THE DEVICE MACHINE (16 CPU cores, no PCL, no node) from the repository root, with .deps carried
# after `DW_DEVICE_NODE=1 tools/device/prepare.sh` (node as .deps/node/node.xz, npm's laz-perf under
# .deps/lazperf, the shared format-8 LAZ file): builds dw_laz_bench and measures the single-thread
# decode of our LAZ codec against laz-perf (LASzip compiled to WASM, run by the carried node) on the
# same files in the same run, on a quiet machine: the shared LAS 1.4 format-8 file with extra bytes,
# and synthetic tiles of format 1 and format 8 (variable chunks) that our encoder writes there.
# Best of 5; prints the wall and CPU-time ratios. About one minute; logs go to $OUT.
#   usage: tools/device/laz_lazperf.sh
set -uo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
OUT=${OUT:-$ROOT/out}
DEPS=$ROOT/.deps
BUILD=${DW_DEVICE_BUILD:-/tmp/dw-build-laz}
mkdir -p "$OUT"
. "$ROOT/tools/device/cpu_build.sh"
device_machine_info "$OUT/laz_machine.txt"
device_cpu_build "$ROOT" "$BUILD" laz dw_laz_bench || exit 1

NODE_DIR=/tmp/dw-node
mkdir -p "$NODE_DIR"
[ -x "$NODE_DIR/node" ] || xz -dc "$DEPS/node/node.xz" > "$NODE_DIR/node" && chmod +x "$NODE_DIR/node"
export PATH="$NODE_DIR:$PATH"
echo "node $(node --version)"

B="$BUILD/bench/dw_laz_bench"
rc=0
run() {  # label, then dw_laz_bench arguments
  local label=$1; shift
  echo "== $label"
  timeout 200 "$B" "$@" --threads 1 --repeats 5 --lazperf "$DEPS/lazperf" 2>&1 | tee -a "$OUT/laz_lazperf.txt" || rc=1
}
run "shared format 8 + extra bytes" "$DEPS/data/airborne/las_with_several_extra_byte_bloc.laz"
run "synthetic 2M format 1, 50k chunks" -n 2M --format 1
run "synthetic 2M format 8, variable chunks" -n 2M --format 8 --variable-chunks
exit $rc
