#!/usr/bin/env bash
# Run HERE (the development machine), once per checkout, before using the device machine: fills the
# git-ignored folder .deps/ with what the device lacks: Qhull (headers, the reentrant library and a
# minimal CMake package), nanoflann's header, the real clouds the GPU tests and benchmarks read, and
# the benchmark-only peers' headers (nanoflann 1.12, pico_tree, small_gicp) for tools/device/peers.sh,
# and pybind11 and pytest for tools/device/python_gpu.sh.
# The device call then names .deps in `carry` and runs tools/device/run.sh.
set -euo pipefail
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
DEPS=$ROOT/.deps
DATA=${DW_SHARED_DATA_DIR:-$ROOT/../shared/data}
mkdir -p "$DEPS/qhull/include" "$DEPS/qhull/lib/cmake/Qhull" "$DEPS/nanoflann" "$DEPS/data/models" "$DEPS/data/scans"

cp -r /usr/include/libqhull_r "$DEPS/qhull/include/"
cp -L /usr/lib/x86_64-linux-gnu/libqhull_r.so.8.0 "$DEPS/qhull/lib/"
# Debian's own QhullTargets.cmake insists on every Qhull library being present; the core needs only
# the reentrant C library, so a five-line package config stands in for it.
cat > "$DEPS/qhull/lib/cmake/Qhull/QhullConfig.cmake" <<'CFG'
get_filename_component(_dw_qhull_prefix "${CMAKE_CURRENT_LIST_DIR}/../../.." ABSOLUTE)
if(NOT TARGET Qhull::qhull_r)
  add_library(Qhull::qhull_r SHARED IMPORTED)
  set_target_properties(Qhull::qhull_r PROPERTIES IMPORTED_LOCATION "${_dw_qhull_prefix}/lib/libqhull_r.so.8.0"
    INTERFACE_INCLUDE_DIRECTORIES "${_dw_qhull_prefix}/include")
endif()
set(Qhull_FOUND TRUE)
CFG

cp /usr/include/nanoflann.hpp "$DEPS/nanoflann/"
# The real clouds and the KITTI frames (tools/device/localize.sh reads the KITTI pair).

for f in dragon_vrip.ply.gz dragon_vrip_res2.ply.gz dragon_vrip_res3.ply dragon_vrip_res4.ply bun000.ply bun045.ply; do
  cp "$DATA/models/$f" "$DEPS/data/models/"
done
for f in fastgicp_251370668.pcd fastgicp_251371071.pcd fastgicp_relative.txt kitti_000000.bin kitti_000001.bin; do
  cp "$DATA/scans/$f" "$DEPS/data/scans/"
done
mkdir -p "$DEPS/data/airborne"
cp "$DATA/airborne/autzen_trim.las" "$DEPS/data/airborne/"
# The benchmark-only peers of tools/device/peers.sh and localize.sh (headers only, with their
# licences), laid out as bench/CMakeLists.txt looks for them under -DDW_PEERS_DIR=.deps/peers:
# nanoflann/include/nanoflann.hpp, pico_tree/src/pico_tree/pico_tree/kd_tree.hpp and
# small_gicp/include/small_gicp/....
PEERS=${DW_PEERS_DIR:-$ROOT/../shared/peers}
if [ -d "$PEERS" ]; then
  mkdir -p "$DEPS/peers/nanoflann" "$DEPS/peers/pico_tree/src" "$DEPS/peers/small_gicp"
  cp -r "$PEERS/nanoflann/include" "$PEERS/nanoflann/COPYING" "$DEPS/peers/nanoflann/"
  cp -r "$PEERS/pico_tree/src/pico_tree" "$DEPS/peers/pico_tree/src/"
  cp "$PEERS/pico_tree/COPYING.txt" "$DEPS/peers/pico_tree/"
  cp -r "$PEERS/small_gicp/include" "$PEERS/small_gicp/LICENSE" "$DEPS/peers/small_gicp/"
  cp "$PEERS/README.md" "$DEPS/peers/"
else
  echo "prepare.sh: no peers at $PEERS: tools/device/peers.sh will run without them"
fi
# With DW_DEVICE_NODE=1: node (compressed; the device has none), npm's laz-perf and the shared LAZ file,
# for tools/device/laz_lazperf.sh.
if [ "${DW_DEVICE_NODE:-0}" = 1 ]; then
  mkdir -p "$DEPS/node"
  [ -f "$DEPS/node/node.xz" ] || xz -T0 -6 -c "$(readlink -f "$(command -v node)")" > "$DEPS/node/node.xz"
  cp "$DATA/airborne/las_with_several_extra_byte_bloc.laz" "$DEPS/data/airborne/"
  [ -d "$DEPS/lazperf/node_modules/laz-perf" ] || echo "prepare.sh: no laz-perf in .deps/lazperf (scripts/setup.sh installs it)"
fi
# The Python package's device run (tools/device/python_gpu.sh): pybind11 and pytest, both taken from
# Debian 13 (trixie) through apt with a private source list and state, so the machine's own apt setup
# is untouched. Debian 12's pybind11 2.10 cannot serve the device's NumPy 2: it reads a dtype's
# element size at NumPy 1's PyArray_Descr offset (NumPy 2 moved it and widened it to npy_intp), so
# every array it allocates gets wrong strides; pybind11 >= 2.12 reads either layout. The pytest set
# (pytest, pluggy, iniconfig, packaging) is pure Python; the script prefers the device's own pytest.
fetch_debian13() {  # package...: unpacked under $DEPS/debian13
  local apt=/tmp/dw-prepare-apt
  local o=(-o Dir::Etc::SourceList=$apt/sources.list -o Dir::Etc::SourceParts=/dev/null
           -o Dir::State::Lists=$apt/lists -o Dir::Cache=$apt/cache -o APT::Sandbox::User=root)
  mkdir -p "$apt/lists/partial" "$apt/cache/archives/partial" "$apt/debs" "$DEPS/debian13"
  echo "deb [signed-by=/usr/share/keyrings/debian-archive-keyring.gpg] http://deb.debian.org/debian trixie main" \
    > "$apt/sources.list"
  apt-get "${o[@]}" -qq update
  (cd "$apt/debs" && apt-get "${o[@]}" -qq download "$@")
  for deb in "$apt"/debs/*.deb; do dpkg-deb -x "$deb" "$DEPS/debian13"; done
}
if [ ! -d "$DEPS/pybind11/include/pybind11" ] || [ ! -d "$DEPS/pytest/_pytest" ]; then
  fetch_debian13 pybind11-dev python3-pytest python3-pluggy python3-iniconfig python3-packaging
  rm -rf "$DEPS/pybind11" "$DEPS/pytest"
  mkdir -p "$DEPS/pybind11/include" "$DEPS/pybind11/lib/cmake" "$DEPS/pytest"
  cp -r "$DEPS/debian13/usr/include/pybind11" "$DEPS/pybind11/include/"
  cp -r "$DEPS/debian13/usr/lib/cmake/pybind11" "$DEPS/pybind11/lib/cmake/"
  cp -r "$DEPS"/debian13/usr/lib/python3/dist-packages/* "$DEPS/pytest/"
  rm -rf "$DEPS/debian13"
fi
du -sh "$DEPS"
