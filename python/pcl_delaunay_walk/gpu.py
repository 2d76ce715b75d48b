"""The GPU module (gpu/ in the C++ tree: dw::gpu::DelaunayWalk and dw::gpu::IterativeClosestPoint).

    import pcl_delaunay_walk as dw
    if dw.gpu.is_available():
        walk = dw.gpu.DelaunayWalk(dw.DelaunayGraph(target))   # the graph on the device
        idx, d2, ends = walk.nearest(queries)                   # exact, as NeighbourSearch.nearest
        result = dw.gpu.icp(source, walk, max_distance=0.05)   # point-to-point ICP on the device
    else:
        print(dw.gpu.why_unavailable())

Where the build has no CUDA module, its library cannot be loaded, or no CUDA device is present, every
call raises RuntimeError with the reason; `is_available()` and `why_unavailable()` say so without
raising. Arrays are (n, 3) float32 or float64 (C-contiguous ones are read in place, others converted
once); every call releases the GIL while the device works.
"""

from ._native import HAVE_GPU

try:
    from . import _gpu
    _IMPORT_ERROR = ""
except ImportError as e:  # no CUDA module in this build, or its CUDA runtime library is missing
    _gpu = None
    _IMPORT_ERROR = str(e)


def why_unavailable() -> str:
    """'' when GPU calls can run here, else why not."""
    if not HAVE_GPU:
        return ("pcl_delaunay_walk.gpu: this build has no CUDA module (configure with CUDA to build it; "
                "NeighbourSearch and icp run on the CPU)")
    if _gpu is None:
        return "pcl_delaunay_walk.gpu: the CUDA module cannot be loaded: " + _IMPORT_ERROR
    why = _gpu.why_unavailable()
    return "pcl_delaunay_walk.gpu: " + why if why else ""


def is_available() -> bool:
    """Whether GPU calls can run here (a CUDA module in this build and a CUDA device)."""
    return why_unavailable() == ""


available = is_available  # the name of the first release


def _require():
    why = why_unavailable()
    if why:
        raise RuntimeError(why)


class DelaunayWalk:
    """A DelaunayGraph uploaded to the current CUDA device, for exact batch nearest-neighbour search.

    Raises RuntimeError where no CUDA device (or no CUDA module) is available."""

    def __init__(self, graph):
        _require()
        self._impl = _gpu.DelaunayWalk(graph)
        self.graph = graph

    @property
    def num_vertices(self) -> int:
        return self._impl.num_vertices

    def nearest(self, queries, hints=None):
        """(indices int64, sq_dists float32, ends int64), as NeighbourSearch.nearest."""
        return self._impl.nearest(queries, hints)


def icp(source, target, init=None, max_iterations=50, max_distance=float("inf"), transformation_epsilon=0.0,
        fitness_epsilon=float("-inf")):
    """Point-to-point ICP of `source` onto `target` (a gpu.DelaunayWalk, or points to build one from)
    on the GPU with PCL's convergence rules: {'transform' 4x4, 'iterations', 'converged', 'state', 'mse',
    'correspondences'}. Raises RuntimeError where no CUDA device is available."""
    _require()
    if not isinstance(target, DelaunayWalk):
        from ._native import DelaunayGraph
        target = DelaunayWalk(DelaunayGraph(target))
    return _gpu.icp(source, target._impl, init, max_iterations, max_distance, transformation_epsilon,
                    fitness_epsilon)
