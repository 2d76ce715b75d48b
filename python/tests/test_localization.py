"""Localizer and SlidingWindowOdometry: the binding's frames equal the C++ classes' on the same inputs
(dw_py_reference localize/odometry), bit for bit; the odometry tracks a synthetic drive; bad input
raises or gets a status."""

import subprocess

import numpy as np
import pytest

import pcl_delaunay_walk as dw
from conftest import reference_exe


def sample_scene(rng, n):
    """Points on a walled yard: ground z = 0 over [-20, 20]^2, four 5 m walls, and six pillars."""
    k = rng.integers(0, 3, n)
    p = np.empty((n, 3))
    u = rng.uniform(-20, 20, n)
    h = rng.uniform(0, 5, n)
    side = rng.integers(0, 4, n)
    g = k == 0
    p[g] = np.c_[rng.uniform(-20, 20, g.sum()), rng.uniform(-20, 20, g.sum()), np.zeros(g.sum())]
    w = k == 1
    sx = np.where(side < 2, np.where(side == 0, -20.0, 20.0), u)
    sy = np.where(side < 2, u, np.where(side == 2, -20.0, 20.0))
    p[w] = np.c_[sx, sy, h][w]
    c = k == 2
    centres = np.array([[-8, -6], [5, -9], [9, 7], [-4, 10], [0, 0], [13, -2]], float)
    which = rng.integers(0, len(centres), c.sum())
    ang = rng.uniform(0, 2 * np.pi, c.sum())
    p[c] = np.c_[centres[which] + 0.6 * np.c_[np.cos(ang), np.sin(ang)], 4 * h[c] / 5]
    return p


def pose_xy_yaw(x, y, yaw):
    m = np.eye(4)
    m[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
    m[:3, 3] = [x, y, 0.0]
    return m


def scan_at(rng, pose, n=6000, noise=0.01, max_range=18.0):
    """A fresh sampling of the scene within range of the sensor, in sensor coordinates, float32."""
    p = sample_scene(rng, 4 * n)
    p = p[np.linalg.norm(p[:, :2] - pose[:2, 3], axis=1) < max_range][:n]
    p += rng.normal(0, noise, p.shape)
    local = (p - pose[:3, 3]) @ pose[:3, :3]
    return np.ascontiguousarray(local.astype(np.float32))


def drive(frames):
    """Sensor poses of a drive starting at the identity (so the reference's default start fits)."""
    return [pose_xy_yaw(0.4 * i, 0.1 * i, 0.02 * i) for i in range(frames)]


def parse_frames(out):
    frames = []
    for line in out.strip().splitlines():
        w = line.split()
        if w[0] == "frame":
            frames.append((int(w[1]), int(w[2]), float.fromhex(w[3]), np.array([float.fromhex(v) for v in w[4:]]).reshape(4, 4)))
    return frames


@pytest.fixture(scope="module")
def yard():
    rng = np.random.default_rng(7)
    poses = drive(5)
    return sample_scene(rng, 30000).astype(np.float32), poses, [scan_at(rng, p) for p in poses]


@pytest.mark.parametrize("method,kernel", [("point_to_point", "none"), ("point_to_plane", "huber")])
def test_localizer_equals_cpp_localizer(tmp_path, yard, method, kernel):
    map_points, poses, scans = yard
    loc = dw.Localizer(map_points, method=method, kernel=kernel, max_distance=1.0, voxel=0.2, threads=2)
    py = [loc.register_scan(s) for s in scans]
    files = []
    for i, s in enumerate([map_points] + scans):
        f = tmp_path / f"{i}.f32"
        s.astype("<f4").tofile(f)
        files.append(str(f))
    out = subprocess.run([reference_exe(), "localize", files[0], method, kernel, "1.0", "0.2", "2"] + files[1:],
                         check=True, capture_output=True, text=True).stdout
    cpp = parse_frames(out)
    assert len(cpp) == len(py)
    for r, (status, iterations, fitness, pose) in zip(py, cpp):
        assert int(r.status.value) == status and r.iterations == iterations and r.fitness == fitness
        np.testing.assert_array_equal(r.pose, pose)
    # The localizer tracks the drive (constant velocity carries it between frames).
    for r, truth in zip(py, poses):
        assert r.ok, r
        assert np.abs(r.pose[:3, 3] - truth[:3, 3]).max() < 0.05
        assert np.abs(r.pose[:3, :3] - truth[:3, :3]).max() < 0.01
    assert loc.map_size == len(map_points)
    np.testing.assert_array_equal(loc.pose, py[-1].pose)


def test_localizer_from_graph_and_file_and_init(tmp_path, yard):
    map_points, poses, scans = yard
    a = dw.Localizer(map_points, max_distance=1.0)
    ra = a.register_scan(scans[2], init=poses[2] @ pose_xy_yaw(0.1, 0.1, 0.01))
    assert ra.ok and np.abs(ra.pose[:3, 3] - poses[2][:3, 3]).max() < 0.05
    path = tmp_path / "map.graph"
    a.save(str(path))
    for m in (dw.DelaunayGraph(map_points), path):
        b = dw.Localizer(m, max_distance=1.0)
        rb = b.register_scan(scans[2], init=poses[2] @ pose_xy_yaw(0.1, 0.1, 0.01))
        assert rb.ok and np.abs(rb.pose[:3, 3] - poses[2][:3, 3]).max() < 0.05
    assert a.map_normals().shape == (len(map_points), 3)


def test_localizer_bad_frames_get_statuses_and_bad_input_raises(tmp_path, yard):
    map_points, poses, scans = yard
    loc = dw.Localizer(map_points)
    assert loc.register_scan(np.zeros((0, 3), np.float32)).status == dw.FrameStatus.EmptyScan
    assert loc.register_scan(np.full((5, 3), np.nan)).status == dw.FrameStatus.NoFinitePoints
    far = loc.register_scan(scans[0] + np.float32(1000))
    assert far.status == dw.FrameStatus.NoCorrespondences and not far.ok
    with pytest.raises(ValueError, match="method"):
        dw.Localizer(map_points, method="plane")
    with pytest.raises(ValueError, match="kernel"):
        dw.Localizer(map_points, kernel="tukey")
    with pytest.raises(ValueError, match="min_fitness"):
        dw.Localizer(map_points, min_fitness=2)
    with pytest.raises(ValueError, match="shape"):
        loc.register_scan(np.zeros((4, 2)))
    with pytest.raises(TypeError, match="float32 or float64"):
        loc.register_scan(np.zeros((4, 3), np.int32))
    with pytest.raises(ValueError, match="4x4"):
        loc.register_scan(scans[0], init=np.eye(3))
    bad = tmp_path / "bad.graph"
    bad.write_bytes(b"not a graph")
    with pytest.raises(dw.GraphFileError, match="bad.graph"):
        dw.Localizer(bad)


def test_odometry_equals_cpp_and_tracks_a_drive(tmp_path):
    rng = np.random.default_rng(11)
    poses = drive(10)
    scans = [scan_at(rng, p) for p in poses]
    odo = dw.SlidingWindowOdometry(voxel=0.3, max_range=30.0, max_distance=1.0, threads=2)
    py = [odo.add_scan(s) for s in scans]
    files = []
    for i, s in enumerate(scans):
        f = tmp_path / f"{i}.f32"
        s.astype("<f4").tofile(f)
        files.append(str(f))
    out = subprocess.run([reference_exe(), "odometry", "0.3", "30", "1.0", "2"] + files,
                         check=True, capture_output=True, text=True).stdout
    cpp = parse_frames(out)
    for r, (status, iterations, fitness, pose) in zip(py, cpp):
        assert int(r.status.value) == status and r.iterations == iterations and r.fitness == fitness
        np.testing.assert_array_equal(r.pose, pose)
    assert f"map {odo.map_size}" in out
    # Poses are in the first scan's frame: compare with the true motion relative to it.
    first = np.linalg.inv(poses[0])
    for r, truth in zip(py, poses):
        assert r.ok, r
        rel = first @ truth
        assert np.abs(r.pose[:3, 3] - rel[:3, 3]).max() < 0.1
    assert odo.frames == len(scans)
    assert odo.map_points().shape == (odo.map_size, 3)
    assert odo.map_stats["inserted"] - odo.map_stats["removed"] == odo.map_size
    with pytest.raises(ValueError, match="voxel"):
        dw.SlidingWindowOdometry(voxel=0)


def test_concurrent_register_scan_calls_queue_up(yard):
    import threading

    map_points, poses, scans = yard
    loc = dw.Localizer(map_points, constant_velocity=False, threads=1)
    results, errors = [], []

    def work():
        try:
            for _ in range(3):
                results.append(loc.register_scan(scans[0], init=poses[0]))
        except Exception as e:  # noqa: BLE001  (reported below)
            errors.append(e)

    threads = [threading.Thread(target=work) for _ in range(3)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors and len(results) == 9
    for r in results:
        np.testing.assert_array_equal(r.pose, results[0].pose)
