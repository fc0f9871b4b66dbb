#!/bin/sh
# Builds and runs tests with AddressSanitizer + UndefinedBehaviorSanitizer in build-asan/.
#
#   scripts/sanitize.sh        every test: the unit tests of every module, the parsers' fuzz
#                              corpora, the end-to-end tests (integration/, pipeline/, hostile/,
#                              capture/: without the exit-time leak check, see below), the
#                              installed package (install/) and the Python module (python/: an
#                              ASan-built extension loaded by an uninstrumented python3, so the
#                              sanitizer runtimes are preloaded into it, and CPython's own
#                              allocations alive at its exit are not reported as leaks).
#   scripts/sanitize.sh --ci   the subset run by the README's test command (so by CI): the modules
#                              that read untrusted bytes (util, io, phase — the scheme manifests —
#                              and scan) with their unit tests, and the replay of every parser's
#                              fuzz corpus and past findings (fuzz/corpus, fuzz/known). Chosen to
#                              keep the whole CI run well under 45 minutes on 2 cores
#                              (docs/benchmarks.md, "Hostile inputs").
set -eu
root=$(cd "$(dirname "$0")/.." && pwd)
build="$root/build-asan"
launcher=""
if command -v ccache >/dev/null 2>&1; then launcher="-DCMAKE_CXX_COMPILER_LAUNCHER=ccache"; fi
python=OFF
[ "${1:-}" = "--ci" ] || python=ON
cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DFRINGE_SANITIZE=ON \
  -DFRINGE_BUILD_BENCH=OFF -DFRINGE_BUILD_PYTHON=$python $launcher >/dev/null
export ASAN_OPTIONS=detect_leaks=1:abort_on_error=1
export UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1
if [ "${1:-}" = "--ci" ]; then
  # fuzz_replay_markers needs the registration library and all below it: left to the full run.
  cmake --build "$build" -j2 --target fringe_util_tests fringe_io_tests fringe_phase_tests \
    fringe_scan_tests fuzz_replay_ply fuzz_replay_json fuzz_replay_opencv fuzz_replay_image \
    fuzz_replay_names fuzz_replay_mesh
  ctest --test-dir "$build" -j2 --output-on-failure \
    -R '^(util|io|phase|scan)/|^fuzz/Replay(ply|json|opencv|image|names|mesh)$'
else
  # Every part runs even when an earlier one fails, so one failure does not hide the others.
  rc=0
  cmake --build "$build" -j2
  ctest --test-dir "$build" -j2 --output-on-failure -E '^(python|capture)/' || rc=1
  # capture/ opens an SDL2 window and X11 displays (Xvfb). Their stack leaks at exit: 1032 bytes
  # allocated in libdbus-1 and 2 x 56 bytes in a library SDL has already unloaded, which LSan
  # cannot name, so no suppression can match them (scripts/sanitize.sh full run, 2026-12-06: the
  # 14 capture tests each passed and then failed on these leaks; no frame of fringe's code was in
  # any of the stacks). These tests keep ASan's memory errors and UBSan, without the exit-time
  # leak check.
  ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 \
    ctest --test-dir "$build" -j2 --output-on-failure -R '^capture/' || rc=1
  cxx=$(sed -n 's/^CMAKE_CXX_COMPILER:[A-Z]*=//p' "$build/CMakeCache.txt")
  LD_PRELOAD="$("$cxx" -print-file-name=libasan.so) $("$cxx" -print-file-name=libubsan.so)" \
    ASAN_OPTIONS=detect_leaks=0:abort_on_error=1 \
    ctest --test-dir "$build" -j2 --output-on-failure -R '^python/' || rc=1
  exit $rc
fi
