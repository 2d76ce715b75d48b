#!/usr/bin/env python3
"""Per-frame plots of a dw_localize / dw_odometry run from its frames CSV.

usage: plot_localization.py FRAMES.csv PREFIX [TITLE]
writes PREFIX_latency.png (latency per frame, with p50/p95/p99 lines) and, when the CSV has errors
against true poses, PREFIX_error.png (translation and rotation error per frame).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def percentile(values, q):
    s = sorted(values)
    if not s:
        return 0.0
    k = max(0, min(len(s) - 1, int(-(-q * len(s) // 1)) - 1))
    return s[k]


def main():
    if len(sys.argv) < 3:
        sys.exit(__doc__)
    path, prefix = sys.argv[1], sys.argv[2]
    title = sys.argv[3] if len(sys.argv) > 3 else "localization"
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    frames = [int(r["frame"]) for r in rows]
    lat = [float(r["latency_ms"]) for r in rows]
    fig, ax = plt.subplots(figsize=(9, 4))
    ax.plot(frames, lat, lw=1, label="latency")
    for q, style in ((0.5, "--"), (0.95, "-."), (0.99, ":")):
        ax.axhline(percentile(lat, q), ls=style, color="gray", lw=1, label=f"p{int(q * 100)} {percentile(lat, q):.2f} ms")
    bad = [(fr, la) for fr, la, r in zip(frames, lat, rows) if r["status"] != "ok"]
    if bad:
        ax.scatter([b[0] for b in bad], [b[1] for b in bad], color="red", s=12, label="status not ok", zorder=3)
    ax.set_xlabel("frame")
    ax.set_ylabel("ms per frame")
    ax.set_title(f"{title}: per-frame latency")
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(prefix + "_latency.png", dpi=110)
    errs = [(int(r["frame"]), float(r["t_error_m"]), float(r["r_error_deg"])) for r in rows if r["t_error_m"]]
    if errs:
        fig, ax = plt.subplots(figsize=(9, 4))
        ax.plot([e[0] for e in errs], [e[1] for e in errs], lw=1, color="tab:blue", label="translation (m)")
        ax.set_xlabel("frame")
        ax.set_ylabel("translation error (m)", color="tab:blue")
        ax2 = ax.twinx()
        ax2.plot([e[0] for e in errs], [e[2] for e in errs], lw=1, color="tab:orange", label="rotation (deg)")
        ax2.set_ylabel("rotation error (deg)", color="tab:orange")
        ax.set_title(f"{title}: error against the true poses")
        fig.tight_layout()
        fig.savefig(prefix + "_error.png", dpi=110)


if __name__ == "__main__":
    main()
