"""Type stubs of pcl_delaunay_walk (the native module _native and its re-exports)."""

from typing import Any, Literal, Optional, Sequence, Tuple, TypedDict, Union

import numpy as np
import numpy.typing as npt

from . import gpu as gpu

Points = Union[npt.NDArray[np.float32], npt.NDArray[np.float64], Sequence[Sequence[float]]]
Strategy = Literal["zero", "kd-ann", "pnn", "pnn-optimized"]

HAVE_ICP: bool
HAVE_GPU: bool

class Error(RuntimeError): ...
class GraphFileError(Error): ...
class LasError(Error): ...

class DelaunayGraph:
    def __init__(
        self, points: Points, threads: int = 0, builder: Literal["auto", "qhull", "incremental"] = "auto"
    ) -> None: ...
    def save(self, path: str) -> None: ...
    @staticmethod
    def load(path: str) -> DelaunayGraph: ...
    def validate(self) -> None: ...
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
