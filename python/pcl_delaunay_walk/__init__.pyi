"""Type stubs of pcl_delaunay_walk (the native module _native and its re-exports)."""

import enum
import os
from typing import Any, Literal, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

from . import gpu as gpu

Points = Union[npt.NDArray[np.float32], npt.NDArray[np.float64], Sequence[Sequence[float]]]
Strategy = Literal["zero", "kd-ann", "pnn", "pnn-optimized"]

HAVE_ICP: bool
HAVE_GPU: bool
HAVE_GDAL: bool

class Error(RuntimeError): ...
class GraphFileError(Error): ...
class LasError(Error): ...
class RasterError(Error): ...

class DelaunayGraph:
    def __init__(
        self, points: Points, threads: int = 0, builder: Literal["auto", "qhull", "incremental"] = "auto"
    ) -> None: ...
    def save(self, path: str) -> None: ...
    @staticmethod
    def load(path: str) -> DelaunayGraph: ...
    def validate(self, threads: int = 0) -> None: ...
    def degree_statistics(self) -> dict[str, float]: ...
    @property
    def num_vertices(self) -> int: ...
    @property
    def num_directed_edges(self) -> int: ...
    @property
    def num_edges(self) -> int: ...
    @property
    def num_input_points(self) -> int: ...
    @property
    def dimension(self) -> int: ...
    @property
    def origin(self) -> Tuple[float, float, float]: ...
    @property
    def memory_bytes(self) -> int: ...
    @property
    def points(self) -> npt.NDArray[np.float32]: ...
    @property
    def input_to_vertex(self) -> npt.NDArray[np.uint32]: ...

class NeighbourSearch:
    def __init__(self, graph: DelaunayGraph) -> None: ...
    @property
    def graph(self) -> DelaunayGraph: ...
    def nearest(
        self,
        queries: Points,
        hints: Optional[npt.ArrayLike] = None,
        strategy: Optional[Strategy] = None,
        threads: int = 0,
    ) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.float32], npt.NDArray[np.int64]]: ...
    def knn(
        self,
        queries: Points,
        k: int,
        hints: Optional[npt.ArrayLike] = None,
        strategy: Optional[Strategy] = None,
        threads: int = 0,
    ) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.float32]]: ...
    def radius(
        self,
        queries: Points,
        r: float,
        max_nn: int = 0,
        hints: Optional[npt.ArrayLike] = None,
        strategy: Optional[Strategy] = None,
        threads: int = 0,
    ) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.float32]]: ...

class IterationStatistics(TypedDict):
    queries: int
    correspondences: int
    walk_steps: int
    widened: int
    nn_seconds: float

class IcpResult(TypedDict):
    transform: npt.NDArray[np.float64]
    fitness: float
    converged: bool
    iterations: int
    graph_seconds: float
    statistics: list[IterationStatistics]

def icp(
    source: Points,
    target: Points,
    method: Literal["point_to_point", "point_to_plane"] = "point_to_point",
    init: Optional[npt.ArrayLike] = None,
    max_iterations: int = 50,
    max_distance: float = ...,
    transformation_epsilon: float = 0.0,
    fitness_epsilon: float = ...,
    normal_k: int = 15,
    strategy: Strategy = "pnn-optimized",
    threads: int = 0,
    graph: Optional[DelaunayGraph] = None,
) -> IcpResult: ...
def tin(points: Points, threads: int = 0, strips: int = 0) -> npt.NDArray[np.uint32]: ...
def read_las(path: str, classification: int = -1, attributes: bool = True) -> dict[str, Any]: ...

Method = Literal["point_to_point", "point_to_plane"]
Kernel = Literal["none", "huber", "cauchy"]
GeoTransform = Tuple[float, float, float, float, float, float]

class FrameStatus(enum.Enum):
    Ok = 0
    EmptyScan = 1
    NoFinitePoints = 2
    NoCorrespondences = 3
    LostTrack = 4

class IcpConvergence(enum.Enum):
    NotConverged = 0
    Iterations = 1
    Transform = 2
    AbsoluteMse = 3
    RelativeMse = 4
    NoCorrespondences = 5

class FrameResult:
    @property
    def pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def status(self) -> FrameStatus: ...
    @property
    def ok(self) -> bool: ...
    @property
    def message(self) -> str: ...
    @property
    def convergence(self) -> IcpConvergence: ...
    @property
    def iterations(self) -> int: ...
    @property
    def fitness(self) -> float: ...
    @property
    def rmse(self) -> float: ...
    @property
    def points(self) -> int: ...
    @property
    def latency_seconds(self) -> float: ...
    @property
    def search_seconds(self) -> float: ...

class Localizer:
    def __init__(
        self,
        map: Union[Points, DelaunayGraph, str, os.PathLike[str]],
        *,
        method: Method = "point_to_point",
        max_distance: float = 1.0,
        max_iterations: int = 30,
        transformation_epsilon: float = 1e-8,
        fitness_epsilon: float = ...,
        kernel: Kernel = "none",
        kernel_scale: float = 1.0,
        voxel: float = 0.0,
        constant_velocity: bool = True,
        min_fitness: float = 0.3,
        max_rmse: float = ...,
        normal_k: int = 10,
        warm_start: bool = True,
        threads: int = 0,
    ) -> None: ...
    def register_scan(self, scan: Points, init: Optional[npt.ArrayLike] = None) -> FrameResult: ...
    def set_pose(self, pose: npt.ArrayLike) -> None: ...
    @property
    def pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def predicted_pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def map_size(self) -> int: ...
    @property
    def map_vertices(self) -> int: ...
    def map_normals(self) -> npt.NDArray[np.float32]: ...
    def save(self, path: str) -> None: ...

class OdometryMapStats(TypedDict):
    inserted: int
    removed: int
    insert_seconds: float
    remove_seconds: float
    graph_seconds: float

class SlidingWindowOdometry:
    def __init__(
        self,
        *,
        voxel: float = 0.5,
        max_range: float = 100.0,
        max_age: int = 0,
        max_distance: float = 1.0,
        max_iterations: int = 30,
        transformation_epsilon: float = 1e-8,
        fitness_epsilon: float = ...,
        kernel: Kernel = "none",
        kernel_scale: float = 1.0,
        min_fitness: float = 0.3,
        threads: int = 1,
    ) -> None: ...
    def register_scan(self, scan: Points) -> FrameResult: ...
    def add_scan(self, scan: Points) -> FrameResult: ...
    def set_pose(self, pose: npt.ArrayLike) -> None: ...
    @property
    def pose(self) -> npt.NDArray[np.float64]: ...
    @property
    def map_size(self) -> int: ...
    @property
    def frames(self) -> int: ...
    @property
    def map_stats(self) -> OdometryMapStats: ...
    def map_points(self) -> npt.NDArray[np.float64]: ...

def raster_from_tin(
    points: Points,
    resolution: float,
    *,
    bounds: Optional[Tuple[float, float, float, float]] = None,
    max_edge: float = ...,
    nodata: float = -9999.0,
    values: Optional[npt.ArrayLike] = None,
    triangles: Optional[npt.ArrayLike] = None,
    threads: int = 0,
) -> Tuple[npt.NDArray[np.float64], GeoTransform]: ...

class DemWritten(TypedDict):
    geotransform: GeoTransform
    shape: Tuple[int, int]
    cells_set: int
    triangles_killed: int

def write_dem(
    path: str,
    data: Union[Points, npt.ArrayLike],
    *,
    geotransform: Optional[GeoTransform] = None,
    resolution: Optional[float] = None,
    bounds: Optional[Tuple[float, float, float, float]] = None,
    max_edge: float = ...,
    nodata: float = -9999.0,
    values: Optional[npt.ArrayLike] = None,
    triangles: Optional[npt.ArrayLike] = None,
    crs_wkt: Optional[str] = None,
    cog: bool = False,
    float64: bool = False,
    compress: Literal["DEFLATE", "LZW", "ZSTD", "NONE"] = "DEFLATE",
    block: int = 0,
    hillshade: Optional[str] = None,
    threads: int = 0,
) -> DemWritten: ...
def las_crs_wkt(path: str) -> str: ...
