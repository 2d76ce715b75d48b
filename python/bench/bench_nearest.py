"""Times the binding's batch nearest() against the same batch called from C++ and against SciPy's
cKDTree(workers=-1) where SciPy is installed, plus an ICP-like sequence where the walk starts at the
last ends.

    . build/python/test_env.sh && $DW_PYTHON python/bench/bench_nearest.py [--points N] [--queries M]

The C++ batch is python/src/reference_nearest.h, run inside this process (_cpp_nearest_seconds) on
the same graph and the same queries, so both read the same memory; with --process-reference also
as a separate program (dw_py_reference), which builds its own graph. Prints what it measured; the
overhead is (binding - C++) / C++ on the fastest run of each. The binding and the C++ batch
alternate for --rounds rounds of --repeats runs each, so a change of the machine's load between
them shows in both.
"""

import argparse
import os
import subprocess
import tempfile
import time

import numpy as np

import pcl_delaunay_walk as dw
from pcl_delaunay_walk import _native

try:
    from scipy.spatial import cKDTree
except ImportError:  # the device machine has NumPy only
    cKDTree = None


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
    ap.add_argument("--big-points", type=int, default=0,
                    help="also time small kNN and radius batches on a graph of this many points: first call vs later ones")
    ap.add_argument("--process-reference", action="store_true",
                    help="also time the C++ batch as a separate program (dw_py_reference)")
    a = ap.parse_args()
    rng = np.random.default_rng(1)
    points = rng.random((a.points, 3)).astype(np.float32)
    queries = (points[rng.choice(a.points, a.queries)] + rng.normal(0, 0.002, (a.queries, 3))).astype(np.float32)
    threads = a.threads or os.cpu_count()

    search = dw.NeighbourSearch(dw.DelaunayGraph(points))
    batch = lambda: search.nearest(queries, strategy="kd-ann", threads=threads)  # noqa: E731
    t_py = c_py = t_cpp = c_cpp = float("inf")
    for _ in range(a.rounds):
        t_py = min(t_py, best_of(a.repeats, batch))
        c_py = min(c_py, best_of(a.repeats, batch, time.process_time))
        wall, cpu, index_sum = _native._cpp_nearest_seconds(search, queries, threads, a.repeats)
        t_cpp, c_cpp = min(t_cpp, wall), min(c_cpp, cpu)
    idx = search.nearest(queries, strategy="kd-ann")[0]
    assert index_sum == int(idx.sum()), "C++ and binding answers differ"
    t_proc = process_reference(a, points, queries, threads, index_sum) if a.process_reference else None
    tree = cKDTree(points) if cKDTree else None
    t_kd = best_of(a.repeats, lambda: tree.query(queries, workers=-1)) if tree else None

    # ICP-like: the same source moves a little each iteration; the walk starts where it last ended.
    steps = [queries + np.float32(0.0005 * k) for k in range(a.icp_iterations)]
    def walk_sequence():
        ends = None
        for q in steps:
            _, _, ends = search.nearest(q, hints=ends, threads=threads)
    t_walk_seq = best_of(max(1, a.repeats // 2), walk_sequence)
    t_kd_seq = best_of(max(1, a.repeats // 2), lambda: [tree.query(q, workers=-1) for q in steps]) if tree else None

    print(f"{a.points} points, {a.queries} queries, {threads} threads (fastest of {a.repeats})")
    print(f"  C++ batch, same process       {t_cpp * 1e3:9.2f} ms")
    print(f"  binding nearest()             {t_py * 1e3:9.2f} ms   overhead {100 * (t_py - t_cpp) / t_cpp:+.1f} %")
    print(f"  CPU time: C++ {c_cpp * 1e3:.2f} ms, binding {c_py * 1e3:.2f} ms   overhead "
          f"{100 * (c_py - c_cpp) / c_cpp:+.1f} % (steadier than wall time on a shared machine)")
    if t_proc is not None:
        print(f"  C++ batch, own process        {t_proc * 1e3:9.2f} ms (dw_py_reference: its own graph)")
    if tree:
        print(f"  cKDTree.query(workers=-1)     {t_kd * 1e3:9.2f} ms   {t_kd / t_py:.2f}x the binding's time")
    print(f"ICP-like sequence, {a.icp_iterations} batches")
    print(f"  walk with hints               {t_walk_seq * 1e3:9.2f} ms")
    if tree:
        print(f"  cKDTree(workers=-1)           {t_kd_seq * 1e3:9.2f} ms   walk {t_kd_seq / t_walk_seq:.2f}x faster")
    else:
        print("  cKDTree: SciPy not installed, skipped")
    if a.big_points:
        small_batches(a, rng, threads)


def small_batches(a, rng, threads):
    """kNN (k = 16) and radius batches of 2,000 queries on a big graph, call after call: a worker sizes
    its search scratch (a stamp per vertex) once, so later calls must not pay it again."""
    big = rng.random((a.big_points, 3)).astype(np.float32)
    search = dw.NeighbourSearch(dw.DelaunayGraph(big))
    q = rng.random((2000, 3)).astype(np.float32)
    r = float(np.cbrt(16 / (4.18879 * a.big_points)))  # a ball holding ~16 points
    for name, call in (("knn(k=16)", lambda: search.knn(q, 16, threads=threads)),
                       ("radius(~16 points)", lambda: search.radius(q, r, threads=threads))):
        times = []
        for _ in range(8):
            t0 = time.perf_counter()
            call()
            times.append(time.perf_counter() - t0)
        print(f"{a.big_points} points, 2000 queries, {name}, {threads} threads: first call "
              f"{times[0] * 1e3:.2f} ms, later calls median {np.median(times[1:]) * 1e3:.2f} ms")


def process_reference(a, points, queries, threads, index_sum):
    """The same C++ batch in dw_py_reference, a separate process that builds its own graph."""
    exe = os.environ.get("DW_PY_REFERENCE", "build/python/dw_py_reference")
    best = float("inf")
    with tempfile.TemporaryDirectory() as d:
        pf, qf = os.path.join(d, "p.f32"), os.path.join(d, "q.f32")
        points.tofile(pf)
        queries.tofile(qf)
        for _ in range(a.rounds):
            out = subprocess.run([exe, "nearest", pf, qf, str(threads), str(a.repeats)], check=True,
                                 capture_output=True, text=True).stdout
            fields = dict(line.split() for line in out.strip().splitlines())
            assert int(fields["index_sum"]) == index_sum, "dw_py_reference and binding answers differ"
            best = min(best, float(fields["seconds"]))
    return best

if __name__ == "__main__":
    main()
