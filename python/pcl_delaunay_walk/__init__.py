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

See docs/python.md.
"""

from ._native import (  # noqa: F401  (re-exported)
    HAVE_GPU,
    HAVE_ICP,
    DelaunayGraph,
    Error,
    GraphFileError,
    LasError,
    NeighbourSearch,
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


__all__ = [
    "DelaunayGraph",
    "NeighbourSearch",
    "icp",
    "tin",
    "read_las",
    "gpu",
    "Error",
    "GraphFileError",
    "LasError",
    "HAVE_ICP",
    "HAVE_GPU",
]
