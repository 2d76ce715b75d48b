#!/usr/bin/env python3
"""Runs dw_viewer under xvfb-run and checks what it wrote.

Modes:
  --app APP --out OUT.png --size WxH [--background R,G,B] [--make-mesh PLY] -- ARGS...
      runs `xvfb-run APP ARGS --screenshot OUT --size WxH`, then checks that OUT is a PNG of exactly
      WxH pixels and that enough of its pixels differ from the background colour; with
      --expect-stdout TEXT (repeatable) also that the run printed these texts in this order; with
      --expect-colour R,G,B,N (repeatable) that at least N pixels have that colour (within 8 per
      channel); with --make-drifted-poses TRUE OUT first writes OUT, the KITTI poses of TRUE with a
      translation drift growing by (0.05, 0.03, 0) m per frame (an "estimate" to show beside them).
  --app APP [--no-display] --expect-error RC TEXT -- ARGS...
      runs APP ARGS (under xvfb-run unless --no-display, which also removes DISPLAY) and checks that it
      exits with RC and says TEXT on stderr, without a crash.
  --self-test
      the PNG check itself must reject a blank image and a wrongly sized one.

Exit 77 (ctest SKIP_RETURN_CODE) when xvfb-run is needed but missing. PNG is decoded with zlib from
the standard library, so no imaging package is needed.
"""
import argparse
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

SKIP = 77
XVFB_SERVER_ARGS = "-screen 0 1280x1024x24"


class PngError(Exception):
    pass


def read_png(path):
    """Returns (width, height, channels, rows) with rows as bytearrays of 8-bit samples."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise PngError("not a PNG file")
    pos, ihdr, idat = 8, None, bytearray()
    while pos + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        body = data[pos + 8:pos + 8 + length]
        if len(body) != length or pos + 12 + length > len(data):
            raise PngError("truncated chunk %r" % kind)
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        if zlib.crc32(kind + body) & 0xFFFFFFFF != crc:
            raise PngError("bad CRC in chunk %r" % kind)
        if kind == b"IHDR":
            ihdr = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        elif kind == b"IEND":
            break
        pos += 12 + length
    if ihdr is None:
        raise PngError("no IHDR chunk")
    width, height, depth, colour, _, _, interlace = ihdr
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour)
    if depth != 8 or channels is None or interlace != 0:
        raise PngError("unsupported PNG (bit depth %d, colour type %d, interlace %d)" % (depth, colour, interlace))
    raw = zlib.decompress(bytes(idat))
    stride = width * channels
    if len(raw) != height * (stride + 1):
        raise PngError("image data has %d bytes, expected %d" % (len(raw), height * (stride + 1)))
    rows, prev = [], bytearray(stride)
    for y in range(height):
        ftype = raw[y * (stride + 1)]
        line = bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for i in range(stride):
            a = line[i - channels] if i >= channels else 0
            b = prev[i]
            c = prev[i - channels] if i >= channels else 0
            if ftype == 1:
                line[i] = (line[i] + a) & 0xFF
            elif ftype == 2:
                line[i] = (line[i] + b) & 0xFF
            elif ftype == 3:
                line[i] = (line[i] + ((a + b) >> 1)) & 0xFF
            elif ftype == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                pred = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
                line[i] = (line[i] + pred) & 0xFF
            elif ftype != 0:
                raise PngError("bad filter type %d in row %d" % (ftype, y))
        rows.append(line)
        prev = line
    return width, height, channels, rows


def write_png(path, width, height, pixel):
    """Writes an RGB PNG; pixel(x, y) -> (r, g, b). For the self-test."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)
        for x in range(width):
            raw += bytes(pixel(x, y))

    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF)

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(bytes(raw))) + chunk(b"IEND", b""))


def check_png(path, width, height, background, min_fraction, tolerance=3, colours=()):
    """Returns a list of problems (empty when the image passes). colours: (r, g, b, n) tuples, each
    needing n pixels within 8 per channel of (r, g, b)."""
    try:
        w, h, channels, rows = read_png(path)
    except (OSError, PngError, zlib.error) as e:
        return ["cannot decode %s: %s" % (path, e)]
    problems = []
    if (w, h) != (width, height):
        problems.append("image is %dx%d, expected %dx%d" % (w, h, width, height))
    counts = {}
    for line in rows:
        for x in range(0, len(line), channels):
            px = tuple(line[x:x + 3]) if channels >= 3 else (line[x],) * 3
            counts[px] = counts.get(px, 0) + 1
    total = max(1, w * h)
    mode, mode_count = max(counts.items(), key=lambda kv: kv[1])
    if background is not None and any(abs(m - b) > tolerance for m, b in zip(mode, background)):
        problems.append("most common colour %s is not the background %s" % (mode, background))
    bg = background if background is not None else mode
    foreground = sum(n for px, n in counts.items() if any(abs(p - b) > tolerance for p, b in zip(px, bg)))
    fraction = foreground / total
    print("%s: %dx%d, %d colours, %.1f%% non-background pixels" % (path, w, h, len(counts), 100 * fraction))
    if fraction < min_fraction:
        problems.append("only %.3f%% of the pixels differ from the background (need %.1f%%)" %
                        (100 * fraction, 100 * min_fraction))
    for r, g, b, need in colours:
        have = sum(n for px, n in counts.items() if all(abs(p - c) <= 8 for p, c in zip(px, (r, g, b))))
        print("%s: %d pixels of colour (%d, %d, %d)" % (path, have, r, g, b))
        if have < need:
            problems.append("only %d pixels of colour (%d, %d, %d), need %d" % (have, r, g, b, need))
    return problems


def self_test():
    tmp = tempfile.mkdtemp(prefix="dw_viewer_check_")
    bg = (18, 20, 26)
    blank = os.path.join(tmp, "blank.png")
    write_png(blank, 64, 48, lambda x, y: bg)
    drawn = os.path.join(tmp, "drawn.png")
    write_png(drawn, 64, 48, lambda x, y: (200, 120, 40) if 20 <= x < 40 and 10 <= y < 30 else bg)
    failures = []
    if not check_png(blank, 64, 48, bg, 0.01):
        failures.append("a blank image passed")
    if not check_png(drawn, 65, 48, bg, 0.01):
        failures.append("a wrongly sized image passed")
    if check_png(drawn, 64, 48, bg, 0.01):
        failures.append("a valid image failed")
    if check_png(drawn, 64, 48, bg, 0.01, colours=[(200, 120, 40, 400)]):
        failures.append("a colour that is present was not found")
    if not check_png(drawn, 64, 48, bg, 0.01, colours=[(40, 255, 90, 1)]):
        failures.append("a colour that is absent was found")
    corrupt = os.path.join(tmp, "corrupt.png")
    with open(drawn, "rb") as f:
        data = bytearray(f.read())
    data[40] ^= 0xFF
    with open(corrupt, "wb") as f:
        f.write(data)
    if not check_png(corrupt, 64, 48, bg, 0.01):
        failures.append("a corrupt image passed")
    shutil.rmtree(tmp, ignore_errors=True)
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


def make_terrain_mesh(path, n=40):
    """A small hilly terrain as an ASCII PLY mesh with quads and triangles, as a stand-in for dw_tin's
    output (the viewer must fan quads into triangles)."""
    import math
    verts, faces = [], []
    for j in range(n):
        for i in range(n):
            x, y = 5000000.0 + i * 2.0, 600000.0 + j * 2.0  # georeferenced-like coordinates
            z = 100.0 + 8.0 * math.sin(i / 6.0) * math.cos(j / 7.0) + 0.1 * i
            verts.append((x, y, z))
    for j in range(n - 1):
        for i in range(n - 1):
            a, b, c, d = j * n + i, j * n + i + 1, (j + 1) * n + i + 1, (j + 1) * n + i
            if (i + j) % 2:
                faces.append((a, b, c, d))
            else:
                faces.extend([(a, b, c), (a, c, d)])
    with open(path, "w") as f:
        f.write("ply\nformat ascii 1.0\nelement vertex %d\nproperty double x\nproperty double y\n"
                "property double z\nelement face %d\nproperty list uchar int vertex_indices\nend_header\n" %
                (len(verts), len(faces)))
        for v in verts:
            f.write("%.3f %.3f %.3f\n" % v)
        for face in faces:
            f.write("%d %s\n" % (len(face), " ".join(map(str, face))))


def make_drifted_poses(truth, out):
    """Writes the KITTI poses of `truth` with a translation drift growing by (0.05, 0.03, 0) m per frame."""
    rows = []
    with open(truth) as f:
        for line in f:
            v = [float(t) for t in line.split()]
            if not v:
                continue
            if len(v) != 12:
                raise ValueError("%s: a line without 12 numbers" % truth)
            k = len(rows)
            v[3] += 0.05 * k
            v[7] += 0.03 * k
            rows.append(" ".join("%.9e" % t for t in v))
    with open(out, "w") as f:
        f.write("\n".join(rows) + "\n")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--self-test", action="store_true")
    ap.add_argument("--app")
    ap.add_argument("--out")
    ap.add_argument("--size", default="640x480")
    ap.add_argument("--background")
    ap.add_argument("--min-fraction", type=float, default=0.02)
    ap.add_argument("--make-mesh")
    ap.add_argument("--make-drifted-poses", nargs=2, metavar=("TRUE", "OUT"))
    ap.add_argument("--expect-colour", action="append", default=[],
                    help="R,G,B,N: at least N pixels of this colour (repeatable)")
    ap.add_argument("--require-file", action="append", default=[],
                    help="skip (exit 77) when this input is absent (shared data)")
    ap.add_argument("--no-display", action="store_true")
    ap.add_argument("--expect-error", nargs=2, metavar=("RC", "TEXT"))
    ap.add_argument("--expect-stdout", action="append", default=[],
                    help="text the screenshot run must print (repeatable, in this order)")
    ap.add_argument("args", nargs="*")
    opt = ap.parse_args()
    if opt.self_test:
        return self_test()
    if not opt.app:
        ap.error("--app is required")

    for path in opt.require_file:
        if not os.path.exists(path):
            print("SKIP: %s is not present (../shared/data is optional)" % path)
            return SKIP

    env = dict(os.environ)
    if opt.no_display:
        env.pop("DISPLAY", None)
        prefix = []
    else:
        if shutil.which("xvfb-run") is None:
            print("SKIP: xvfb-run not found (Debian: apt-get install xvfb xauth)")
            return SKIP
        prefix = ["xvfb-run", "-a", "-s", XVFB_SERVER_ARGS]

    if opt.expect_error:
        rc_expected, text = int(opt.expect_error[0]), opt.expect_error[1]
        run = subprocess.run(prefix + [opt.app] + opt.args, env=env, capture_output=True, text=True, timeout=240)
        print(run.stdout + run.stderr)
        if run.returncode != rc_expected:
            print("FAIL: exit code %d, expected %d" % (run.returncode, rc_expected))
            return 1
        if text not in run.stderr:
            print("FAIL: stderr does not say %r" % text)
            return 1
        return 0

    if not opt.out:
        ap.error("--out is required")
    width, height = (int(v) for v in opt.size.split("x"))
    background = tuple(int(v) for v in opt.background.split(",")) if opt.background else None
    if opt.make_mesh:
        make_terrain_mesh(opt.make_mesh)
    if opt.make_drifted_poses:
        make_drifted_poses(*opt.make_drifted_poses)
    colours = [tuple(int(v) for v in c.split(",")) for c in opt.expect_colour]
    if os.path.exists(opt.out):
        os.remove(opt.out)
    cmd = prefix + [opt.app] + opt.args + ["--screenshot", opt.out, "--size", opt.size]
    print("running:", " ".join(cmd))
    run = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=240)
    print(run.stdout + run.stderr)
    if run.returncode != 0:
        print("FAIL: dw_viewer exited with %d" % run.returncode)
        return 1
    if not os.path.exists(opt.out):
        print("FAIL: no screenshot at %s" % opt.out)
        return 1
    problems = check_png(opt.out, width, height, background, opt.min_fraction, colours=colours)
    pos = 0
    for text in opt.expect_stdout:
        found = run.stdout.find(text, pos)
        if found < 0:
            problems.append("stdout does not say %r (after position %d)" % (text, pos))
        else:
            pos = found + len(text)
    for p in problems:
        print("FAIL:", p)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
