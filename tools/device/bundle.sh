#!/usr/bin/env bash
# Run HERE: packs programs built on this machine (Debian 12, with PCL) together with every shared
# library they load into .deps/bundle/<name>.tar.xz, so that they run on the device machine, which has
# no PCL, Boost, FLANN, VTK or Qhull and no package archive. Debian 12's glibc (2.36) is older than the
# device's (Ubuntu 24.04), so binaries made here run there; glibc itself and the CUDA runtime/driver are
# left out (the device has its own, and the driver must match the GPU).
#   usage: tools/device/bundle.sh NAME BINARY [BINARY...]
# On the device (after naming .deps in `carry`):
#   mkdir -p /tmp/b && tar -xJf .deps/bundle/NAME.tar.xz -C /tmp/b && export LD_LIBRARY_PATH=/tmp/b/lib
#   /tmp/b/bin/<program> ...
set -euo pipefail
[ $# -ge 2 ] || { echo "usage: $0 NAME BINARY [BINARY...]" >&2; exit 2; }
ROOT=$(cd "$(dirname "$0")/../.." && pwd)
NAME=$1; shift
STAGE=$(mktemp -d)
trap 'rm -rf "$STAGE"' EXIT
mkdir -p "$STAGE/bin" "$STAGE/lib" "$ROOT/.deps/bundle"
for b in "$@"; do
  [ -x "$b" ] || { echo "$0: $b is not an executable" >&2; exit 1; }
  cp -L "$b" "$STAGE/bin/"
  ldd "$b" | awk '/=> \//{print $3}' | while read -r lib; do
    case "$(basename "$lib")" in
      libc.so.*|libm.so.*|libdl.so.*|librt.so.*|libpthread.so.*|ld-linux*|libcuda.so*|libcudart.so*|libnvidia*) ;;
      *) cp -Ln "$lib" "$STAGE/lib/" ;;
    esac
  done
done
tar -cJf "$ROOT/.deps/bundle/$NAME.tar.xz" -C "$STAGE" bin lib
du -h "$ROOT/.deps/bundle/$NAME.tar.xz"
du -sh "$ROOT/.deps"
