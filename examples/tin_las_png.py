"""Triangulate a LAS tile's ground points and save a PNG of the TIN coloured by height; with a third
argument, also write the TIN-linear DEM (cells of 1 coordinate unit) as a GeoTIFF with the tile's CRS, as dw_dem does.

    . build/python/test_env.sh && $DW_PYTHON examples/tin_las_png.py [tile.las] [out.png] [dem.tif]

Default tile: /work/shared/data/airborne/autzen_trim.las (or make one with build/apps/dw_lidar_gen).
"""

import sys
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import matplotlib.tri as mtri  # noqa: E402

import pcl_delaunay_walk as dw  # noqa: E402

path = sys.argv[1] if len(sys.argv) > 1 else "/work/shared/data/airborne/autzen_trim.las"
out = sys.argv[2] if len(sys.argv) > 2 else "tin.png"
t0 = time.perf_counter()
cloud = dw.read_las(path, classification=2)  # ground
xyz = cloud["xyz"]
if len(xyz) < 3:
    cloud = dw.read_las(path)
    xyz = cloud["xyz"]
t1 = time.perf_counter()
centre = xyz.mean(axis=0)
local = xyz - centre  # a centred frame keeps the exact predicates rare
tris = dw.tin(local)
t2 = time.perf_counter()
print(f"{path}: {len(xyz)} points read in {t1 - t0:.3f} s; {len(tris)} triangles in {t2 - t1:.3f} s")
fig, ax = plt.subplots(figsize=(8, 8), dpi=150)
tri = mtri.Triangulation(local[:, 0], local[:, 1], tris.astype("int64"))
shade = ax.tripcolor(tri, local[:, 2] + centre[2], shading="gouraud", cmap="terrain")
ax.triplot(tri, color="k", linewidth=0.05, alpha=0.3)
ax.set_aspect("equal")
ax.set_title(f"{len(tris)} Delaunay triangles of {len(xyz)} points")
ax.set_xlabel(f"x - {centre[0]:.1f}")
ax.set_ylabel(f"y - {centre[1]:.1f}")
fig.colorbar(shade, ax=ax, label="z", shrink=0.8)
fig.savefig(out, bbox_inches="tight")
print(f"wrote {out}")

if len(sys.argv) > 3 and dw.HAVE_GDAL:
    t3 = time.perf_counter()
    raster, gt = dw.raster_from_tin(local, 1.0, triangles=tris)
    world_gt = (gt[0] + centre[0], gt[1], 0.0, gt[3] + centre[1], 0.0, gt[5])  # back to the tile's frame
    r = dw.write_dem(sys.argv[3], raster + centre[2] * (raster != -9999), geotransform=world_gt,
                     crs_wkt=dw.las_crs_wkt(path) or None)
    print(f"wrote {sys.argv[3]}: {r['shape'][1]} x {r['shape'][0]} cells, {r['cells_set']} set, "
          f"in {time.perf_counter() - t3:.3f} s")
