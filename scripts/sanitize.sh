#!/bin/sh
# Builds the unit tests with AddressSanitizer + UndefinedBehaviorSanitizer in build-asan/ and runs
# them, leaving out the heavy end-to-end tests (integration/, pipeline/, the demo) that would take
# too long under the sanitizers, and the Python module (an ASan-built extension would need the
# sanitizer runtime preloaded into python3) with the tests that use it (python/, install/). Usage: scripts/sanitize.sh
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build="$root/build-asan"
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFRINGE_SANITIZE=ON \
  -DFRINGE_BUILD_BENCH=OFF -DFRINGE_BUILD_PYTHON=OFF >/dev/null
cmake --build "$build" -j2
ASAN_OPTIONS=detect_leaks=1:abort_on_error=1 UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
  ctest --test-dir "$build" -j2 --output-on-failure -E '^(integration|pipeline|python|install)/'
