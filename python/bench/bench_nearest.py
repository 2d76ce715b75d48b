"""Times the binding's batch nearest() against the same batch called from C++ (dw_py_reference) and
against SciPy's cKDTree(workers=-1), plus an ICP-like sequence where the walk starts at the last ends.

    . build/python/test_env.sh && $DW_PYTHON python/bench/bench_nearest.py [--points N] [--queries M]

Prints what it measured; the overhead is (binding - C++) / C++ on the fastest run of each. The binding
and the C++ reference (a separate process) alternate for --rounds rounds of --repeats runs each, so a
change of the machine's load between them shows in both.
"""

import argparse
import os
import subprocess
import tempfile
import time

import numpy as np
from scipy.spatial import cKDTree

import pcl_delaunay_walk as dw


def best_of(repeats, fn, clock=time.perf_counter):
    best = float("inf")
    for _ in range(repeats):
        t0 = clock()
        fn()
        best = min(best, clock() - t0)
    return best


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--points", type=int, default=200000)
    ap.add_argument("--queries", type=int, default=100000)
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--threads", type=int, default=0)
    ap.add_argument("--icp-iterations", type=int, default=10)
    a = ap.parse_args()
    rng = np.random.default_rng(1)
    points = rng.random((a.points, 3)).astype(np.float32)
    queries = (points[rng.choice(a.points, a.queries)] + rng.normal(0, 0.002, (a.queries, 3))).astype(np.float32)
    threads = a.threads or os.cpu_count()

    search = dw.NeighbourSearch(dw.DelaunayGraph(points))
    t_py = t_cpp = c_py = c_cpp = float("inf")
    batch = lambda: search.nearest(queries, strategy="kd-ann", threads=threads)  # noqa: E731
    with tempfile.TemporaryDirectory() as d:
        pf, qf = os.path.join(d, "p.f32"), os.path.join(d, "q.f32")
        points.tofile(pf)
        queries.tofile(qf)
        exe = os.environ.get("DW_PY_REFERENCE", "build/python/dw_py_reference")
        for _ in range(a.rounds):
            t_py = min(t_py, best_of(a.repeats, batch))
            c_py = min(c_py, best_of(a.repeats, batch, time.process_time))
            out = subprocess.run([exe, "nearest", pf, qf, str(threads), str(a.repeats)], check=True,
                                 capture_output=True, text=True).stdout
            fields = dict(line.split() for line in out.strip().splitlines())
            t_cpp = min(t_cpp, float(fields["seconds"]))
            c_cpp = min(c_cpp, float(fields["cpu_seconds"]))
    idx = search.nearest(queries, strategy="kd-ann")[0]
    assert int(fields["index_sum"]) == int(idx.sum()), "C++ and binding answers differ"
    tree = cKDTree(points)
    t_kd = best_of(a.repeats, lambda: tree.query(queries, workers=-1))

    # ICP-like: the same source moves a little each iteration; the walk starts where it last ended.
    steps = [queries + np.float32(0.0005 * k) for k in range(a.icp_iterations)]
    def walk_sequence():
        ends = None
        for q in steps:
            _, _, ends = search.nearest(q, hints=ends, threads=threads)
    t_walk_seq = best_of(max(1, a.repeats // 2), walk_sequence)
    t_kd_seq = best_of(max(1, a.repeats // 2), lambda: [tree.query(q, workers=-1) for q in steps])

    print(f"{a.points} points, {a.queries} queries, {threads} threads (fastest of {a.repeats})")
    print(f"  C++ batch (dw_py_reference)   {t_cpp * 1e3:9.2f} ms")
    print(f"  binding nearest()             {t_py * 1e3:9.2f} ms   overhead {100 * (t_py - t_cpp) / t_cpp:+.1f} %")
    print(f"  CPU time: C++ {c_cpp * 1e3:.2f} ms, binding {c_py * 1e3:.2f} ms   overhead "
          f"{100 * (c_py - c_cpp) / c_cpp:+.1f} % (steadier than wall time on a shared machine)")
    print(f"  cKDTree.query(workers=-1)     {t_kd * 1e3:9.2f} ms   {t_kd / t_py:.2f}x the binding's time")
    print(f"ICP-like sequence, {a.icp_iterations} batches")
    print(f"  walk with hints               {t_walk_seq * 1e3:9.2f} ms")
    print(f"  cKDTree(workers=-1)           {t_kd_seq * 1e3:9.2f} ms   walk {t_kd_seq / t_walk_seq:.2f}x faster")


if __name__ == "__main__":
    main()
