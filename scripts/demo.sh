#!/usr/bin/env bash
# The README's main command: set up (install missing packages, build), then run the main job on the
# bundled real data — ICP of the Stanford bunny scans with the Delaunay walk vs stock PCL ICP, and the
# Delaunay graph of the dragon.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
B=${BUILD_DIR:-build}
echo
echo "== ICP: bunny bun045 -> bun000, Delaunay walk vs stock PCL ICP + KdTree"
"$B/apps/dw_icp" data/bun045.ply data/bun000.ply --compare --max-iterations 50
echo
echo "== Delaunay graph of the dragon (23k points)"
"$B/apps/dw_graph" data/dragon_vrip_res3.ply -o "$B/dragon_res3.graph"
