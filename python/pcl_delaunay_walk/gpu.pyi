from typing import Any, Dict, Optional, Tuple

import numpy as np
import numpy.typing as npt

from . import DelaunayGraph

def why_unavailable() -> str: ...
def is_available() -> bool: ...
def available() -> bool: ...

class DelaunayWalk:
    graph: DelaunayGraph
    def __init__(self, graph: DelaunayGraph) -> None: ...
    @property
    def num_vertices(self) -> int: ...
    def nearest(
        self, queries: npt.ArrayLike, hints: Optional[npt.ArrayLike] = ...
    ) -> Tuple[npt.NDArray[np.int64], npt.NDArray[np.float32], npt.NDArray[np.int64]]: ...

def icp(
    source: npt.ArrayLike,
    target: Any,
    init: Optional[npt.ArrayLike] = ...,
    max_iterations: int = ...,
    max_distance: float = ...,
    transformation_epsilon: float = ...,
    fitness_epsilon: float = ...,
) -> Dict[str, Any]: ...
