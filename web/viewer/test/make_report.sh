#!/usr/bin/env bash
# The browser tests' fixture: a small simulated scan (the demo part, 3 views on the half-size
# rig, no calibration images: the true rig) scanned into OUT with its report.html and mesh.ply.
# Usage: make_report.sh FRINGE OUT
set -euo pipefail
fringe=$1
out=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$fringe" --quiet simulate demo --out "$work/scan" --views 3 --rig-scale 0.5 \
  --calibration-images 0 --supersampling 1 --no-truth-maps --precompensate-gamma 2.2
cp "$work/scan/truth/rig.json" "$work/scan/rig.json"
"$fringe" --quiet scan "$work/scan" --out "$out" --poisson-depth 8 >/dev/null
test -s "$out/report.html"
echo "make_report: $out/report.html ($(stat -c %s "$out/report.html") bytes)"
