#!/bin/bash
# Speed regressions caught before landing (issue 28): the quick forms of bench_phase,
# bench_reconstruction, bench_fusion and bench_pipeline, each headline figure printed beside the
# value recorded in bench/recorded.json (cited by docs/benchmarks.md) and, where the benchmark runs a
# peer in the same process, the same-run ratio to that peer. Fails (exit 1) when a same-run ratio
# falls below half its recorded value: ratios measured side by side, not absolute times, so a
# loaded machine does not fail it. Absolute figures are printed for the reader only.
#
# usage: scripts/bench-check.sh [BUILD_DIR]   (default build; the bench targets must be built)
# Run it through benchlock on a shared machine. Writes the JSON of each run to $BUILD_DIR/bench-check/.
set -euo pipefail

root="$(cd "$(dirname "$0")/.." && pwd)"
build="${1:-$root/build}"
bench="$build/bench"
out="$build/bench-check"
recorded="$root/bench/recorded.json"
mkdir -p "$out"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT

for b in bench_phase bench_reconstruction bench_fusion bench_pipeline; do
  if [[ ! -x "$bench/$b" ]]; then
    echo "bench-check: $bench/$b not built (cmake --build $build --target $b)" >&2
    exit 2
  fi
done

run() {  # name, command...
  local name="$1"
  shift
  local start=$SECONDS
  if ! "$@" >"$out/$name.json.tmp" 2>"$out/$name.log"; then
    echo "bench-check: $name failed (log: $out/$name.log)" >&2
    exit 2
  fi
  mv "$out/$name.json.tmp" "$out/$name.json"
  echo "$name: $((SECONDS - start)) s" >>"$out/seconds.txt"
}

: >"$out/seconds.txt"
start_all=$SECONDS
run phase "$bench/bench_phase" --json --quick --repeats 5
run reconstruction "$bench/bench_reconstruction" --json --view-only --repeats 5
run fusion "$bench/bench_fusion" --json --scale 0.25 --views 4 --registration injected \
  --no-mesh
run pipeline "$bench/bench_pipeline" --json --views 2 --rig-scale 0.5 --work "$work/pipeline"
echo "total: $((SECONDS - start_all)) s" >>"$out/seconds.txt"

echo "load: $(cut -d' ' -f1-3 /proc/loadavg)"
python3 - "$recorded" "$out" <<'EOF'
import json, sys

recorded, out = sys.argv[1], sys.argv[2]
rows = [(c["run"], c["figure"], c.get("value"), c.get("load"), c.get("ratio"), c.get("ratio_value"))
        for c in json.load(open(recorded, encoding="utf-8"))["checks"]]
if not rows:
    sys.exit("bench-check: no checks in " + recorded)


def text(v):
    return "-" if v is None else (f"{v:.4g}" if isinstance(v, (int, float)) else str(v))


failed = []
print(f"{'run':15} {'figure':28} {'now':>10} {'recorded':>18}   {'ratio to peer':28} {'now':>8} {'recorded':>9}")
for run, key, value, load, ratio_key, ratio_recorded in rows:
    data = json.load(open(f"{out}/{run}.json"))
    now = data.get(key)
    rec = text(value) + (f" (load {load})" if load else "")
    line = f"{run:15} {key:28} {text(now):>10} {rec:>18}"
    if ratio_key:
        ratio = data.get(ratio_key)
        if not isinstance(ratio_recorded, (int, float)):  # no value recorded yet: printed only
            verdict = "not recorded"
        else:
            ok = isinstance(ratio, (int, float)) and ratio >= 0.5 * ratio_recorded
            verdict = "ok" if ok else "FAIL (< half)"
            if not ok:
                failed.append(f"{run} {ratio_key} {text(ratio)} < half of {ratio_recorded}")
        line += f"   {ratio_key:28} {text(ratio):>8} {text(ratio_recorded):>9}  {verdict}"
    print(line)
print(open(f"{out}/seconds.txt").read().strip())
if failed:
    print("bench-check: FAILED: " + "; ".join(failed))
    sys.exit(1)
print("bench-check: every same-run ratio is at least half its recorded value")
EOF
