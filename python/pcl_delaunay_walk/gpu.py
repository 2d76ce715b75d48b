"""The GPU module's entry points. The CUDA module (gpu/ in the C++ tree) is not bound by this package
yet, so every call raises RuntimeError with the reason; `available()` says so without raising."""

from ._native import HAVE_GPU

_REASON = (
    "pcl_delaunay_walk.gpu: the CUDA module is not available in this build "
    "(the Python package binds the CPU library only; use NeighbourSearch and icp)"
)


def available() -> bool:
    """Whether GPU calls can run here."""
    return bool(HAVE_GPU)


class DelaunayWalk:
    """GPU Delaunay walk (not available in this build: constructing one raises RuntimeError)."""

    def __init__(self, *args, **kwargs):
        raise RuntimeError(_REASON)


def icp(*args, **kwargs):
    """GPU ICP (not available in this build: raises RuntimeError)."""
    raise RuntimeError(_REASON)
