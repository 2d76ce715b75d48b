#!/usr/bin/env python3
"""Writes the small LAS seed files of fuzz/corpus/las (LAS 1.2 formats 0 and 3, LAS 1.4 format 6 with
extra bytes), laid out from the ASPRS LAS 1.2/1.4 specifications. Run from this folder."""
import struct


def header(minor, fmt, rec_len, n, pts):
    size = {2: 227, 3: 235, 4: 375}[minor]
    xs, ys, zs = ([p[i] * 0.01 for p in pts] or [0.0] for i in range(3))
    h = b'LASF' + struct.pack('<HH', 0, 0) + bytes(16) + struct.pack('<BB', 1, minor)
    h += b'pcl_delaunay_walk'.ljust(32, b'\0') + b'fuzz seed'.ljust(32, b'\0')
    h += struct.pack('<HHHIIBHI', 1, 2026, size, size, 0, fmt, rec_len, n if fmt < 6 else 0)
    h += struct.pack('<5I', n if fmt < 6 else 0, 0, 0, 0, 0)
    h += struct.pack('<3d', 0.01, 0.01, 0.01) + struct.pack('<3d', 0.0, 0.0, 0.0)
    h += struct.pack('<6d', max(xs), min(xs), max(ys), min(ys), max(zs), min(zs))
    if minor >= 3:
        h += struct.pack('<Q', 0)
    if minor >= 4:
        h += struct.pack('<QIQ', 0, 0, n) + struct.pack('<15Q', n, *([0] * 14))
    assert len(h) == size, (len(h), size)
    return h


def record(fmt, p, i, extra):
    x, y, z = p
    if fmt in (0, 3):
        r = struct.pack('<iiiHBBbBH', x, y, z, 100 + i, 0x09, 2, 0, 0, 1)
        if fmt == 3:
            r += struct.pack('<d3H', 1000.5 + i, 10, 20, 30)
    else:  # 6
        r = struct.pack('<iiiHBBBBhHd', x, y, z, 100 + i, 0x11, 0, 2, 0, 0, 1, 1000.5 + i)
    return r + bytes(extra)


def write(name, minor, fmt, base, pts, extra=0):
    body = b''.join(record(fmt, p, i, extra) for i, p in enumerate(pts))
    with open(name, 'wb') as f:
        f.write(header(minor, fmt, base + extra, len(pts), pts) + body)


grid = [(x * 100, y * 100, (x * y) % 7) for x in range(3) for y in range(3)]
write('las/v12_pdrf0_grid.las', 2, 0, 20, grid)
write('las/v12_pdrf3.las', 2, 3, 34, [(0, 0, 0), (150, 0, 10), (0, 150, 20)])
write('las/v14_pdrf6_extra_bytes.las', 4, 6, 30, [(5, 5, 5), (-5, 5, 0), (5, -5, 1), (-5, -5, 2)], extra=3)
write('las/v12_empty.las', 2, 0, 20, [])
