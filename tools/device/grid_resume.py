#!/usr/bin/python3
"""Job lines for bench/run_grid.sh --jobs that finish or renew an earlier grid run.

A grid run stopped at its deadline leaves some (data set, noise, rotation, method) rows missing; a
change to one method (say the walk's inner loop) makes its rows stale while the peers' stay valid. This
reads the earlier run (its jobs.txt and every icp.csv below it) and writes jobs that
  --redo METHODS      run these methods again on every rotation of every data set they were planned for;
  --complete METHODS  run these methods on the rotations where the earlier run has no row for them;
  --nn METHODS        repeat the earlier run's build and per-query (nn) jobs, for these methods only.
Rotations that need the same methods are grouped into jobs of about --job-seconds, sized by the
earlier run's own mean CPU time per registration, and interleaved across data sets (as run_grid.sh
does) so that a deadline trims every data set a little.

Brute force is left out above 11,000 points, as dw_bench does. --datasets limits the ICP jobs to
some data sets. The estimated CPU seconds of all jobs go to stderr.

usage: grid_resume.py PREV_GRID_DIR [--redo a,b] [--complete c,d] [--nn a,b] [--datasets x,y]
                      [--job-seconds 60]
"""
import argparse
import csv
import glob
import os
import shlex
import sys
from collections import defaultdict

STEPS = [-20, -10, 0, 10, 20]
BRUTE_FORCE_MAX = 11000  # dw_bench's kBruteForceMax


def rotation_set(name):
    if name == "grid":
        return [f"r{r}p{p}y{y}" for r in STEPS for p in STEPS for y in STEPS if r or p or y]
    if name == "axes":
        out = []
        for axis in range(3):
            for s in STEPS:
                if s:
                    a = [0, 0, 0]
                    a[axis] = s
                    out.append(f"r{a[0]}p{a[1]}y{a[2]}")
        return out
    if name == "one":
        return ["r10p10y10"]
    sys.exit(f"grid_resume.py: unknown rotation set '{name}'")


def parse_jobs(path):
    """(name, {option: value}) of each job line."""
    jobs = []
    with open(path) as f:
        for line in f:
            words = shlex.split(line)
            if not words or words[0].startswith("#"):
                continue
            opts = {}
            for k in range(1, len(words) - 1, 2):
                opts[words[k].lstrip("-")] = words[k + 1]
            jobs.append((words[0], opts))
    return jobs


def csv_list(s):
    return [x for x in (s or "").split(",") if x]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("prev")
    ap.add_argument("--redo", default="")
    ap.add_argument("--complete", default="")
    ap.add_argument("--nn", default="")
    ap.add_argument("--datasets", default="")
    ap.add_argument("--job-seconds", type=float, default=60.0)
    a = ap.parse_args()
    jobs_txt = os.path.join(a.prev, "jobs.txt")
    if not os.path.exists(jobs_txt):
        sys.exit(f"grid_resume.py: no {jobs_txt}")
    redo, complete, nn = set(csv_list(a.redo)), set(csv_list(a.complete)), set(csv_list(a.nn))
    if redo & complete:
        sys.exit("grid_resume.py: a method cannot be both redone and completed")

    rows = []
    for p in glob.glob(os.path.join(a.prev, "**", "icp.csv"), recursive=True):
        with open(p, newline="") as f:
            rows += list(csv.DictReader(f))
    have = {(r["dataset"], r["noise"], r["rotation"], r["method"]) for r in rows}
    points = {}
    for p in glob.glob(os.path.join(a.prev, "**", "*.csv"), recursive=True):
        with open(p, newline="") as f:
            for r in csv.DictReader(f):
                if "points" in r and "dataset" in r:
                    points[r["dataset"]] = int(r["points"])
    only = set(csv_list(a.datasets))
    cost_sum, cost_n = defaultdict(float), defaultdict(int)
    for r in rows:
        cost_sum[(r["dataset"], r["method"])] += float(r["cpu_seconds"])
        cost_n[(r["dataset"], r["method"])] += 1

    def cost(d, m):
        n = cost_n[(d, m)]
        return cost_sum[(d, m)] / n if n else 1.0

    out = []
    # Build and per-query jobs first, as run_grid.sh orders them.
    for name, o in parse_jobs(jobs_txt):
        sections = o.get("sections", "")
        if nn and sections == "build":
            out.append(f"{name} --sections build --repeats {o.get('repeats', '2')} --datasets {o['datasets']}")
        elif nn and sections == "nn":
            keep = [m for m in csv_list(o.get("methods")) if m in nn]
            if keep:
                out.append(f"{name} --sections nn --threads {o.get('threads', '1')} --repeats "
                           f"{o.get('repeats', '2')} --datasets {o['datasets']} --methods {','.join(keep)}")

    # Planned methods per (data set, noise, rotation set).
    planned = defaultdict(list)
    for name, o in parse_jobs(jobs_txt):
        if o.get("sections") != "icp" or (only and o["datasets"] not in only):
            continue
        key = (o["datasets"], o.get("noise", "0"), o.get("rotations", "grid"))
        for m in csv_list(o.get("methods")):
            if m == "brute-force" and points.get(o["datasets"], 0) > BRUTE_FORCE_MAX:
                continue
            if m not in planned[key]:
                planned[key].append(m)
    per_set = []  # one list of job lines per (data set, noise), to interleave
    estimate = 0.0
    for (d, noise, rset), methods in planned.items():
        groups = defaultdict(list)  # method tuple -> rotations
        for rot in rotation_set(rset):
            need = tuple(m for m in methods if m in redo or (m in complete and (d, noise, rot, m) not in have))
            if need:
                groups[need].append(rot)
        lines = []
        for need, rots in groups.items():
            per_rot = sum(cost(d, m) for m in need)
            estimate += per_rot * len(rots)
            size = max(1, int(a.job_seconds / max(per_rot, 1e-3)))
            for k in range(0, len(rots), size):
                chunk = rots[k:k + size]
                tag = "redo" if any(m in redo for m in need) else "complete"
                lines.append(f"icp-{d.replace(':', '-')}-n{noise}-{tag}-{len(lines)} --sections icp --rotations {rset} "
                             f"--noise {noise} --datasets {d} --methods {','.join(need)} "
                             f"--only-rotations {','.join(chunk)}")
        if lines:
            per_set.append(lines)
    # Largest sets first within each round, then round-robin.
    per_set.sort(key=len, reverse=True)
    for k in range(max((len(l) for l in per_set), default=0)):
        for lines in per_set:
            if k < len(lines):
                out.append(lines[k])
    print("\n".join(out))
    total = sum(1 for l in out if l.startswith("icp-"))
    print(f"grid_resume.py: {len(out)} jobs ({total} ICP), ICP jobs estimated at {estimate:.0f} CPU s",
          file=sys.stderr)


if __name__ == "__main__":
    main()
