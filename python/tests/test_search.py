"""NeighbourSearch against SciPy's cKDTree and a brute force in the graph's own frame: random, real
(bundled bunny) and degenerate data; hints, kNN order, radius sets, layouts, errors, lifetime, threads."""

import gc
import threading

import numpy as np
import pytest
from scipy.spatial import cKDTree

import pcl_delaunay_walk as dw
from conftest import assert_nearest_matches_ckdtree, true_sq_dist


def local_frame(graph, a):
    """What the library does to a caller's point: subtract the origin in double, round once to float."""
    return (a.astype(np.float64) - np.asarray(graph.origin)).astype(np.float32).astype(np.float64)


def brute_force_local(graph, points, queries):
    """Exact nearest squared distance of each query among the points, in the graph's local frame, with
    the walk's arithmetic (double from float coordinates, dx*dx + dy*dy + dz*dz)."""
    lp, lq = local_frame(graph, points), local_frame(graph, queries)
    finite = np.isfinite(lp).all(axis=1)
    lp = lp[finite]
    out = np.empty(len(lq))
    for s in range(0, len(lq), 256):
        q = lq[s : s + 256, None, :]
        d = lp[None, :, :] - q
        out[s : s + 256] = (d[..., 0] * d[..., 0] + d[..., 1] * d[..., 1] + d[..., 2] * d[..., 2]).min(axis=1)
    return out


def check_nearest(points, queries, **kw):
    g = dw.DelaunayGraph(points)
    s = dw.NeighbourSearch(g)
    idx, d2, ends = s.nearest(queries, **kw)
    assert idx.dtype == np.int64 and d2.dtype == np.float32 and ends.dtype == np.int64
    assert_nearest_matches_ckdtree(points, queries, idx)
    exact = brute_force_local(g, points, queries)
    np.testing.assert_array_equal(d2, exact.astype(np.float32))
    return g, s, idx, d2, ends


@pytest.fixture
def rng():
    return np.random.default_rng(20240607)


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_random_points_equal_ckdtree_and_brute_force(rng, dtype):
    p = rng.random((20000, 3)).astype(dtype)
    q = (rng.random((3000, 3)) * 1.2 - 0.1).astype(dtype)
    check_nearest(p, q)


def test_georeferenced_coordinates(rng):
    p = rng.random((5000, 3)) * 100 + np.array([5.0e5, 4.2e6, 300.0])
    q = rng.random((1000, 3)) * 100 + np.array([5.0e5, 4.2e6, 300.0])
    check_nearest(p, q)


def test_bundled_bunny(bunny, rng):
    q = bunny[rng.choice(len(bunny), 3000)] + rng.normal(0, 0.002, (3000, 3)).astype(np.float32)
    check_nearest(bunny, q)


@pytest.mark.parametrize("strategy", ["zero", "kd-ann", "pnn", "pnn-optimized"])
def test_every_strategy_is_exact(rng, strategy):
    p = rng.random((5000, 3))
    q = rng.random((1000, 3))
    check_nearest(p, q, strategy=strategy)


def test_degenerate_duplicates_coplanar_collinear_grid(rng):
    base = rng.random((500, 3))
    dup = np.vstack([base, base, base[:100]])  # every point at least twice
    coplanar = np.column_stack([rng.random((3000, 2)), np.full(3000, 0.5)])
    collinear = np.column_stack([np.linspace(0, 1, 500), np.linspace(0, 2, 500), np.zeros(500)])
    g = np.stack(np.meshgrid(*[np.arange(12.0)] * 3), -1).reshape(-1, 3)  # cocircular ties everywhere
    for pts in (dup, coplanar, collinear, g):
        q = pts[rng.choice(len(pts), 400)] + rng.normal(0, 0.05, (400, 3))
        q = np.vstack([q, pts[:50]])  # queries on data points (distance 0)
        graph, _, idx, d2, _ = check_nearest(pts, q)
        assert graph.dimension in (1, 2, 3)
    # a duplicate is reported as its smallest input index
    _, _, idx, d2, _ = check_nearest(dup, base[:50])
    np.testing.assert_array_equal(idx, np.arange(50))
    np.testing.assert_array_equal(d2, 0)


def test_hints_round_trip(rng):
    p = rng.random((20000, 3))
    q = rng.random((3000, 3))
    g, s, idx, d2, ends = check_nearest(p, q)
    assert (ends >= 0).all() and (ends < g.num_vertices).all()
    for strategy in (None, "pnn", "pnn-optimized"):
        i2, d22, e2 = s.nearest(q, hints=ends, strategy=strategy)
        np.testing.assert_array_equal(i2, idx)
        np.testing.assert_array_equal(d22, d2)
        np.testing.assert_array_equal(e2, ends)
    # an ICP-like sequence: the next batch moves a little, the hints are the last ends
    moved = q + 0.001
    i3, _, _ = s.nearest(moved, hints=ends.astype(np.uint32))
    np.testing.assert_array_equal(i3, s.nearest(moved)[0])
    # hints out of range mean "no hint"
    i4, _, _ = s.nearest(q, hints=np.full(len(q), -1), strategy="pnn")
    np.testing.assert_array_equal(i4, idx)


def test_knn_sorted_and_equal_ckdtree(rng, bunny):
    for p in (rng.random((10000, 3)), bunny):
        q = p[rng.choice(len(p), 500)] + rng.normal(0, 0.01, (500, 3)).astype(p.dtype)
        s = dw.NeighbourSearch(dw.DelaunayGraph(p))
        k = 12
        idx, d2 = s.knn(q, k)
        assert idx.shape == (500, k) and d2.shape == (500, k)
        assert (np.diff(d2, axis=1) >= 0).all()
        ref_d, _ = cKDTree(p.astype(np.float64)).query(q.astype(np.float64), k)
        ours = np.sqrt(true_sq_dist(p, np.repeat(q, k, 0), idx.ravel())).reshape(-1, k)
        np.testing.assert_allclose(ours, ref_d, rtol=0, atol=2e-6 * (np.abs(p).max() + np.abs(q).max()))
        assert all(len(set(row)) == k for row in idx)


def test_knn_more_than_points_pads():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1], [np.nan, 0, 0]])
    idx, d2 = dw.NeighbourSearch(dw.DelaunayGraph(p)).knn(np.zeros((1, 3)), 6)
    np.testing.assert_array_equal(idx[0, 0], 0)
    assert sorted(idx[0, 1:4]) == [1, 2, 3]
    np.testing.assert_array_equal(idx[0, 4:], -1)
    assert np.isinf(d2[0, 4:]).all()


def test_radius_equals_ckdtree(rng, bunny):
    for p, r in ((rng.random((10000, 3)), 0.06), (bunny, 0.004)):
        q = p[rng.choice(len(p), 400)] + rng.normal(0, 0.01, (400, 3)).astype(p.dtype)
        s = dw.NeighbourSearch(dw.DelaunayGraph(p))
        offsets, idx, d2 = s.radius(q, r)
        assert offsets.shape == (401,) and offsets[0] == 0 and offsets[-1] == len(idx) == len(d2)
        ref = cKDTree(p.astype(np.float64)).query_ball_point(q.astype(np.float64), r)
        tol = 2e-6 * (np.abs(p).max() + np.abs(q).max())
        for i in range(len(q)):
            ours = idx[offsets[i] : offsets[i + 1]]
            assert (np.diff(d2[offsets[i] : offsets[i + 1]]) >= 0).all()
            # points within rounding of the sphere may fall either way; all others must agree
            diff = set(ours.tolist()) ^ set(ref[i])
            for j in diff:
                assert abs(np.sqrt(true_sq_dist(p, q[i : i + 1], [j])[0]) - r) <= tol
        # max_nn keeps the nearest ones
        o5, i5, d5 = s.radius(q, r, max_nn=5)
        for i in range(len(q)):
            np.testing.assert_array_equal(d5[o5[i] : o5[i + 1]], d2[offsets[i] : offsets[i] + min(5, offsets[i + 1] - offsets[i])])


def test_layouts_without_and_with_copies(rng):
    p = rng.random((4000, 3))
    q = rng.random((600, 6))[:, ::2]  # strided columns
    ref = dw.NeighbourSearch(dw.DelaunayGraph(p)).nearest(np.ascontiguousarray(q))
    for pts in (p, np.asfortranarray(p), p[::-1][::-1], np.hstack([p, p])[:, :3]):
        s = dw.NeighbourSearch(dw.DelaunayGraph(pts))
        for qs in (q, np.asfortranarray(q), q[::-1][::-1], q.tolist()):
            idx, d2, _ = s.nearest(qs)
            np.testing.assert_array_equal(idx, ref[0])
            np.testing.assert_array_equal(d2, ref[1])


def test_non_finite_queries_and_points():
    p = np.array([[0.0, 0, 0], [1, 0, 0], [np.nan, 1, 0], [0, np.inf, 0], [0, 0, 1]])
    g = dw.DelaunayGraph(p)
    assert g.num_input_points == 5 and g.num_vertices == 3
    assert g.input_to_vertex[2] == 2**32 - 1
    idx, d2, ends = dw.NeighbourSearch(g).nearest(np.array([[0.9, 0, 0], [np.nan, 0, 0]]))
    assert idx.tolist() == [1, -1] and np.isinf(d2[1]) and ends[1] == -1


def test_packed_float32_queries_equal_the_strided_read(rng):
    """C-contiguous float32 queries take the packed read (one finiteness test on the floats); it must
    skip exactly the rows any coordinate of which is NaN or +-inf, and keep huge finite ones."""
    p = rng.random((3000, 3)).astype(np.float32)
    s = dw.NeighbourSearch(dw.DelaunayGraph(p))
    q = rng.random((400, 3)).astype(np.float32)
    bad = [np.nan, np.inf, -np.inf]
    for k in range(9):
        q[10 + k, k % 3] = bad[k // 3]
    q[30] = [3e38, -3e38, 3e38]  # finite: x - x is 0, though x + x overflows
    q[31] = np.float32(1e-45)  # subnormal
    assert q.flags.c_contiguous
    got = s.nearest(q)
    strided = s.nearest(np.hstack([q, q])[:, :3])
    wide = s.nearest(q.astype(np.float64))
    for ref in (strided, wide):
        for a, b in zip(got, ref):
            np.testing.assert_array_equal(a, b)
    assert (got[0][10:19] == -1).all() and np.isinf(got[1][10:19]).all()
    assert got[0][30] >= 0 and got[0][31] >= 0
    hinted = s.nearest(q, hints=got[2])
    np.testing.assert_array_equal(hinted[1], got[1])
    np.testing.assert_array_equal(hinted[2][10:19], got[2][10:19])  # skipped rows keep their hint


def test_empty_graph_and_empty_batch():
    s = dw.NeighbourSearch(dw.DelaunayGraph(np.zeros((0, 3))))
    idx, d2, _ = s.nearest(np.ones((2, 3)))
    assert idx.tolist() == [-1, -1]
    idx, d2, ends = dw.NeighbourSearch(dw.DelaunayGraph(np.eye(3))).nearest(np.zeros((0, 3)))
    assert idx.shape == (0,)


def test_bad_arguments_raise():
    s = dw.NeighbourSearch(dw.DelaunayGraph(np.eye(3)))
    with pytest.raises(ValueError, match=r"shape \(n, 3\)"):
        s.nearest(np.zeros((4, 2)))
    with pytest.raises(ValueError):
        s.nearest(np.zeros(3))
    with pytest.raises(TypeError, match="float32 or float64"):
        s.nearest(np.zeros((4, 3), dtype=np.int32))
    with pytest.raises(TypeError):
        s.nearest(np.zeros((4, 3)), hints=np.zeros(4))
    with pytest.raises(ValueError, match="hints"):
        s.nearest(np.zeros((4, 3)), hints=np.zeros(3, dtype=np.int64))
    with pytest.raises(ValueError, match="k must"):
        s.knn(np.zeros((4, 3)), 0)
    with pytest.raises(ValueError, match="non-negative"):
        s.radius(np.zeros((4, 3)), -1.0)
    with pytest.raises(dw.Error, match="start strategy|strategy"):
        s.nearest(np.zeros((4, 3)), strategy="nope")
    with pytest.raises(ValueError, match="builder"):
        dw.DelaunayGraph(np.eye(3), builder="nope")
    with pytest.raises(TypeError):
        dw.NeighbourSearch(None)


def test_search_keeps_graph_alive_and_views_survive(rng):
    p = rng.random((3000, 3))
    q = rng.random((100, 3))
    expected = dw.NeighbourSearch(dw.DelaunayGraph(p)).nearest(q)[0]
    s = dw.NeighbourSearch(dw.DelaunayGraph(p.copy()))
    view = s.graph.points
    gc.collect()
    np.testing.assert_array_equal(s.nearest(q)[0], expected)
    assert not view.flags.writeable
    del s
    gc.collect()
    assert np.isfinite(view).all()  # the view still holds the graph
    g = dw.DelaunayGraph(p)
    s = dw.NeighbourSearch(g)
    assert s.graph is g
    del g, p
    gc.collect()
    np.testing.assert_array_equal(s.nearest(q)[0], expected)


def test_concurrent_calls_from_python_threads(rng):
    p = rng.random((20000, 3))
    s = dw.NeighbourSearch(dw.DelaunayGraph(p))
    batches = [rng.random((5000, 3)) for _ in range(8)]
    expected = [s.nearest(b, threads=1)[0] for b in batches]
    expected_knn = [s.knn(b, 4, threads=1)[0] for b in batches]
    results, errors = [None] * 8, []

    def work(i):
        try:
            for _ in range(3):
                idx = s.nearest(batches[i])[0]
                kidx = s.knn(batches[i], 4)[0]
                o, r, _ = s.radius(batches[i], 0.02)
            results[i] = (idx, kidx)
        except Exception as e:  # noqa: BLE001
            errors.append(e)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for i in range(8):
        np.testing.assert_array_equal(results[i][0], expected[i])
        np.testing.assert_array_equal(results[i][1], expected_knn[i])


def test_thread_count_does_not_change_answers(rng):
    p = rng.random((20000, 3))
    q = rng.random((20000, 3))
    s = dw.NeighbourSearch(dw.DelaunayGraph(p, threads=1))
    one = s.nearest(q, threads=1)
    many = s.nearest(q, threads=4)
    for a, b in zip(one, many):
        np.testing.assert_array_equal(a, b)
    o1 = s.radius(q[:2000], 0.03, threads=1)
    o4 = s.radius(q[:2000], 0.03, threads=4)
    for a, b in zip(o1, o4):
        np.testing.assert_array_equal(a, b)


def test_cpp_reference_batch_gives_the_bindings_answers(rng):
    """The overhead benchmark's C++ batch (_cpp_nearest_seconds) answers what nearest() answers, so
    that timing one against the other compares the same work."""
    from pcl_delaunay_walk import _native

    p = rng.random((5000, 3)).astype(np.float32)
    q = (p[rng.choice(5000, 3000)] + rng.normal(0, 0.002, (3000, 3))).astype(np.float32)
    s = dw.NeighbourSearch(dw.DelaunayGraph(p))
    wall, cpu, index_sum = _native._cpp_nearest_seconds(s, q, 2, 2)
    assert wall > 0 and cpu > 0
    assert index_sum == int(s.nearest(q, strategy="kd-ann")[0].sum())
    with pytest.raises(ValueError):
        _native._cpp_nearest_seconds(s, q[:, :2], 1, 1)


def test_batches_keep_threads_and_work_after_fork(rng):
    """Batches run on threads the module keeps between calls; a forked child (multiprocessing's
    default on Linux) has none of them and must still answer, on threads of its own."""
    import os
    import signal

    p = rng.random((20000, 3))
    q = rng.random((3000, 3))
    s = dw.NeighbourSearch(dw.DelaunayGraph(p))
    want = s.knn(q, 8, threads=1)[0]
    np.testing.assert_array_equal(s.knn(q, 8, threads=2)[0], want)
    np.testing.assert_array_equal(s.knn(q, 8, threads=2)[0], want)  # the kept threads again
    pid = os.fork()
    if pid == 0:  # the child: any failure, or a hang past the alarm, is a non-zero exit
        signal.alarm(30)
        try:
            ok = np.array_equal(s.knn(q, 8, threads=2)[0], want)
        except BaseException:
            ok = False
        os._exit(0 if ok else 1)
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0
