#!/bin/bash
# Speed regressions caught before landing (issue 28): the quick forms of bench_phase,
# bench_reconstruction, bench_fusion and bench_pipeline, each headline figure printed beside the
# value recorded in docs/benchmarks.md ("Regression check" table) and, where the benchmark runs a
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
docs="$root/docs/benchmarks.md"
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
run reconstruction "$bench/bench_reconstruction" --json --quick
run fusion "$bench/bench_fusion" --json --scale 0.25 --views 4 --registration injected \
  --no-mesh
run pipeline "$bench/bench_pipeline" --json --views 2 --rig-scale 0.5 --work "$work/pipeline"
echo "total: $((SECONDS - start_all)) s" >>"$out/seconds.txt"

python3 - "$docs" "$out" <<'EOF'
import json, re, sys

docs, out = sys.argv[1], sys.argv[2]
# The "Regression check" table: | run | figure | recorded | peer ratio | recorded ratio |
rows, in_section = [], False
for line in open(docs, encoding="utf-8"):
    if line.startswith("## "):
        in_section = "Regression check" in line
        continue
    if in_section and line.startswith("| `"):
        cells = [c.strip().strip("`") for c in line.strip().strip("|").split("|")]
        if len(cells) >= 5:
            rows.append(cells[:5])
if not rows:
    sys.exit("bench-check: no 'Regression check' table in " + docs)


def number(text):
    m = re.match(r"[-+0-9.eE]+", text.replace(",", ""))
    return float(m.group(0)) if m else None


failed = []
print(f"{'run':15} {'figure':28} {'now':>10} {'recorded':>10}   {'ratio to peer':32} {'now':>8} {'recorded':>9}")
for run, key, recorded, ratio_key, ratio_recorded in rows:
    data = json.load(open(f"{out}/{run}.json"))
    now = data.get(key)
    now_text = f"{now:.4g}" if isinstance(now, (int, float)) else str(now)
    line = f"{run:15} {key:28} {now_text:>10} {recorded:>10}"
    if ratio_key and ratio_key != "-":
        ratio = data.get(ratio_key)
        floor = number(ratio_recorded)
        ratio_text = f"{ratio:.4g}" if isinstance(ratio, (int, float)) else str(ratio)
        if floor is None:  # no value recorded yet: printed, not checked
            verdict = "not recorded"
        else:
            ok = isinstance(ratio, (int, float)) and ratio >= 0.5 * floor
            verdict = "ok" if ok else "FAIL (< half)"
            if not ok:
                failed.append(f"{run} {ratio_key} {ratio_text} < half of {ratio_recorded}")
        line += f"   {ratio_key:32} {ratio_text:>8} {ratio_recorded:>9}  {verdict}"
    print(line)
print(open(f"{out}/seconds.txt").read().strip())
if failed:
    print("bench-check: FAILED: " + "; ".join(failed))
    sys.exit(1)
print("bench-check: every same-run ratio is at least half its recorded value")
EOF
