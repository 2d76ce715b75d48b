"""pcl_delaunay_walk: exact Delaunay-walk nearest-neighbour search, ICP and Delaunay TINs from NumPy.

    import numpy as np, pcl_delaunay_walk as dw
    graph = dw.DelaunayGraph(points)              # (n, 3) float32/float64
    search = dw.NeighbourSearch(graph)
    idx, d2, ends = search.nearest(queries)       # exact; pass `ends` back as hints next time
    idx, d2, ends = search.nearest(moved, hints=ends)
    knn_idx, knn_d2 = search.knn(queries, 8)
    offsets, ball_idx, ball_d2 = search.radius(queries, 0.05)
    result = dw.icp(source, target, max_distance=0.01)
    triangles = dw.tin(xy)                        # (t, 3) input indices
    loc = dw.Localizer(map_points, max_distance=1.0)
    frame = loc.register_scan(scan)               # FrameResult: pose, status, fitness, ...
    raster, gt = dw.raster_from_tin(xyz, 0.5)     # TIN-linear DEM and its GDAL geotransform
    dw.write_dem("dem.tif", xyz, resolution=0.5)  # GeoTIFF, as dw_dem (HAVE_GDAL)

See docs/python.md.
"""

from ._native import (  # noqa: F401  (re-exported)
    HAVE_GDAL,
    HAVE_GPU,
    HAVE_ICP,
    DelaunayGraph,
    Error,
    FrameResult,
    FrameStatus,
    GraphFileError,
    IcpConvergence,
    LasError,
    Localizer,
    NeighbourSearch,
    SlidingWindowOdometry,
    raster_from_tin,
    read_las,
    tin,
)
from . import gpu  # noqa: F401

if HAVE_ICP:
    from ._native import icp  # noqa: F401
else:

    def icp(*args, **kwargs):
        """ICP needs the PCL layer, which this build of pcl_delaunay_walk lacks."""
        raise RuntimeError("pcl_delaunay_walk was built without PCL: icp() is not available")

if HAVE_GDAL:
    from ._native import RasterError, las_crs_wkt, write_dem  # noqa: F401
else:

    class RasterError(Error):
        """A raster GDAL could not write (never raised: this build has no GDAL adapter)."""

    def write_dem(*args, **kwargs):
        """write_dem needs the GDAL adapter, which this build of pcl_delaunay_walk lacks."""
        raise RuntimeError("pcl_delaunay_walk was built without GDAL: write_dem() is not available")

    def las_crs_wkt(*args, **kwargs):
        """las_crs_wkt needs the GDAL adapter, which this build of pcl_delaunay_walk lacks."""
        raise RuntimeError("pcl_delaunay_walk was built without GDAL: las_crs_wkt() is not available")


__all__ = [
    "DelaunayGraph",
    "NeighbourSearch",
    "icp",
    "tin",
    "read_las",
    "Localizer",
    "SlidingWindowOdometry",
    "FrameResult",
    "FrameStatus",
    "IcpConvergence",
    "raster_from_tin",
    "write_dem",
    "las_crs_wkt",
    "RasterError",
    "HAVE_GDAL",
    "gpu",
    "Error",
    "GraphFileError",
    "LasError",
    "HAVE_ICP",
    "HAVE_GPU",
]
