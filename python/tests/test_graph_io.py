"""DelaunayGraph: statistics, save/load round trip, and corrupt files raising GraphFileError."""

import os

import numpy as np
import pytest

import pcl_delaunay_walk as dw


def test_statistics(bunny):
    g = dw.DelaunayGraph(bunny)
    assert g.num_input_points == len(bunny)
    assert 0 < g.num_vertices <= len(bunny)
    assert g.num_directed_edges == 2 * g.num_edges
    st = g.degree_statistics()
    assert 0 < st["min"] <= st["mean"] <= st["max"]
    assert st["mean"] == pytest.approx(g.num_directed_edges / g.num_vertices)
    assert g.dimension == 3 and g.memory_bytes > 0
    assert g.points.shape == (g.num_vertices, 3) and g.points.dtype == np.float32
    g.validate()


def test_builders_agree(bunny):
    a = dw.DelaunayGraph(bunny[:5000], builder="auto")
    b = dw.DelaunayGraph(bunny[:5000], builder="incremental", threads=1)
    assert a.num_edges == b.num_edges


def test_save_load_round_trip(tmp_path, bunny):
    g = dw.DelaunayGraph(bunny)
    path = str(tmp_path / "bunny.graph")
    g.save(path)
    h = dw.DelaunayGraph.load(path)
    assert (h.num_vertices, h.num_edges, h.dimension, h.origin) == (g.num_vertices, g.num_edges, g.dimension, g.origin)
    np.testing.assert_array_equal(h.points, g.points)
    np.testing.assert_array_equal(h.input_to_vertex, g.input_to_vertex)
    q = bunny[::7] + np.float32(0.001)
    for a, b in zip(dw.NeighbourSearch(g).knn(q, 5), dw.NeighbourSearch(h).knn(q, 5)):
        np.testing.assert_array_equal(a, b)


def test_corrupt_truncated_and_missing_files_raise(tmp_path):
    g = dw.DelaunayGraph(np.random.default_rng(3).random((2000, 3)))
    path = tmp_path / "g.graph"
    g.save(str(path))
    data = path.read_bytes()
    flipped = bytearray(data)
    flipped[len(data) // 2] ^= 0xFF
    cases = {"flipped": bytes(flipped), "truncated": data[: len(data) // 3], "foreign": b"not a graph" * 50, "empty": b""}
    for name, content in cases.items():
        bad = tmp_path / f"{name}.graph"
        bad.write_bytes(content)
        with pytest.raises(dw.GraphFileError):
            dw.DelaunayGraph.load(str(bad))
    with pytest.raises(dw.Error):
        dw.DelaunayGraph.load(str(tmp_path / "missing.graph"))
    assert issubclass(dw.GraphFileError, RuntimeError)


def test_failed_save_keeps_the_existing_file(tmp_path):
    """A save that fails (past RLIMIT_FSIZE, in a forked child) raises dw.Error naming the file and
    the reason, and leaves the existing file byte for byte with no temporary beside it."""
    import os
    import resource
    import signal

    g = dw.DelaunayGraph(np.random.default_rng(5).random((3000, 3)))
    path = tmp_path / "existing.graph"
    old = b"an existing graph file" * 100
    path.write_bytes(old)
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:  # the child: capped, so the write fails with EFBIG
        os.close(r)
        code = 0
        try:
            signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
            resource.setrlimit(resource.RLIMIT_FSIZE, (64 * 1024, 64 * 1024))
            g.save(str(path))
        except dw.Error as e:
            os.write(w, str(e).encode())
            code = 1
        except BaseException as e:  # noqa: BLE001 (reported to the parent)
            os.write(w, repr(e).encode())
            code = 2
        os._exit(code)
    os.close(w)
    message = b""
    while chunk := os.read(r, 4096):
        message += chunk
    os.close(r)
    _, status = os.waitpid(pid, 0)
    assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 1, message
    assert str(path) in message.decode() and "File too large" in message.decode()
    assert path.read_bytes() == old
    assert sorted(p.name for p in tmp_path.iterdir()) == ["existing.graph"]


def _rss_anon_kb():
    """Anonymous resident memory of this process (Linux), or None where /proc does not say."""
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith("RssAnon:"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def test_load_maps_the_file_instead_of_copying(tmp_path):
    # 150k uniform points: ~46 MB of edge records, above glibc's largest mmap threshold (32 MB), so a
    # copy takes fresh anonymous pages and shows in RssAnon; a mapped file's pages are RssFile.
    pts = np.random.default_rng(5).random((150_000, 3), dtype=np.float32)
    g = dw.DelaunayGraph(pts)
    path = str(tmp_path / "uniform.graph")
    g.save(path)
    edge_kb = g.num_directed_edges * 20 / 1024
    assert not g.is_mapped

    before = _rss_anon_kb()
    mapped = dw.DelaunayGraph.load(path)
    grown_mapped = None if before is None else _rss_anon_kb() - before
    assert mapped.is_mapped
    before = _rss_anon_kb()
    copied = dw.DelaunayGraph.load(path, mapped=False)
    grown_copied = None if before is None else _rss_anon_kb() - before
    assert not copied.is_mapped
    if grown_mapped is not None:
        assert grown_copied > 0.75 * edge_kb, (grown_copied, edge_kb)  # the measurement sees a copy
        assert grown_mapped < 0.25 * edge_kb, (grown_mapped, edge_kb)

    q = pts[::50] + np.float32(0.001)
    expected = dw.NeighbourSearch(g).knn(q, 4)
    for h in (mapped, copied):
        for a, b in zip(expected, dw.NeighbourSearch(h).knn(q, 4)):
            np.testing.assert_array_equal(a, b)

    # The mapping outlives the path, and the mapped graph saves again (over its own path).
    os.remove(path)
    for a, b in zip(expected, dw.NeighbourSearch(mapped).knn(q, 4)):
        np.testing.assert_array_equal(a, b)
    mapped.save(path)
    again = dw.DelaunayGraph.load(path)
    assert again.is_mapped and again.num_edges == g.num_edges
    np.testing.assert_array_equal(again.points, g.points)
