#!/usr/bin/env bash
# Issue 20 item 5, "a 256² planet tile no slower than a scene tile of the same size on one core":
# planet_bench's planet tiles and every example scene's tile in the same process, pinned to one
# core, ROUNDS times over; each benchmark's fastest round is kept, because this class of VM drifts
# by up to a third between runs and the fastest round is the one least disturbed. Prints each
# planet figure as a multiple of the median scene tile's.
# Usage: bench/planet_speed.sh [BUILD_DIR]   (default build/release; ROUNDS=3, CORE=0)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
bench="$build/bench/planet_bench"
[ -x "$bench" ] || { echo "missing $bench: build planet_bench" >&2; exit 1; }
rounds="${ROUNDS:-3}"
core="${CORE:-0}"
filter='BM_PlanetBaseMesh|BM_PlanetTile/|BM_PlanetTileRefined/|BM_PlanetTilePanning/|BM_PlanetTileDisplacement|BM_SceneTile/'
runs="$(mktemp)"
trap 'rm -f "$runs"' EXIT
for round in $(seq "$rounds"); do
  echo "round $round of $rounds" >&2
  # CSV rows: "name",iterations,real_time,cpu_time,time_unit,... (milliseconds here)
  taskset -c "$core" "$bench" --benchmark_filter="$filter" --benchmark_format=csv 2> /dev/null |
    grep '^"BM_' >> "$runs"
done
python3 - "$runs" "$rounds" <<'EOF'
import csv, statistics, sys
fastest = {}
for row in csv.reader(open(sys.argv[1])):
    name, real, unit = row[0], float(row[2]), row[4]
    assert unit == "ms", f"{name}: unit {unit}"
    fastest[name] = min(real, fastest.get(name, real))
scenes = {n: t for n, t in fastest.items() if n.startswith("BM_SceneTile/")}
if not scenes:
    sys.exit("no scene tile was measured")
median = statistics.median(scenes.values())
print(f"fastest of {sys.argv[2]} rounds, ms; x: times the median scene tile ({median:.1f} ms)")
print(f"scene tiles: {min(scenes.values()):.1f}-{max(scenes.values()):.1f}")
for name in sorted(scenes, key=scenes.get):
    print(f"  {name[len('BM_SceneTile/'):]:<16} {scenes[name]:6.1f}")
for name, t in sorted(fastest.items()):
    if name.startswith("BM_SceneTile/"):
        continue
    ratio = "" if name == "BM_PlanetBaseMesh" else f"  x{t / median:.2f}"
    print(f"{name[3:]:<34} {t:6.1f}{ratio}")
EOF
