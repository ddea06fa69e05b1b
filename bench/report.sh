#!/usr/bin/env bash
# Builds the release preset, runs the benchmarks on one core and prints a Markdown table of
# throughput per benchmark (the figures docs/performance.md records). Extra arguments go to the
# benchmark binary, e.g. --benchmark_filter=Grid256.
set -euo pipefail
cd "$(dirname "$0")/.."
scripts/build.sh release >/dev/null
json="$(mktemp)"
trap 'rm -f "$json"' EXIT
taskset -c 0 build/release/bench/terrain_bench --benchmark_min_time=0.5 \
  --benchmark_format=json "$@" >"$json"
python3 - "$json" <<'PY'
import json, sys
data = json.load(open(sys.argv[1]))
ctx = data["context"]
print(f"Machine: {ctx.get('num_cpus')} CPUs at {ctx.get('mhz_per_cpu')} MHz, run on one core; {ctx.get('date')}\n")
print("| Benchmark | Time per iteration | Throughput |")
print("|---|---|---|")
for b in data["benchmarks"]:
    rate = b.get("items_per_second") or b.get("evals/s")
    unit = b.get("time_unit", "ns")
    rate_text = f"{rate / 1e6:.2f} M/s" if rate else ""
    print(f"| {b['name']} | {b['real_time']:.1f} {unit} | {rate_text} |")
PY
