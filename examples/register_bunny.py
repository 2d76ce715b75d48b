"""Register the two bundled Stanford bunny scans (bun045 onto bun000) with the Delaunay-walk ICP and
print the transform, the timing and the error against the pose in data/bun.conf.

    . build/python/test_env.sh && $DW_PYTHON examples/register_bunny.py
"""

import pathlib
import sys
import time

import numpy as np

import pcl_delaunay_walk as dw

DATA = pathlib.Path(__file__).resolve().parents[1] / "data"
sys.path.insert(0, str(DATA.parent / "python" / "tests"))
from conftest import read_ply_xyz  # noqa: E402  (the tests' ASCII PLY reader)


def true_pose():
    """bun045 -> common frame from data/bun.conf: p' = R^T p + t, quaternion (x, y, z, w) as written."""
    for line in (DATA / "bun.conf").read_text().splitlines():
        w = line.split()
        if len(w) == 9 and w[1] == "bun045.ply":
            t, (x, y, z, qw) = np.array(w[2:5], float), map(float, w[5:9])
            r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * qw), 2 * (x * z + y * qw)],
                          [2 * (x * y + z * qw), 1 - 2 * (x * x + z * z), 2 * (y * z - x * qw)],
                          [2 * (x * z - y * qw), 2 * (y * z + x * qw), 1 - 2 * (x * x + y * y)]])
            m = np.eye(4)
            m[:3, :3], m[:3, 3] = r.T, t
            return m
    raise RuntimeError("bun045.ply not in bun.conf")


source, target = read_ply_xyz(DATA / "bun045.ply"), read_ply_xyz(DATA / "bun000.ply")
truth = true_pose()
init = np.eye(4)
init[:3, :3] = truth[:3, :3] @ np.array([[1, 0, 0], [0, np.cos(0.03), -np.sin(0.03)], [0, np.sin(0.03), np.cos(0.03)]])
init[:3, 3] = truth[:3, 3] + [0.003, -0.002, 0.0]  # the true pose, disturbed by 1.7 degrees and 3.6 mm
for method in ("point_to_point", "point_to_plane"):
    t0 = time.perf_counter()
    r = dw.icp(source, target, method=method, init=init, max_distance=0.005, max_iterations=50)
    seconds = time.perf_counter() - t0
    err = r["transform"] @ np.linalg.inv(truth)
    angle = np.degrees(np.arccos(np.clip((np.trace(err[:3, :3]) - 1) / 2, -1, 1)))
    nn = sum(s["nn_seconds"] for s in r["statistics"])
    print(f"{method}: {r['iterations']} iterations in {seconds:.3f} s (graph {r['graph_seconds']:.3f} s, "
          f"nearest neighbours {nn:.3f} s), fitness {r['fitness']:.3g}, converged {r['converged']}")
    print(np.array2string(r["transform"], precision=6, suppress_small=True))
    print(f"  vs bun.conf: {angle:.3f} deg, {np.linalg.norm(err[:3, 3]) * 1e3:.2f} mm")
