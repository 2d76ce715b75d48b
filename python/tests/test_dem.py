"""raster_from_tin reproduces a plane exactly inside the hull (nodata outside) and matches a direct
TIN-linear evaluation; write_dem writes a GeoTIFF that GDAL reads back with the right geotransform,
nodata and cells; bad input raises."""

import subprocess

import numpy as np
import pytest

import pcl_delaunay_walk as dw


def plane_points(rng, n=200):
    xy = rng.uniform(0, 10, (n, 2))
    return np.c_[xy, 0.5 * xy[:, 0] - 0.25 * xy[:, 1] + 3.0]


def inside_hull(xy, hull_pts):
    from scipy.spatial import Delaunay

    return Delaunay(hull_pts).find_simplex(xy) >= 0


def cell_centres(shape, gt):
    rows, cols = shape
    x = gt[0] + (np.arange(cols) + 0.5) * gt[1]
    y = gt[3] + (np.arange(rows) + 0.5) * gt[5]
    return np.meshgrid(x, y)


def test_plane_is_reproduced_inside_the_hull_and_nodata_outside():
    rng = np.random.default_rng(3)
    pts = plane_points(rng)
    raster, gt = dw.raster_from_tin(pts, 0.5)
    assert gt[1] == 0.5 and gt[5] == -0.5 and gt[2] == gt[4] == 0
    assert gt[0] <= pts[:, 0].min() and gt[3] >= pts[:, 1].max() and gt[0] % 0.5 == 0
    cx, cy = cell_centres(raster.shape, gt)
    inside = inside_hull(np.c_[cx.ravel(), cy.ravel()], pts[:, :2]).reshape(raster.shape)
    strictly = inside_hull(np.c_[cx.ravel(), cy.ravel()] + 1e-9, pts[:, :2]).reshape(raster.shape) & inside
    set_ = raster != -9999
    assert set_[strictly].all() and not set_[~inside].any()
    np.testing.assert_allclose(raster[set_], 0.5 * cx[set_] - 0.25 * cy[set_] + 3.0, rtol=0, atol=1e-12)
    # The same with the caller's triangles, float32 input and another thread count.
    r2, gt2 = dw.raster_from_tin(pts, 0.5, triangles=dw.tin(pts), threads=1)
    np.testing.assert_array_equal(r2, raster)
    assert gt2 == gt


def test_tiny_tin_matches_direct_linear_interpolation():
    # Two triangles of a non-planar square: each cell centre takes its own triangle's plane.
    pts = np.array([[0, 0, 1.0], [4, 0, 2.0], [4, 4, 7.0], [0, 4, 3.0]])
    tri = np.array([[0, 1, 2], [0, 2, 3]])
    raster, gt = dw.raster_from_tin(pts, 1.0, bounds=(0, 0, 4, 4), triangles=tri, nodata=-1.0)
    assert raster.shape == (4, 4) and gt == (0.0, 1.0, 0.0, 4.0, 0.0, -1.0)
    cx, cy = cell_centres(raster.shape, gt)
    # Planes through the corners: (0, 1, 2) z = 1 + x/4 + 5y/4 below the diagonal, (0, 2, 3)
    # z = 1 + x + y/2 above it (no centre lies on it).
    below = cy < cx
    want = np.where(below, 1 + 0.25 * cx + 1.25 * cy, 1 + 1.0 * cx + 0.5 * cy)
    np.testing.assert_allclose(raster, want, rtol=0, atol=1e-12)
    # A longer edge than max_edge kills both triangles.
    killed, _ = dw.raster_from_tin(pts, 1.0, bounds=(0, 0, 4, 4), triangles=tri, nodata=-1.0, max_edge=4.5)
    assert (killed == -1.0).all()
    wider, gtw = dw.raster_from_tin(pts, 1.0, bounds=(-2, 0, 4, 4), triangles=tri, nodata=-1.0)
    assert wider.shape == (4, 6) and (wider[:, :2] == -1.0).all()
    np.testing.assert_array_equal(wider[:, 2:], raster)


def read_back(path):
    try:
        from osgeo import gdal
    except ImportError:
        gdal = None
    if gdal is not None:
        ds = gdal.Open(str(path))
        band = ds.GetRasterBand(1)
        return ds.GetGeoTransform(), band.GetNoDataValue(), band.ReadAsArray().astype(np.float64), ds.GetProjection()
    info = subprocess.run(["gdalinfo", str(path)], check=True, capture_output=True, text=True).stdout
    pytest.skip("osgeo missing: " + info.splitlines()[0])


pytestmark_gdal = pytest.mark.skipif(not dw.HAVE_GDAL, reason="built without GDAL")


@pytestmark_gdal
@pytest.mark.parametrize("cog", [False, True])
def test_write_dem_points_and_raster_read_back(tmp_path, cog):
    rng = np.random.default_rng(5)
    pts = plane_points(rng)
    raster, gt = dw.raster_from_tin(pts, 0.5)
    wkt = 'GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]]'
    out = tmp_path / "dem.tif"
    r = dw.write_dem(str(out), pts, resolution=0.5, crs_wkt=wkt, cog=cog, float64=True,
                     hillshade=str(tmp_path / "shade.png"))
    assert r["geotransform"] == gt and r["shape"] == raster.shape
    assert r["cells_set"] == (raster != -9999).sum()
    got_gt, nodata, cells, proj = read_back(out)
    assert got_gt == gt and nodata == -9999
    np.testing.assert_array_equal(cells, raster)
    assert "WGS" in proj and (tmp_path / "shade.png").stat().st_size > 0
    out2 = tmp_path / "raster.tif"
    r2 = dw.write_dem(str(out2), raster.astype(np.float32), geotransform=gt, nodata=-9999.0)
    got_gt, nodata, cells, _ = read_back(out2)
    assert got_gt == gt and nodata == -9999 and r2["cells_set"] == r["cells_set"]
    np.testing.assert_array_equal(cells, raster.astype(np.float32))


def test_bad_input_raises(tmp_path):
    pts = plane_points(np.random.default_rng(1), 20)
    with pytest.raises(ValueError, match="resolution"):
        dw.raster_from_tin(pts, 0)
    with pytest.raises(ValueError, match="values"):
        dw.raster_from_tin(pts[:, :2], 1.0)
    with pytest.raises(ValueError, match="triangles"):
        dw.raster_from_tin(pts, 1.0, triangles=np.array([[0, 1, 99]]))
    with pytest.raises(TypeError, match="float32 or float64"):
        dw.raster_from_tin(pts.astype(np.int64), 1.0)
    with pytest.raises(dw.Error, match="empty bounds"):
        dw.raster_from_tin(pts, 1.0, bounds=(5, 5, 0, 0))
    with pytest.raises(dw.Error, match="no finite points"):
        dw.raster_from_tin(np.full((3, 3), np.nan), 1.0)
    if not dw.HAVE_GDAL:
        return
    with pytest.raises(ValueError, match="exactly one"):
        dw.write_dem(str(tmp_path / "a.tif"), pts)
    with pytest.raises(ValueError, match="north-up"):
        dw.write_dem(str(tmp_path / "a.tif"), np.zeros((2, 2)), geotransform=(0, 1, 0, 0, 0, 1))
    with pytest.raises(dw.RasterError, match="compression"):
        dw.write_dem(str(tmp_path / "a.tif"), pts, resolution=1.0, compress="JPEG2000")
    with pytest.raises(dw.RasterError):
        dw.write_dem(str(tmp_path / "no" / "such" / "dir.tif"), pts, resolution=1.0)
    assert not (tmp_path / "a.tif").exists()
