"""Shared helpers of the Python tests: where the data and the C++ reference are, a PLY reader, and the
tie-aware comparison with SciPy's cKDTree."""

import os
import pathlib

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
DATA = pathlib.Path(os.environ.get("DW_DATA_DIR", ROOT / "data"))
SHARED = pathlib.Path(os.environ.get("DW_SHARED_DATA_DIR", "/work/shared/data"))


def reference_exe():
    exe = os.environ.get("DW_PY_REFERENCE", str(ROOT / "build" / "python" / "dw_py_reference"))
    if not os.path.exists(exe):
        pytest.fail(f"the C++ reference {exe} is missing: build the target dw_py_reference")
    return exe


def read_ply_xyz(path):
    """x, y, z of an ASCII PLY's vertices as float32 (parsed like PCL: one correctly rounded float each)."""
    with open(path, "rb") as f:
        n, props = 0, []
        in_vertex = False
        for line in f:
            words = line.decode("ascii").split()
            if not words:
                continue
            if words[0] == "element":
                in_vertex = words[1] == "vertex"
                if in_vertex:
                    n = int(words[2])
            elif words[0] == "property" and in_vertex:
                props.append(words[-1])
            elif words[0] == "format" and words[1] != "ascii":
                raise ValueError(f"{path}: only ASCII PLY is read here")
            elif words[0] == "end_header":
                break
        table = np.loadtxt(f, max_rows=n, dtype=np.float64, ndmin=2)
    cols = [props.index(c) for c in ("x", "y", "z")]
    return np.ascontiguousarray(table[:, cols].astype(np.float32))


def true_sq_dist(points, queries, idx):
    """Squared distances in float64 from the caller's coordinates."""
    d = points[idx].astype(np.float64) - queries.astype(np.float64)
    return np.einsum("ij,ij->i", d, d)


def assert_nearest_matches_ckdtree(points, queries, idx, rel=2e-6):
    """Each returned index is a nearest point: its distance equals cKDTree's up to the float rounding
    of the graph's local frame (the only way two answers may differ is a tie within that rounding)."""
    from scipy.spatial import cKDTree

    ref_d, ref_i = cKDTree(points.astype(np.float64)).query(queries.astype(np.float64))
    ours = np.sqrt(true_sq_dist(points, queries, idx))
    scale = np.abs(points).max() + np.abs(queries).max()
    tol = rel * scale
    bad = np.abs(ours - ref_d) > tol
    assert not bad.any(), f"{bad.sum()} answers differ from cKDTree, first at query {np.argmax(bad)}"
    return ref_i


@pytest.fixture(scope="session")
def bunny():
    return read_ply_xyz(DATA / "bun000.ply")
