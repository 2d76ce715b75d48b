"""pcl_delaunay_walk.gpu: without a CUDA device (or without the CUDA module) every call raises a
RuntimeError that says why, and the device tests skip with that reason; with a device, the GPU walk's
answers equal the CPU search's and a brute force's, and the GPU ICP equals the CPU ICP (PCL's rules)
within the GPU module's tolerance (1e-4 per transform element, gpu/test/test_gpu_icp.cpp)."""

import numpy as np
import pytest

import pcl_delaunay_walk as dw

ICP_TOLERANCE = 1e-4  # the GPU module's bar against the host reference (docs/gpu.md)

needs_device = pytest.mark.skipif(not dw.gpu.is_available(), reason="no GPU path here: " + dw.gpu.why_unavailable())


def _cloud(n=3000, seed=5):
    return np.random.default_rng(seed).random((n, 3)).astype(np.float32)


def test_unavailable_gpu_raises_runtime_error_with_the_reason():
    if dw.gpu.is_available():
        pytest.skip("a CUDA device is present: the error path is not reachable here")
    why = dw.gpu.why_unavailable()
    assert why.startswith("pcl_delaunay_walk.gpu")
    assert "CUDA" in why
    assert dw.gpu.available() is False
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


def _local(g, q):
    """Queries in the graph's local frame, rounded as the walks round them (double difference, one float)."""
    return (q.astype(np.float64) - np.asarray(g.origin, dtype=np.float64)).astype(np.float32)


def _brute_force_sq_dists(g, queries):
    """Exact nearest squared distance of each query to the graph's vertices, in double from the float
    local coordinates and rounded once to float: the comparison the walks make."""
    pts = np.asarray(g.points, dtype=np.float64)
    q = _local(g, queries).astype(np.float64)
    out = np.empty(len(q), dtype=np.float32)
    for s in range(0, len(q), 256):
        d = q[s:s + 256, None, :] - pts[None, :, :]
        out[s:s + 256] = np.einsum("ijk,ijk->ij", d, d).min(axis=1).astype(np.float32)
    return out


@needs_device
@pytest.mark.parametrize("layout", ["float32", "float64", "strided"])
def test_gpu_walk_equals_cpu_search_and_brute_force(layout):
    pts = _cloud()
    pts[100] = pts[99]  # a duplicate: reported as its smallest input index, as on the CPU
    g = dw.DelaunayGraph(pts)
    q = _cloud(2000, 9)
    q[1000:1100] = pts[1000:1100]  # queries on data points: distance 0
    q[7] = np.nan
    arg = {"float32": q, "float64": q.astype(np.float64),
           "strided": np.asfortranarray(np.hstack([q, q])[:, :3])}[layout]
    walk = dw.gpu.DelaunayWalk(g)
    assert walk.num_vertices == g.num_vertices
    idx, d2, ends = walk.nearest(arg)
    assert idx.dtype == np.int64 and d2.dtype == np.float32 and ends.dtype == np.int64
    cidx, cd2, _ = dw.NeighbourSearch(g).nearest(q)
    assert idx[7] == -1 and np.isinf(d2[7])
    np.testing.assert_array_equal(d2, cd2)  # exact: bit-equal distances
    assert np.all((idx == cidx) | (d2 == cd2))  # indices may differ only on ties
    finite = np.arange(len(q)) != 7
    np.testing.assert_array_equal(d2[finite], _brute_force_sq_dists(g, q[finite]))
    assert np.all(d2[1000:1100] == 0) and np.all(idx[1000:1100] == np.arange(1000, 1100))
    # The reported input is at the reported distance from the query.
    v = g.input_to_vertex[idx[finite]]
    np.testing.assert_array_equal(v, ends[finite])
    idx2, d22, ends2 = walk.nearest(arg, hints=ends)  # hints round-trip
    np.testing.assert_array_equal(d22, d2)
    np.testing.assert_array_equal(ends2[finite], ends[finite])


@needs_device
def test_gpu_walk_rejects_bad_arguments_with_value_errors():
    walk = dw.gpu.DelaunayWalk(dw.DelaunayGraph(_cloud(500)))
    with pytest.raises(ValueError):
        walk.nearest(np.zeros((4, 2), np.float32))
    with pytest.raises(ValueError):
        walk.nearest(_cloud(10), hints=np.zeros(3, np.int64))
    idx, d2, _ = walk.nearest(np.zeros((0, 3), np.float32))
    assert idx.shape == (0,) and d2.shape == (0,)


def _reference_icp(g, source, init, max_iterations, max_distance, transformation_epsilon, fitness_epsilon):
    """PCL 1.13's IterativeClosestPoint<PointXYZ, PointXYZ, float> rule for rule (as gpu/test/
    reference_icp.h): float source moved by each step, exact NN on the CPU, SVD (Umeyama) estimation in
    double, DefaultConvergenceCriteria with the transformation test in float."""
    search = dw.NeighbourSearch(g)
    origin = np.asarray(g.origin, dtype=np.float64)
    pts = np.asarray(g.points, dtype=np.float64) + origin
    cur = (source.astype(np.float64) @ init[:3, :3].T + init[:3, 3]).astype(np.float32)
    transform, iterations, prev_mse = init.copy(), 0, np.finfo(np.float64).max
    while True:
        _, d2, ends = search.nearest(cur)
        keep = np.isfinite(d2) & (d2.astype(np.float64) <= max_distance * max_distance)
        if keep.sum() < 3:
            return transform, iterations, False
        s, t = cur[keep].astype(np.float64), pts[ends[keep]]
        ms, mt = s.mean(axis=0), t.mean(axis=0)
        u, _, vt = np.linalg.svd((s - ms).T @ (t - mt))
        v = vt.T
        if np.linalg.det(u) * np.linalg.det(v) < 0:
            v[:, 2] *= -1
        step = np.eye(4)
        step[:3, :3] = v @ u.T
        step[:3, 3] = mt - step[:3, :3] @ ms
        stepf = step.astype(np.float32)
        cur = cur @ stepf[:3, :3].T + stepf[:3, 3]
        transform = step @ transform
        iterations += 1
        if iterations >= max_iterations:
            return transform, iterations, True
        trace = np.float32(stepf[0, 0] + stepf[1, 1] + stepf[2, 2] - np.float32(1))
        if 0.5 * float(trace) >= 1.0 - transformation_epsilon and \
                float(np.sum(stepf[:3, 3] * stepf[:3, 3], dtype=np.float32)) <= transformation_epsilon:
            return transform, iterations, True
        mse = float(np.mean(d2[keep].astype(np.float64)))
        if abs(mse - prev_mse) < 1e-12 or abs(mse - prev_mse) / prev_mse < fitness_epsilon:
            return transform, iterations, True
        prev_mse = mse


def _rotation(angle, axis):
    axis = np.asarray(axis, dtype=np.float64) / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * k @ k


@needs_device
def test_gpu_icp_equals_cpu_icp(bunny):
    target = bunny
    motion = np.eye(4)
    motion[:3, :3] = _rotation(0.05, [0.2, 1.0, 0.3])
    motion[:3, 3] = [0.004, -0.003, 0.002]
    inv = np.linalg.inv(motion)
    source = (target.astype(np.float64) @ inv[:3, :3].T + inv[:3, 3]).astype(np.float32)
    kw = dict(max_iterations=40, max_distance=0.02, transformation_epsilon=1e-12, fitness_epsilon=1e-7)
    g = dw.DelaunayGraph(target)
    walk = dw.gpu.DelaunayWalk(g)
    r = dw.gpu.icp(source, walk, **kw)
    assert r["transform"].shape == (4, 4) and r["transform"].dtype == np.float64
    ref, ref_iterations, ref_converged = _reference_icp(g, source, np.eye(4), **kw)
    np.testing.assert_allclose(r["transform"], ref, rtol=0, atol=ICP_TOLERANCE)
    assert abs(r["iterations"] - ref_iterations) <= 1
    assert r["converged"] == ref_converged
    np.testing.assert_allclose(r["transform"], motion, rtol=0, atol=1e-3)  # and the motion comes back
    assert r["correspondences"] > 0.9 * len(source)
    if dw.HAVE_ICP:  # the PCL build's icp(), where a machine has both PCL and a device
        cpu = dw.icp(source, target, **kw)
        np.testing.assert_allclose(r["transform"], cpu["transform"], rtol=0, atol=ICP_TOLERANCE)


@needs_device
def test_gpu_icp_from_points_and_an_initial_guess():
    target = _cloud(20000)
    source = target - np.float32([0.01, -0.005, 0.002])
    init = np.eye(4)
    init[:3, 3] = [0.008, -0.004, 0.001]
    r = dw.gpu.icp(source, target, init=init, max_iterations=30)
    np.testing.assert_allclose(r["transform"][:3, 3], [0.01, -0.005, 0.002], atol=1e-4)
    assert r["iterations"] >= 1 and r["state"]
    with pytest.raises(ValueError, match="4x4"):
        dw.gpu.icp(source, target, init=np.eye(3))
    with pytest.raises(ValueError, match="max_iterations"):
        dw.gpu.icp(source, target, max_iterations=0)
