"""pcl_delaunay_walk.gpu: without a CUDA device (or without the CUDA module) every call raises a
RuntimeError that says why; with one, the GPU walk's answers equal the CPU search's and ICP recovers a
known motion (skipped, with the reason, where no device is present)."""

import numpy as np
import pytest

import pcl_delaunay_walk as dw


def _cloud(n=3000, seed=5):
    return np.random.default_rng(seed).random((n, 3)).astype(np.float32)


def test_unavailable_gpu_raises_runtime_error_with_the_reason():
    if dw.gpu.available():
        pytest.skip("a CUDA device is present: the error path is not reachable here")
    why = dw.gpu.why_unavailable()
    assert why.startswith("pcl_delaunay_walk.gpu")
    assert "CUDA" in why
    g = dw.DelaunayGraph(_cloud(200))
    with pytest.raises(RuntimeError, match="CUDA") as e:
        dw.gpu.DelaunayWalk(g)
    assert str(e.value) == why
    with pytest.raises(RuntimeError, match="CUDA"):
        dw.gpu.icp(_cloud(200), _cloud(200))
    if dw.HAVE_GPU:
        # The extension itself refuses too (it is what gpu.DelaunayWalk calls), never touching a device.
        from pcl_delaunay_walk import _gpu

        assert _gpu.why_unavailable() != ""
        with pytest.raises(RuntimeError, match="no CUDA device"):
            _gpu.DelaunayWalk(g)


def test_gpu_walk_equals_cpu_search():
    if not dw.gpu.available():
        pytest.skip("no GPU path here: " + dw.gpu.why_unavailable())
    pts = _cloud()
    g = dw.DelaunayGraph(pts)
    q = _cloud(2000, 9)
    q[7] = np.nan
    idx, d2, ends = dw.gpu.DelaunayWalk(g).nearest(q)
    cidx, cd2, _ = dw.NeighbourSearch(g).nearest(q)
    assert idx[7] == -1 and np.isinf(d2[7])
    np.testing.assert_array_equal(d2, cd2)  # exact: equal distances (indices may differ only on ties)
    same = idx == cidx
    assert np.all(same | (d2 == cd2))
    idx2, d22, _ = dw.gpu.DelaunayWalk(g).nearest(q, hints=ends)
    np.testing.assert_array_equal(d22, d2)


def test_gpu_icp_recovers_a_translation():
    if not dw.gpu.available():
        pytest.skip("no GPU path here: " + dw.gpu.why_unavailable())
    target = _cloud(20000)
    source = target - np.float32([0.01, -0.005, 0.002])
    r = dw.gpu.icp(source, target, max_iterations=30)
    np.testing.assert_allclose(r["transform"][:3, 3], [0.01, -0.005, 0.002], atol=1e-4)
    assert r["iterations"] >= 1
