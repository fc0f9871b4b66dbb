#!/usr/bin/env bash
# The calibration browser test's fixture: a small simulated stereo calibration (the half-size
# rig's board images, no fringe views) calibrated with its report into OUT.
# Usage: make_calibration_report.sh FRINGE OUT
set -euo pipefail
fringe=$1
out=$2
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
"$fringe" --quiet simulate demo --out "$work/scan" --views 0 --rig-scale 0.5 \
  --calibration-images 8 --supersampling 1 --no-truth-maps
rm -rf "$out"
"$fringe" --quiet calibrate "$work/scan/calibration" --target "$work/scan/calibration/target.json" \
  --out "$work/rig.json" --report "$out" >/dev/null
test -s "$out/report.html"
echo "make_calibration_report: $out/report.html ($(stat -c %s "$out/report.html") bytes)"
