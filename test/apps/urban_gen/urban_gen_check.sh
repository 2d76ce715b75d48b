#!/bin/sh
# dw_urban_gen end to end: the same seed gives byte-identical files (for any thread count), another
# seed other files; every file is where info.txt says; bad arguments are usage errors (exit 2) and
# an unwritable output is an error (exit 1) that leaves an existing map in place.
# usage: urban_gen_check.sh DW_URBAN_GEN WORK_DIR
set -u
app=$1
work=$2
fail() { echo "FAIL: $*"; exit 1; }
rm -rf "$work"
mkdir -p "$work"
small="--scans 3 --map-points 20k --blocks 2 --beams 8 --azimuth-steps 256"
"$app" --out "$work/a" --seed 5 $small --threads 1 || fail "generation a"
"$app" --out "$work/b" --seed 5 $small --threads 2 || fail "generation b"
"$app" --out "$work/c" --seed 6 $small --threads 2 || fail "generation c"
for f in map.ply poses.txt scans/000000.bin scans/000001.bin scans/000002.bin; do
  [ -s "$work/a/$f" ] || fail "$f missing or empty"
  cmp -s "$work/a/$f" "$work/b/$f" || fail "$f differs between two runs of seed 5"
done
[ -e "$work/a/scans/000003.bin" ] && fail "a fourth scan for --scans 3"
cmp -s "$work/a/map.ply" "$work/c/map.ply" && fail "seeds 5 and 6 gave the same map"
cmp -s "$work/a/scans/000001.bin" "$work/c/scans/000001.bin" && fail "seeds 5 and 6 gave the same scan"
[ "$(wc -l < "$work/a/poses.txt")" -eq 3 ] || fail "poses.txt does not have 3 lines"
[ "$(awk '{ print NF }' "$work/a/poses.txt" | sort -u)" = "12" ] || fail "poses.txt lines without 12 numbers"
grep -q "3 scans" "$work/a/info.txt" || fail "info.txt does not describe the scans"
grep -q "^element vertex 20000$" "$work/a/map.ply" || fail "map.ply does not hold 20000 points"
ls "$work"/a/*.tmp-* "$work"/a/scans/*.tmp-* 2>/dev/null && fail "temporary files left behind"

"$app" --out "$work/d" --seed 5 --scans 0 --map-points 5k --map-format las --blocks 2 || fail "a LAS map"
[ -s "$work/d/map.las" ] || fail "map.las missing"
[ -e "$work/d/poses.txt" ] && fail "poses for --scans 0"

expect() {  # expect RC TEXT ARGS...: exit code RC and TEXT on stderr
  rc=$1; text=$2; shift 2
  "$app" "$@" > "$work/out.txt" 2> "$work/err.txt"
  got=$?
  [ "$got" -eq "$rc" ] || fail "'$*' exited $got, expected $rc: $(cat "$work/err.txt")"
  grep -q -- "$text" "$work/err.txt" || fail "'$*' did not say '$text': $(cat "$work/err.txt")"
}
expect 2 "no output folder" --scans 3
expect 2 "unknown option" --out "$work/e" --frobnicate
expect 2 "bad --scans" --out "$work/e" --scans -4
expect 2 "bad --map-points" --out "$work/e" --map-points lots
expect 2 "--map-format must be" --out "$work/e" --map-format xyz
expect 2 "nothing to generate" --out "$work/e" --scans 0 --map-points 0
expect 2 "LidarModel" --out "$work/e" --max-range 0.1
# A file where the folder should be: a clear error, and the file is untouched.
echo keep > "$work/file"
expect 1 "cannot create the folder" --out "$work/file" $small
[ "$(cat "$work/file")" = "keep" ] || fail "the file in the way was changed"
# A run that fails (scans/ is a file) leaves the existing map alone.
mkdir -p "$work/f" && cp "$work/a/map.ply" "$work/f/map.ply" && echo x > "$work/f/scans"
expect 1 "cannot create the folder" --out "$work/f" --seed 6 --scans 2 --map-points 0 --blocks 2
cmp -s "$work/a/map.ply" "$work/f/map.ply" || fail "the existing map was changed by a failed run"
echo "dw_urban_gen checks passed"
