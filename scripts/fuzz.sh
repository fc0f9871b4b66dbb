#!/bin/sh
# Builds the libFuzzer targets (fuzz/) with clang + ASan + UBSan in build-fuzz/ and runs each for
# SECONDS (default 60) from a corpus seeded with fuzz/corpus/<target>/. Crashers are written to
# build-fuzz/fuzz/findings/<target>/; turn each into a regression test.
# Usage: scripts/fuzz.sh [SECONDS]
set -eu
seconds=${1:-60}
root=$(cd "$(dirname "$0")/.." && pwd)
build="$root/build-fuzz"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
  -DCMAKE_CXX_COMPILER=clang++ -DFRINGE_FUZZ=ON -DFRINGE_BUILD_TESTS=OFF \
  -DFRINGE_BUILD_BENCH=OFF >/dev/null
cmake --build "$build" -j2 --target fuzz_ply fuzz_json fuzz_opencv fuzz_image fuzz_names fuzz_mesh fuzz_markers
status=0
for target in ply json opencv image names mesh markers; do
  corpus="$build/fuzz/corpus/$target"
  findings="$build/fuzz/findings/$target"
  mkdir -p "$corpus" "$findings"
  if [ -d "$root/fuzz/corpus/$target" ]; then cp -n "$root/fuzz/corpus/$target"/* "$corpus"/ 2>/dev/null || true; fi
  echo "== fuzz_$target: $seconds s"
  if ! "$build/fuzz/fuzz_$target" -max_total_time="$seconds" -max_len=65536 -rss_limit_mb=2048 \
      -timeout=10 -artifact_prefix="$findings/" -print_final_stats=1 "$corpus" 2>"$build/fuzz/$target.log"; then
    echo "fuzz_$target: FOUND A CRASH (see $findings and $build/fuzz/$target.log)"
    status=1
  fi
  grep -E "stat::number_of_executed_units|stat::peak_rss_mb" "$build/fuzz/$target.log" || true
done
exit $status
