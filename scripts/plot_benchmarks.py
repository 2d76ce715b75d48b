#!/usr/bin/python3
"""Figures and tables from dw_bench's CSV files (scripts/benchmark.sh runs it).

Figures mirror the Delaunay-walk paper's (Anderson et al. 2022): walk-count histograms per start
strategy (Figs. 8-9), ICP runtime per data set and method (Fig. 11), per-iteration runtime over the
iterations (Fig. 14) and the ICP step breakdown (Figs. 1-2); plus per-query NN time and thread scaling.
Tables (markdown, for docs/benchmarks.md) go to <results>/tables.md.

usage: plot_benchmarks.py RESULTS_DIR [--figures docs/figures]
       plot_benchmarks.py --peers PEERS_DIR [--figures docs/figures]

With --peers, PEERS_DIR holds dw_peers' CSV files (bench/dw_peers.cpp: build.csv, nn.csv, knn.csv,
icp.csv, meta.csv, or folders of them, e.g. one per data set; dw_pcl_pipelines' pipelines.csv): the
figures peers_*.png (per-query time against cloud size per method, thread scaling, kNN time against k,
the ICP time breakdown, build time against n, PCL's pipelines per search) and PEERS_DIR/tables.md.

RESULTS_DIR holds dw_bench's CSV files, or folders of them (bench/run_grid.sh writes one folder per job:
files of the same name are concatenated; where two rows measure the same thing, the one from the file
that sorts last wins). A `scaling/` folder (tools/device/run_grid.sh: the thread scaling run, alone on
the machine) feeds the thread-scaling table only. RESULTS_DIR/runs.txt may name, one per line in the
order they were made, folders that each hold one whole run on one machine (e.g. two device calls):
a table row then never mixes runs: each ICP row comes from the latest run with at least
MIN_ROTATIONS rotations that every method finished (else the run with the most), each per-query row
from the run with the most methods. RESULTS_DIR/superseded.txt may list, one per line,
"<folder> <method,method,...>": rows of those methods under that folder are ignored (e.g. walk rows
of a run made before a change to the walk, when a later run redid them).
"""
import argparse
import csv
import glob
import math
import os
import statistics
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

METHOD_ORDER = ["brute-force", "pcl-kdtree", "nanoflann", "pcl-octree", "walk-zero", "walk-kd-ann",
                "walk-pnn", "walk-pnn-prefetch", "walk-pnn-optimized", "walk-pnn-optimized-prefetch",
                "dw-estimator"]
WALKS = ["walk-zero", "walk-kd-ann", "walk-pnn", "walk-pnn-optimized"]
# The seed's mean walk counts (Anderson et al. 2022, §5), quoted for comparison.
SEED_WALKS = {"walk-zero": "~26 (dragon 62k)", "walk-kd-ann": "~5 (dragon 62k)",
              "walk-pnn": "1.4-2.1 (teapot 1.39 -> 1.56 when doubled)", "walk-pnn-optimized": "~1.4-2"}


def read_one(path):
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def superseded(res):
    out = []
    path = os.path.join(res, "superseded.txt")
    if os.path.exists(path):
        with open(path) as f:
            for line in f:
                words = line.split()
                if len(words) == 2 and not words[0].startswith("#"):
                    out.append((words[0].rstrip("/") + "/", set(words[1].split(","))))
    return out


def read(path, scaling=False):
    """Rows of RESULTS/name and of every RESULTS/**/name (one folder per job), concatenated in path
    order; each row remembers its file in "_src". The scaling run's files are read only when asked for
    (they were measured under other conditions)."""
    res, name = os.path.split(path)
    sup = superseded(res)
    rows = []
    for p in sorted({path} | set(glob.glob(os.path.join(res, "**", name), recursive=True))):
        rel = os.path.relpath(p, res)
        in_scaling = os.sep + "scaling" + os.sep in os.sep + rel
        if in_scaling != scaling:
            continue
        drop = set()
        for folder, methods in sup:
            if rel.startswith(folder):
                drop |= methods
        for r in read_one(p):
            if r.get("method") not in drop:
                r["_src"] = rel
                rows.append(r)
    return rows


MIN_ROTATIONS = 25  # enough rotations for a stable median (of 124)


def runs_of(res):
    path = os.path.join(res, "runs.txt")
    if not os.path.exists(path):
        return []
    with open(path) as f:
        return [l.strip().rstrip("/") for l in f if l.strip() and not l.startswith("#")]


def run_of(r, runs):
    first = r["_src"].split(os.sep)[0]
    return first if first in runs else ""


def latest(rows, key):
    """Of rows grouped by key(row), only those from the last file (by path) that has the group: a
    histogram or an iteration trace must not mix two runs."""
    last = {}
    for r in rows:
        k = key(r)
        last[k] = max(last.get(k, ""), r["_src"])
    return [r for r in rows if r["_src"] == last[key(r)]]


def order(methods):
    return sorted(methods, key=lambda m: METHOD_ORDER.index(m) if m in METHOD_ORDER else 99)


def dataset_order(rows):
    sizes = {}
    for r in rows:
        if "points" in r:
            sizes[r["dataset"]] = int(r["points"])
    return sorted(sizes, key=lambda d: sizes[d]) if sizes else sorted({r["dataset"] for r in rows})


def fmt_time(s):
    if s >= 1:
        return f"{s:.2f} s"
    if s >= 1e-3:
        return f"{s * 1e3:.1f} ms"
    return f"{s * 1e6:.0f} µs"


def table(header, rows):
    out = ["| " + " | ".join(header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    out += ["| " + " | ".join(str(c) for c in r) + " |" for r in rows]
    return "\n".join(out)


def build_section(res, figs, md):
    rows = read(os.path.join(res, "build.csv"))
    if not rows:
        return
    data = dataset_order(rows)
    by = {(r["dataset"], r["method"]): float(r["seconds"]) for r in rows}
    methods = [m for m in ["brute-force", "pcl-kdtree", "nanoflann", "pcl-octree", "walk-graph-qhull",
                           "walk-graph-incremental"]
               if any(k[1] == m for k in by)]
    md.append("### Build time (CPU time, one thread)\n")
    ratio = [("walk-graph-qhull", "Qhull graph / nanoflann"), ("walk-graph-incremental", "incremental graph / nanoflann")]
    md.append(table(["data set"] + methods + [r[1] for r in ratio if r[0] in methods],
                    [[d] + [fmt_time(by[(d, m)]) if (d, m) in by else "–" for m in methods] +
                     [f"{by[(d, g)] / by[(d, 'nanoflann')]:.0f}×" if (d, g) in by and (d, "nanoflann") in by else "–"
                      for g, _ in ratio if g in methods] for d in data]))
    md.append("")


def nn_section(res, figs, md):
    rows = read(os.path.join(res, "nn.csv"))
    if not rows:
        return
    data = dataset_order(rows)
    run_names = runs_of(res)
    if run_names:  # each data set's row from one run: the one with the most methods (ties: the later)
        keep = {}
        for d in data:
            counts = {run: len({r["method"] for r in rows if r["dataset"] == d and run_of(r, run_names) == run})
                      for run in run_names}
            keep[d] = max(run_names, key=lambda run: (counts[run], run_names.index(run)))
        rows = [r for r in rows if run_of(r, run_names) == keep[r["dataset"]]]
    one = {(r["dataset"], r["method"]): r for r in rows if r["threads"] == "1"}
    methods = order({r["method"] for r in rows})
    key = "cpu_ns_per_query" if "cpu_ns_per_query" in rows[0] else "ns_per_query"
    md.append("### Per-query NN time on ICP-like query sequences (one thread, %s ns/query)\n"
              % ("CPU" if key.startswith("cpu") else "wall-clock"))
    hdr = ["data set", "queries"] + methods + ["PNN vs nanoflann", "PNN vs pcl-kdtree", "wrong answers"]
    body = []
    for d in data:
        r0 = next(r for r in rows if r["dataset"] == d)
        line = [f"{d} ({int(r0['points']):,} pts)", f"{int(r0['queries']):,} ({r0['icp_iterations']} it)"]
        for m in methods:
            line.append(f"{float(one[(d, m)][key]):.0f}" if (d, m) in one else "–")
        pnn = one.get((d, "walk-pnn"))
        for peer in ["nanoflann", "pcl-kdtree"]:
            p = one.get((d, peer))
            line.append(f"{float(p[key]) / float(pnn[key]):.1f}×" if p and pnn else "–")
        line.append(str(sum(int(r["wrong"]) for r in rows if r["dataset"] == d and r["threads"] == "1")))
        body.append(line)
    md.append(table(hdr, body))
    md.append("")
    # Walk statistics next to the seed's.
    md.append("### Walk counts (moves per query; the seed counts visited vertices = moves + 1)\n")
    body = []
    for d in data:
        for m in WALKS:
            r = one.get((d, m))
            if r:
                body.append([d, m, f"{float(r['mean_steps']):.2f}", f"{float(r['mean_visited']):.2f}",
                             r["p99_steps"].split(".")[0], r["max_steps"].split(".")[0], SEED_WALKS[m]])
    md.append(table(["data set", "start", "mean moves", "mean visited", "p99", "max", "seed (visited)"], body))
    md.append("")
    # Figure: per-query time per data set and method.
    fig, ax = plt.subplots(figsize=(10, 4.5))
    width = 0.8 / max(1, len(methods))
    for k, m in enumerate(methods):
        xs, ys = [], []
        for i, d in enumerate(data):
            if (d, m) in one:
                xs.append(i + k * width)
                ys.append(float(one[(d, m)][key]))
        ax.bar(xs, ys, width, label=m)
    ax.set_xticks([i + 0.4 - width / 2 for i in range(len(data))])
    ax.set_xticklabels(data, fontsize=8, rotation=20, ha="right")
    ax.set_yscale("log")
    ax.set_ylabel("%s ns per query (1 thread)" % ("CPU" if key.startswith("cpu") else "wall"))
    ax.set_title("Exact NN on ICP-like query sequences")
    ax.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "nn_per_query.png"), dpi=120)
    plt.close(fig)


def scaling_section(res, figs, md):
    """Thread scaling: from the scaling run (alone on its machine) where there is one, else from the
    per-query runs' own thread counts."""
    rows = read(os.path.join(res, "nn.csv"))
    srows = read(os.path.join(res, "nn.csv"), scaling=True) or rows
    threads = sorted({int(r["threads"]) for r in srows})
    if len(threads) > 1:
        md.append("### Thread scaling (wall-clock ns/query; speed-up over one thread)\n")
        body = []
        sdata = dataset_order(srows)
        smethods = order({r["method"] for r in srows})
        fig, axes = plt.subplots(1, len(sdata), figsize=(5 * len(sdata), 4), squeeze=False)
        for ax, d in zip(axes[0], sdata):
            for m in smethods:
                mine = latest([r for r in srows if r["dataset"] == d and r["method"] == m],
                              lambda r: run_of(r, runs_of(res)) and "") if runs_of(res) else \
                    [r for r in srows if r["dataset"] == d and r["method"] == m]
                cells = {int(r["threads"]): float(r["ns_per_query"]) for r in mine}
                if 1 not in cells:
                    continue
                src = {run_of(r, runs_of(res)) for r in mine}
                body.append([d, m + (f" ({'/'.join(sorted(src))})" if any(src) else "")] +
                            [f"{cells[t]:.0f} ({cells[1] / cells[t]:.1f}×)" if t in cells else "–" for t in threads])
                ts = sorted(cells)
                ax.plot(ts, [cells[1] / cells[t] for t in ts], marker="o", label=m)
            ax.plot(threads, threads, color="grey", linestyle=":", label="linear")
            ax.set_xscale("log", base=2)
            ax.set_yscale("log", base=2)
            ax.set_xlabel("threads")
            ax.set_ylabel("speed-up over 1 thread (wall)")
            ax.set_title(f"Thread scaling, {d}")
            ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(os.path.join(figs, "thread_scaling.png"), dpi=110)
        plt.close(fig)
        md.append(table(["data set", "method"] + [f"{t} thread{'s' if t > 1 else ''}" for t in threads], body))
        md.append("")


def hist_section(res, figs, md):
    rows = latest(read(os.path.join(res, "walk_hist.csv")), lambda r: (r["dataset"], r["method"]))
    if not rows:
        return
    for d in sorted({r["dataset"] for r in rows}):
        fig, axes = plt.subplots(1, 4, figsize=(14, 3.2), sharey=True)
        for ax, m in zip(axes, WALKS):
            h = [(int(r["steps"]), int(r["count"])) for r in rows if r["dataset"] == d and r["method"] == m]
            if not h:
                ax.set_visible(False)
                continue
            total = sum(c for _, c in h)
            mean = sum(s * c for s, c in h) / total
            ax.bar([s for s, _ in h], [c / total for _, c in h], width=1.0)
            ax.set_yscale("log")
            ax.set_title(f"{m}: mean {mean:.2f} moves", fontsize=9)
            ax.set_xlabel("walk moves per query")
        axes[0].set_ylabel("fraction of queries")
        fig.suptitle(f"Walk-count histograms, {d} (seed Figs. 8-9)")
        fig.tight_layout()
        fig.savefig(os.path.join(figs, f"walk_hist_{d.replace(':', '_')}.png"), dpi=110)
        plt.close(fig)


def icp_section(res, figs, md):
    rows = read(os.path.join(res, "icp.csv"))
    if not rows:
        return
    data = dataset_order(rows)
    methods = order({r["method"] for r in rows})
    run_names = runs_of(res)
    picked = {}
    for noise in sorted({r["noise"] for r in rows}):
        sel = [r for r in rows if r["noise"] == noise]
        # Medians over the rotations that every method of the data set finished (a run stopped at a
        # deadline may miss a method's last rotations); a method with far fewer rotations than the
        # others (< 90%) gets the median of its own and is marked with its count.
        med, common_n = {}, {}
        for d in data:
            rows_d = [r for r in sel if r["dataset"] == d]
            if not rows_d:
                continue
            # Several runs (runs.txt): the row comes from one run, so that its methods were measured on
            # one machine at one time.
            all_methods = {r["method"] for r in rows_d}
            pick, best = "", None
            for run in run_names:
                by = defaultdict(set)
                for r in rows_d:
                    if run_of(r, run_names) == run:
                        by[r["method"]].add(r["rotation"])
                n = len(set.intersection(*(by[m] for m in all_methods))) if all(by[m] for m in all_methods) else 0
                if n and (best is None or n >= MIN_ROTATIONS or n > best):
                    pick, best = run, n
            if run_names and best:
                rows_d = [r for r in rows_d if run_of(r, run_names) == pick]
                picked[(d, noise)] = pick
            runs = defaultdict(dict)
            for r in rows_d:
                runs[r["method"]][r["rotation"]] = r
            most = max(len(v) for v in runs.values())
            # Within one picked run every method counts (the medians are over the rotations all of
            # them finished); otherwise a method far behind the others is shown on its own.
            full = list(runs) if (d, noise) in picked else [m for m in runs if len(runs[m]) >= 0.9 * most]
            common = set.intersection(*(set(runs[m]) for m in full))
            common_n[d] = len(common)
            for m, by_rot in runs.items():
                sub = [by_rot[k] for k in (common if m in full else by_rot)]
                if not sub:
                    continue
                t = [float(r.get("cpu_seconds") or r["align_seconds"]) for r in sub]
                med[(d, m)] = (statistics.median(t), statistics.median(int(r["iterations"]) for r in sub),
                               max(float(r["rot_err_deg"]) for r in sub), len(sub), m in full)
        label = "noise on the target" if noise == "1" else "no noise"
        md.append(f"### ICP align() CPU time per data set and method ({label}; median over the rotations, "
                  "structure prebuilt)\n")
        body = []
        for d in data:
            if not any((d, m) in med for m in methods):
                continue
            line = [d]
            for m in methods:
                if (d, m) not in med:
                    line.append("–")
                else:
                    line.append(fmt_time(med[(d, m)][0]) + ("" if med[(d, m)][4] else f" ({med[(d, m)][3]} rot.)"))
            if (d, "pcl-kdtree") in med and (d, "walk-pnn-optimized") in med:
                line.append(f"{med[(d, 'pcl-kdtree')][0] / med[(d, 'walk-pnn-optimized')][0]:.1f}×")
            else:
                line.append("–")
            its = {med[(d, m)][1] for m in methods if (d, m) in med}
            line.append("/".join(str(int(i)) for i in sorted(its)))
            line.append(str(common_n[d]) + (f" ({picked[(d, noise)]})" if (d, noise) in picked else ""))
            line.append(f"{max(med[(d, m)][2] for m in methods if (d, m) in med):.2g}°")
            body.append(line)
        md.append(table(["data set"] + methods + ["kdtree / PNN-opt", "median iterations", "rotations",
                                                  "max rot. error"], body))
        md.append("")
        # The walks' ratios to each peer (ratio of the medians above: > 1 means the walk is faster).
        peers = [p for p in ["brute-force", "pcl-kdtree", "nanoflann", "pcl-octree"] if p in methods]
        ours = [w for w in ["walk-pnn", "walk-pnn-optimized", "walk-pnn-optimized-prefetch", "dw-estimator"]
                if w in methods]
        body = []
        for d in data:
            for w in ours:
                if (d, w) not in med:
                    continue
                body.append([d, w] + [f"{med[(d, p)][0] / med[(d, w)][0]:.1f}×" if (d, p) in med else "–"
                                      for p in peers])
        md.append(f"#### Speed-up of the walks over each peer, ICP align() ({label})\n")
        md.append(table(["data set", "ours"] + ["vs " + p for p in peers], body))
        md.append("")
        # Fig. 11: runtime per data set and method.
        fig, ax = plt.subplots(figsize=(10, 4.5))
        width = 0.8 / max(1, len(methods))
        for k, m in enumerate(methods):
            xs = [i + k * width for i, d in enumerate(data) if (d, m) in med]
            ys = [med[(d, m)][0] for d in data if (d, m) in med]
            ax.bar(xs, ys, width, label=m)
        ax.set_xticks([i + 0.4 - width / 2 for i in range(len(data))])
        ax.set_xticklabels(data, fontsize=8, rotation=20, ha="right")
        ax.set_yscale("log")
        ax.set_ylabel("ICP align() CPU seconds (median)")
        ax.set_title(f"ICP runtime per data set and method, {label} (seed Fig. 11)")
        ax.legend(fontsize=7, ncol=3)
        fig.tight_layout()
        fig.savefig(os.path.join(figs, f"icp_runtime_noise{noise}.png"), dpi=120)
        plt.close(fig)
    # Figs. 1-2: step breakdown on the largest data set, no noise. The step timers are wall-clock; on a
    # loaded machine each run's parts are scaled by its CPU/wall ratio so that they add up to its CPU
    # time. Build times come from the build section (CPU) where it ran.
    builds = {r["method"]: float(r["seconds"]) for r in read(os.path.join(res, "build.csv"))
              if r["dataset"] == data[-1]}
    big = data[-1]
    sel = [r for r in rows if r["dataset"] == big and r["noise"] == rows[0]["noise"]]
    present = [m for m in methods if any(r["method"] == m for r in sel)]
    parts = ["build", "nn", "svd", "other"]
    body = {p: [] for p in parts}
    for m in present:
        runs = [r for r in sel if r["method"] == m]
        scale = [float(r["cpu_seconds"]) / float(r["align_seconds"]) if r.get("cpu_seconds") else 1.0 for r in runs]
        for p in ["nn", "svd", "other"]:
            body[p].append(statistics.median(float(r[p + "_seconds"]) * k for r, k in zip(runs, scale)))
        graph = builds.get("walk-graph-incremental", builds.get("walk-graph-qhull"))
        b = builds.get(m, graph if (m.startswith("walk-") or m == "dw-estimator") else None)
        body["build"].append(b if b is not None else statistics.median(float(r["build_seconds"]) for r in runs))
    fig, ax = plt.subplots(figsize=(9, 4))
    bottoms = [0.0] * len(present)
    for p in parts:
        ax.bar(present, body[p], bottom=bottoms, label=p)
        bottoms = [b + v for b, v in zip(bottoms, body[p])]
    ax.set_ylabel("CPU seconds (median over rotations)")
    ax.set_title(f"ICP step breakdown, {big} (seed Figs. 1-2)")
    ax.tick_params(axis="x", labelrotation=30, labelsize=8)
    ax.legend()
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "icp_breakdown.png"), dpi=120)
    plt.close(fig)
    md.append(f"### ICP step breakdown, {big} (CPU seconds, median; NN share of the registration time)\n")
    md.append(table(["method", "build (separate)", "NN", "SVD", "other", "NN share"],
                    [[m] + [fmt_time(body[p][i]) for p in parts] +
                     [f"{100 * body['nn'][i] / max(1e-12, body['nn'][i] + body['svd'][i] + body['other'][i]):.0f}%"]
                     for i, m in enumerate(present)]))
    md.append("")
    # Fig. 14: per-iteration runtime on the largest data set (scaled like the breakdown).
    it_rows = latest([r for r in read(os.path.join(res, "icp_iter.csv"))
                      if r["dataset"] == big and r["noise"] == rows[0]["noise"]], lambda r: r["method"])
    if it_rows:
        rot = it_rows[0]["rotation"]
        scale = {r["method"]: float(r["cpu_seconds"]) / float(r["align_seconds"]) if r.get("cpu_seconds") else 1.0
                 for r in sel if r["rotation"] == rot}
        fig, ax = plt.subplots(figsize=(9, 4))
        for m in order({r["method"] for r in it_rows}):
            pts = sorted((int(r["iteration"]), float(r["seconds"])) for r in it_rows if r["method"] == m)
            ax.plot([p[0] for p in pts], [p[1] * 1e3 * scale.get(m, 1.0) for p in pts], marker=".", label=m)
        ax.set_yscale("log")
        ax.set_xlabel("ICP iteration")
        ax.set_ylabel("ms per iteration (CPU-scaled)")
        ax.set_title(f"Per-iteration runtime, {big}, rotation {rot} (seed Fig. 14)")
        ax.legend(fontsize=7, ncol=3)
        fig.tight_layout()
        fig.savefig(os.path.join(figs, "icp_per_iteration.png"), dpi=120)
        plt.close(fig)


def accept_section(res, figs, md):
    rows = read(os.path.join(res, "accept.csv"))
    if not rows:
        return
    v = {r["variant"]: r for r in rows}
    d = rows[0]["dataset"]
    has_cpu = "cpu_seconds" in rows[0]
    s = float(v["stock-icp-kdtree"]["seconds"])
    sc = float(v["stock-icp-kdtree"]["cpu_seconds"]) if has_cpu else None
    md.append(f"### End-to-end align(), {d}, rotation 10/10/10°, one thread\n")
    labels = [("stock-icp-kdtree", "stock pcl::IterativeClosestPoint (FLANN KdTree, built inside align())"),
              ("icp-walk-estimator-excl-build", "same ICP + CorrespondenceEstimationDelaunayWalk, excluding graph build"),
              ("icp-walk-estimator-incl-build", "same, including the graph build (pcl::search::DelaunayWalk, default builder)")]
    body = []
    for key, label in labels:
        if key not in v:
            continue
        t = float(v[key]["seconds"])
        line = [label, v[key]["iterations"], fmt_time(t), f"{s / t:.1f}×"]
        if has_cpu:
            c = float(v[key]["cpu_seconds"])
            line += [fmt_time(c), f"{sc / c:.1f}×"]
        body.append(line)
    md.append(table(["variant", "iterations", "wall", "speed-up (wall)"] +
                    (["CPU (process)", "speed-up (CPU)"] if has_cpu else []), body))
    md.append("")


def scan2scan_section(res, figs, md):
    rows = read(os.path.join(res, "scan2scan.csv"))
    if not rows:
        return
    labels = [("stock-icp-kdtree", "stock pcl::IterativeClosestPoint (builds its FLANN KdTree)"),
              ("icp-nanoflann", "same ICP, nanoflann estimator (bench adaptor), build included"),
              ("icp-walk-pnn-optimized", "same ICP, core walk PNN-optimized (bench adaptor), graph build included"),
              ("icp-walk-estimator", "same ICP + CorrespondenceEstimationDelaunayWalk, graph build included")]
    pairs = []
    for r in rows:  # files before the pair column held the fast_gicp pair only
        r.setdefault("pair", "fastgicp")
        r.setdefault("error_against", "reference")
        if r["pair"] not in pairs:
            pairs.append(r["pair"])
    for pair in pairs:
        v = {r["variant"]: r for r in rows if r["pair"] == pair}  # the file that sorts last wins
        r0 = next(iter(v.values()))
        against = ("the pair's reference transform" if r0["error_against"] == "reference"
                   else "the stock ICP's pose (no reference shipped)")
        md.append(f"### Scan-to-scan, {pair}: every structure built inside the timing (one thread)\n")
        md.append(f"Source {int(r0['source_points']):,} → target {int(r0['target_points']):,} points (no-return "
                  f"points removed), max correspondence distance {float(r0['max_distance']):g} m, identity initial "
                  f"guess; error against {against}.\n")
        base = float(v["stock-icp-kdtree"]["cpu_seconds"]) if "stock-icp-kdtree" in v else None
        nano = float(v["icp-nanoflann"]["cpu_seconds"]) if "icp-nanoflann" in v else None
        body = []
        for key, label in labels:
            if key not in v:
                continue
            r = v[key]
            c = float(r["cpu_seconds"])
            build = "inside align()" if key == "stock-icp-kdtree" else fmt_time(float(r["build_cpu_seconds"]))
            body.append([label, r["iterations"], fmt_time(c), build,
                         f"{base / c:.1f}×" if base else "–", f"{nano / c:.2f}×" if nano else "–",
                         f"{float(r['rot_err_deg']):.3g}°", f"{100 * float(r['trans_err']):.3g} cm"])
        md.append(table(["variant", "iterations", "CPU incl. build", "of which build", "vs stock", "vs nanoflann",
                         "rot. error", "trans. error"], body))
        md.append("")


# ---- dw_peers (bench/dw_peers.cpp): the 2026 peers side by side --------------------------------------

def peers_read(res, name):
    rows = []
    for p in sorted(set(glob.glob(os.path.join(res, name))) | set(glob.glob(os.path.join(res, "**", name),
                                                                            recursive=True))):
        rows += read_one(p)
    return rows


def peers_style(method):
    """Walks solid, trees dashed; one colour per method family."""
    colours = {"walk-pnn-optimized": "C3", "walk-kd-ann": "C1", "walk-pnn-optimized-sorted-prefetch": "C5",
               "pico_tree": "C0", "nanoflann-1.12": "C2", "nanoflann-1.4": "C8", "small_gicp": "C4",
               "pcl-kdtree": "C7"}
    c = next((colours[k] for k in sorted(colours, key=len, reverse=True) if method.startswith(k)), "C9")
    return dict(color=c, linestyle="-" if method.startswith("walk-") else "--", marker="o")


def peers_by_size(rows):
    return sorted({(int(r["points"]), r["dataset"]) for r in rows})


def peers_nn(res, figs, md):
    rows = [r for r in peers_read(res, "nn.csv")]
    if not rows:
        return
    sets = peers_by_size(rows)
    for order in ("icp", "shuffled"):
        one = [r for r in rows if r["order"] == order and r["threads"] == "1"]
        methods = sorted({r["method"] for r in one}, key=lambda m: (not m.startswith("walk-"), m))
        ns = {(r["dataset"], r["method"]): float(r["cpu_ns_per_query"]) for r in one}
        wrong = sum(int(r["wrong"]) for r in one)
        md.append(f"### Exact 1-NN, ICP-like sequence, queries in {'ICP' if order == 'icp' else 'shuffled'} order, "
                  f"one thread (CPU ns/query; wrong answers: {wrong})\n")
        hdr = ["data set (points)"] + methods + ["fastest peer / default walk", "/ estimator order"]
        body = []
        for n, d in sets:
            peers = [ns[(d, m)] for m in methods if not m.startswith("walk-") and (d, m) in ns]
            ratios = []
            for w in ("walk-pnn-optimized", "walk-pnn-optimized-sorted-prefetch"):
                walk = ns.get((d, w))
                ratios.append(f"**{min(peers) / walk:.2f}×**" if peers and walk else "–")
            if not peers and not any((d, m) in ns for m in methods):
                continue
            body.append([f"{d} ({n:,})"] + [f"{ns[(d, m)]:.0f}" if (d, m) in ns else "–" for m in methods] + ratios)
        md.append(table(hdr, body))
        md.append("")
        if order == "icp":
            fig, ax = plt.subplots(figsize=(7, 4.5))
            for m in methods:
                pts = [(n, ns[(d, m)]) for n, d in sets if (d, m) in ns]
                if pts:
                    ax.plot(*zip(*pts), label=m, **peers_style(m))
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel("reference points")
            ax.set_ylabel("ns per query (CPU, one thread)")
            ax.set_title("Exact 1-NN on ICP-like query sequences")
            for n, d in sets:
                ax.annotate(d, (n, ax.get_ylim()[0]), fontsize=6, rotation=90, va="bottom")
            ax.legend(fontsize=7)
            fig.tight_layout()
            fig.savefig(os.path.join(figs, "peers_nn_per_query.png"), dpi=110)
            plt.close(fig)
    multi = [r for r in rows if r["order"] == "icp"]
    threads = sorted({int(r["threads"]) for r in multi})
    if len(threads) > 1:
        sets_t = sorted({r["dataset"] for r in multi})
        fig, axes = plt.subplots(1, len(sets_t), figsize=(4 * len(sets_t), 3.8), squeeze=False)
        md.append("### Thread scaling, ICP order (wall ns/query)\n")
        for ax, d in zip(axes[0], sets_t):
            methods = sorted({r["method"] for r in multi if r["dataset"] == d})
            for m in methods:
                pts = sorted((int(r["threads"]), float(r["ns_per_query"])) for r in multi
                             if r["dataset"] == d and r["method"] == m)
                ax.plot(*zip(*pts), label=m, **peers_style(m))
                md.append(f"- {d}, {m}: " + ", ".join(f"{t}: {v:.0f}" for t, v in pts))
            ax.set_xscale("log", base=2)
            ax.set_yscale("log")
            ax.set_title(d)
            ax.set_xlabel("threads")
        axes[0][0].set_ylabel("ns per query (wall)")
        axes[0][0].legend(fontsize=6)
        fig.tight_layout()
        fig.savefig(os.path.join(figs, "peers_thread_scaling.png"), dpi=110)
        plt.close(fig)
        md.append("")


def peers_knn(res, figs, md):
    rows = [r for r in peers_read(res, "knn.csv") if r["threads"] == "1"]
    if not rows:
        return
    sets = [d for _, d in peers_by_size(rows)]
    methods = sorted({r["method"] for r in rows}, key=lambda m: (not m.startswith("walk-"), m))
    cols = []
    for r in rows:
        c = (r["query"], r["kind"], int(r["k"]))
        if c not in cols:
            cols.append(c)
    label = lambda c: f"{c[0]} {'k=' + str(c[2]) if c[1] == 'knn' else 'radius'}"
    ns = {(r["dataset"], r["method"], r["query"], r["kind"], int(r["k"])): float(r["cpu_ns_per_query"]) for r in rows}
    differ = sum(int(r["differ"]) for r in rows)
    md.append(f"### kNN and radius, one thread (CPU ns/query; answers differing from the reference: {differ})\n")
    body = []
    for d in sets:
        for m in methods:
            if not any((d, m) + c in ns for c in cols):
                continue
            cells = []
            for c in cols:
                v = ns.get((d, m) + c)
                peers = [ns[(d, p) + c] for p in methods if not p.startswith("walk-") and (d, p) + c in ns]
                cells.append("–" if v is None else (f"{v:.0f} ({min(peers) / v:.2f}×)" if peers else f"{v:.0f}"))
            body.append([d, m] + cells)
    md.append(table(["data set", "method"] + [label(c) for c in cols], body))
    md.append("\n(in brackets: the fastest peer's time over this method's; > 1 means faster than every peer)\n")
    fig, axes = plt.subplots(1, len(sets), figsize=(4 * len(sets), 3.8), squeeze=False)
    for ax, d in zip(axes[0], sets):
        for m in methods:
            pts = sorted((c[2], ns[(d, m) + c]) for c in cols if c[0] == "self" and c[1] == "knn" and (d, m) + c in ns)
            if pts:
                ax.plot(*zip(*pts), label=m, **peers_style(m))
        ax.set_title(d)
        ax.set_xlabel("k (self-queries)")
        ax.set_yscale("log")
    axes[0][0].set_ylabel("ns per query (CPU, one thread)")
    axes[0][0].legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "peers_knn_vs_k.png"), dpi=110)
    plt.close(fig)


def peers_icp(res, figs, md):
    rows = peers_read(res, "icp.csv")
    if not rows:
        return
    sets = [d for _, d in peers_by_size(rows)]
    md.append("### ICP align(), point-to-point, one thread (CPU ms)\n")
    body = []
    for d in sets:
        rs = [r for r in rows if r["dataset"] == d]
        trees = [r for r in rs if r["version"] != "own registration" and not r["method"].startswith("walk-")]
        best_s2s = min((float(r["scan2scan_cpu_seconds"]) for r in trees), default=None)
        best_s2m = min((float(r["scan2model_cpu_seconds"]) for r in trees), default=None)
        for r in rs:
            own = r["version"] == "own registration"
            s2s, s2m = float(r["scan2scan_cpu_seconds"]), float(r["scan2model_cpu_seconds"])
            body.append([d, r["method"], r["iterations"] if int(r["iterations"]) >= 0 else "?",
                         f"{s2s * 1e3:.1f}" + ("" if own or not best_s2s else f" ({best_s2s / s2s:.2f}×)"),
                         "–" if own else f"{s2m * 1e3:.1f}" + (f" ({best_s2m / s2m:.2f}×)" if best_s2m else ""),
                         f"{float(r['rot_diff_deg']):.2g}° / {float(r['trans_diff']):.2g}"])
    md.append(table(["data set", "method", "iterations", "scan-to-scan (build inside)", "scan-to-model (build excluded)",
                     "pose vs the walk's (° / m)"], body))
    md.append("\n(own registrations: small_gicp's ICP/GICP and stock PCL ICP time their whole call; in brackets: "
              "the fastest peer tree's time over this method's in the same ICP loop)\n")
    fig, axes = plt.subplots(1, len(sets), figsize=(4.5 * len(sets), 4), squeeze=False)
    for ax, d in zip(axes[0], sets):
        rs = [r for r in rows if r["dataset"] == d and r["version"] != "own registration"]
        names = [r["method"] for r in rs]
        build = [float(r["build_cpu_seconds"]) * 1e3 for r in rs]
        nn = [float(r["nn_seconds"]) * 1e3 for r in rs]
        rest = [float(r["solve_seconds"]) * 1e3 for r in rs]
        x = range(len(rs))
        ax.bar(x, build, label="build", color="C7")
        ax.bar(x, nn, bottom=build, label="NN", color="C3")
        ax.bar(x, rest, bottom=[a + b for a, b in zip(build, nn)], label="SVD + transform", color="C0")
        ax.set_xticks(list(x))
        ax.set_xticklabels(names, rotation=60, ha="right", fontsize=6)
        ax.set_title(d)
    axes[0][0].set_ylabel("CPU ms per align()")
    axes[0][0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "peers_icp_breakdown.png"), dpi=110)
    plt.close(fig)


def peers_build(res, figs, md):
    rows = peers_read(res, "build.csv")
    if not rows:
        return
    sets = peers_by_size(rows)
    methods = sorted({r["method"] for r in rows}, key=lambda m: (not m.startswith("walk-"), m))
    by = {(r["dataset"], r["method"]): r for r in rows}
    md.append("### Build time (CPU, one thread) and peak memory (bytes per point)\n")
    body = []
    for n, d in sets:
        cells = []
        for m in methods:
            r = by.get((d, m))
            if not r:
                cells.append("–")
                continue
            peak = int(r["peak_bytes"])
            cells.append(fmt_time(float(r["cpu_seconds"])) + (f" / {peak / n:.0f} B" if peak >= 0 else ""))
        body.append([f"{d} ({n:,})"] + cells)
    md.append(table(["data set"] + methods, body))
    md.append("")
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    for m in methods:
        pts = [(n, float(by[(d, m)]["cpu_seconds"])) for n, d in sets if (d, m) in by]
        if pts:
            ax.plot(*zip(*pts), label=m, **peers_style(m))
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("points")
    ax.set_ylabel("build CPU seconds (one thread)")
    ax.set_title("Build time against n")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "peers_build_vs_n.png"), dpi=110)
    plt.close(fig)


def peers_pipelines(res, figs, md):
    """dw_pcl_pipelines' pipelines.csv: PCL's algorithms per search, build included and excluded."""
    rows = peers_read(res, "pipelines.csv")
    if not rows:
        return
    searches = []
    for r in rows:
        if r["search"] not in searches and r["search"] != "pcl-gicp-stock":
            searches.append(r["search"])
    cases = []
    for r in rows:
        c = (r["dataset"], r["points"], r["algorithm"], r["threads"])
        if c not in cases:
            cases.append(c)
    t = {(r["dataset"], r["algorithm"], r["threads"], r["search"]): r for r in rows}
    names = {"normals": "NormalEstimationOMP", "clusters": "EuclideanClusterExtraction", "gicp-cov": "GICP covariances"}
    md.append("### PCL pipelines, one process (ms incl. / excl. build; X / walk: X's time over the walk's)\n")
    body = []
    for d, n, a, th in cases:
        walk = t.get((d, a, th, "delaunay-walk"))
        cells = []
        for s in searches:
            r = t.get((d, a, th, s))
            cells.append("–" if r is None else f"{1e3 * float(r['seconds_incl_build']):.1f} / "
                                                f"{1e3 * float(r['seconds_excl_build']):.1f}")
        ratios = []
        for s in searches[:-1]:
            r = t.get((d, a, th, s))
            if r is None or walk is None:
                ratios.append("–")
                continue
            inc = float(r["seconds_incl_build"]) / float(walk["seconds_incl_build"])
            exc = float(r["seconds_excl_build"]) / max(1e-12, float(walk["seconds_excl_build"]))
            ratios.append(f"{inc:.2f}× / {exc:.2f}×")
        body.append([f"{d} ({n})", names.get(a, a), th] + cells + ratios)
    md.append(table(["data set", "algorithm", "threads"] + [f"{s} incl. / excl." for s in searches] +
                    [f"{s} / walk" for s in searches[:-1]], body))
    md.append("")
    one = [c for c in cases if c[3] == "1"]
    if not one:
        return
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharey=True)
    for ax, key, title in zip(axes, ("seconds_incl_build", "seconds_excl_build"), ("build included", "build excluded")):
        w = 0.8 / len(searches)
        for i, s in enumerate(searches):
            ys = [1e3 * float(t[(d, a, th, s)][key]) if (d, a, th, s) in t else 0 for d, _, a, th in one]
            ax.bar([j + i * w for j in range(len(one))], ys, w, label=s)
        ax.set_xticks([j + 0.4 - w / 2 for j in range(len(one))])
        ax.set_xticklabels([f"{d}\n{names.get(a, a)}" for d, _, a, _ in one], fontsize=6, rotation=30, ha="right")
        ax.set_title(title + " (one thread, CPU)")
    axes[0].set_ylabel("ms")
    axes[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(os.path.join(figs, "peers_pipelines.png"), dpi=110)
    plt.close(fig)


def peers_main(res, figs):
    md = []
    meta = peers_read(res, "meta.csv")
    cpu = next((r["value"] for r in meta if r["key"] == "cpu"), "?")
    hw = next((r["value"] for r in meta if r["key"] == "hardware_threads"), "?")
    peers = sorted({r["value"] for r in meta if r["key"] == "peer"})
    md.append(f"Machine: {cpu}, {hw} hardware threads; peers: {', '.join(peers)}.\n")
    for f in (peers_nn, peers_knn, peers_icp, peers_build, peers_pipelines):
        f(res, figs, md)
    with open(os.path.join(res, "tables.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    print("\n".join(md))
    print(f"figures in {figs}, tables in {os.path.join(res, 'tables.md')}", file=sys.stderr)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results", nargs="?")
    ap.add_argument("--figures", default="docs/figures")
    ap.add_argument("--peers", metavar="PEERS_DIR", help="dw_peers' CSV folder (bench/dw_peers.cpp)")
    a = ap.parse_args()
    if a.peers:
        if not os.path.isdir(a.peers):
            sys.exit(f"plot_benchmarks.py: no dw_peers results folder '{a.peers}'")
        os.makedirs(a.figures, exist_ok=True)
        return peers_main(a.peers, a.figures)
    if not a.results or not os.path.isdir(a.results):
        sys.exit(f"plot_benchmarks.py: no results folder '{a.results}'")
    os.makedirs(a.figures, exist_ok=True)
    md = []
    meta = {r["key"]: r["value"] for r in read_one(os.path.join(a.results, "meta.csv"))}
    machines = sorted(glob.glob(os.path.join(a.results, "**", "machine.txt"), recursive=True))
    machine = machines[-1] if machines else ""
    if not meta and machine:  # tools/device/run_grid.sh: lscpu's record of the machine
        with open(machine) as f:
            info = dict(l.split(":", 1) for l in f if ":" in l)
        md.append(f"Machine: {info.get('Model name', '?').strip()}, {info.get('CPU(s)', '?').strip()} CPUs "
                  f"({info.get('Thread(s) per core', '?').strip()} thread(s) per core); per-job settings in "
                  "each job folder's meta.csv.\n")
    if meta:
        md.append(f"Machine: {meta.get('cpu', '?')}, {meta.get('hardware_threads', '?')} hardware threads; "
                  f"rotations: {meta.get('rotations', '?')}; max iterations {meta.get('max_iterations', '?')}; "
                  f"repeats {meta.get('repeats', '?')} (minimum taken).\n")
    for f in (build_section, nn_section, scaling_section, hist_section, icp_section, accept_section,
              scan2scan_section):
        f(a.results, a.figures, md)
    with open(os.path.join(a.results, "tables.md"), "w") as f:
        f.write("\n".join(md) + "\n")
    print("\n".join(md))
    print(f"figures in {a.figures}, tables in {os.path.join(a.results, 'tables.md')}", file=sys.stderr)


if __name__ == "__main__":
    main()
