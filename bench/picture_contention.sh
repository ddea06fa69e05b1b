#!/usr/bin/env bash
# Pictures against tiles (docs/server.md, Limits): how long uncached tiles take alone, and beside
# N pictures of minutes each rendering on the picture pool (nice 19), then how soon the picture
# threads are free once those clients hang up. Prints a Markdown table.
# Usage: bench/picture_contention.sh [PICTURES]   (PICTURE_BENCH_SERVER names another binary;
# default build/release/server/terrain-server, built when missing)
set -euo pipefail
cd "$(dirname "$0")/.."
pictures="${1:-8}"
scripts/install-deps.sh --tests > /dev/null  # curl
server="${PICTURE_BENCH_SERVER:-build/release/server/terrain-server}"
[ -x "$server" ] || scripts/build.sh release > /dev/null

work="$(mktemp -d)"
picture_pids=()
cleanup() {
  [ "${#picture_pids[@]}" -gt 0 ] && kill "${picture_pids[@]}" 2> /dev/null || true
  [ -n "${server_pid:-}" ] && kill "$server_pid" 2> /dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# Pictures may trace for minutes here, so that they are still rendering while tiles are timed.
"$server" --config /dev/null --port 0 --data-dir "$work/data" --backend cpu --log-level warn \
  --generation-threads 2 --picture-threads 2 --max-picture-cost 1e15 \
  --picture-steps-per-pixel 65536 > "$work/server.out" 2> "$work/server.err" &
server_pid=$!
for _ in $(seq 300); do grep -q listening "$work/server.out" 2> /dev/null && break; sleep 0.1; done
port="$(sed -n 's/.*:\([0-9]*\) .*/\1/p' "$work/server.out" | head -1)"
base="http://127.0.0.1:$port/api/v1/scenes/mountain-range@1"
curl -sf -o /dev/null "$base"  # the version loaded

# Seconds for each of 8 uncached 256² tiles at zoom 3 (row $1 of the 8×8), one after another.
tile_times() {
  for x in 0 1 2 3 4 5 6 7; do
    curl -sf -o /dev/null -w '%{time_total}\n' "$base/tiles/3/$x/$1.png?scheme=local&size=256"
  done
}
stats() {  # median and maximum in milliseconds
  sort -n | awk '{ v[NR] = $1 * 1000 } END { printf "%.1f | %.1f", v[int((NR + 1) / 2)], v[NR] }'
}

alone="$(tile_times 0 | stats)"
for i in $(seq "$pictures"); do
  curl -s -o /dev/null --max-time 120 \
    "$base/render.png?width=1280&height=720&fov=$((30 + i))" &
  picture_pids+=($!)
done
sleep 1
beside="$(tile_times 1 | stats)"
kill "${picture_pids[@]}" 2> /dev/null || true
picture_pids=()
hung_up="$(date +%s.%N)"
for _ in $(seq 200); do
  abandoned="$(curl -sf "http://127.0.0.1:$port/metrics" |
    sed -n 's/^terrain_generation_abandoned_total \([0-9]*\).*/\1/p')"
  [ "${abandoned:-0}" -ge "$pictures" ] && break
  sleep 0.05
done
freed_ms="$(awk -v a="$hung_up" -v b="$(date +%s.%N)" 'BEGIN { printf "%.0f", (b - a) * 1000 }')"

echo "| Uncached 256² tiles (mountain-range, zoom 3) | median ms | max ms |"
echo "|---|---|---|"
echo "| alone | $alone |"
echo "| beside $pictures pictures rendering | $beside |"
echo
echo "$pictures abandoned pictures stopped ${freed_ms} ms after their clients hung up" \
  "(terrain_generation_abandoned_total = ${abandoned:-0})."
