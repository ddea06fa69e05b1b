#!/usr/bin/env bash
# Offline export rate (tiles/s) of `terrain export` and `planet export` with --threads 1 and 2,
# beside the server's uncached rate for the same tiles: a fresh terrain-server per run with the
# tile cache off (--cache-bytes 0) and --generation-threads N, asked for every tile once over
# N keep-alive connections. Both make the same bytes with the same code (ProductMaker /
# PlanetTiles); the difference is the HTTP path against the pack writer.
# Usage: bench/export_bench.sh [BUILD_DIR]   (default build/release; build/dev works too)
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
terrain="$build/tools/terrain"
planet="$build/tools/planet"
server="$build/server/terrain-server"
for binary in "$terrain" "$planet" "$server"; do
  [ -x "$binary" ] || { echo "missing $binary: build terrain_cli planet_cli terrain_server" >&2; exit 1; }
done
scene=config/scenes/mountain-range.json
scene_zooms=13-15
planet_zooms=0-3
work="$(mktemp -d)"
cleanup() {
  [ -n "${server_pid:-}" ] && kill "$server_pid" 2> /dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

field() { node -e "const j = JSON.parse(require('fs').readFileSync(0, 'utf8')); console.log($1)"; }

# URLs of a pack's tiles, from the export summary's ranges.
urls() {  # SUMMARY BASE EXTENSION
  field "j.ranges.flatMap(([z, x0, y0, x1, y1]) => { const out = [];
    for (let y = y0; y <= y1; ++y) for (let x = x0; x <= x1; ++x) out.push('$2/' + z + '/' + x + '/' + y + '.$3');
    return out; }).join('\n')" < "$1"
}

# Tiles per second of a fresh server with no cache asking every URL once over N connections.
server_rate() {  # URL-FILE THREADS PATH-PREFIX
  local list="$1" threads="$2"
  "$server" --config /dev/null --port 0 --data-dir "$work/data-$threads-$RANDOM" \
    --cache-bytes 0 --generation-threads "$threads" --io-threads "$threads" --log-level warn \
    > "$work/server.out" 2> "$work/server.err" &
  server_pid=$!
  for _ in $(seq 300); do grep -q listening "$work/server.out" 2> /dev/null && break; sleep 0.1; done
  local port
  port="$(sed -n 's/.*:\([0-9]*\) .*/\1/p' "$work/server.out" | head -1)"
  sed "s#^#http://127.0.0.1:$port$3#" "$list" > "$work/full-urls"
  # Warm-up: the scene or planet is loaded (and a planet built) by its first request.
  curl -sf -o /dev/null "$(head -1 "$work/full-urls")"
  tail -n +2 "$work/full-urls" > "$work/timed-urls"
  local count start end
  count="$(wc -l < "$work/timed-urls")"
  split -n "r/$threads" "$work/timed-urls" "$work/part-"
  start="$(date +%s.%N)"
  local clients=()
  for part in "$work"/part-*; do
    xargs -a "$part" -n 64 sh -c 'for u; do printf -- "-o /dev/null\n%s\n" "$u"; done | xargs curl -sf' _ &
    clients+=($!)
  done
  wait "${clients[@]}"  # not the server, which runs in the background too
  end="$(date +%s.%N)"
  rm -f "$work"/part-*
  kill "$server_pid"
  wait "$server_pid" 2> /dev/null || true
  server_pid=""
  node -e "console.log(($count / ($end - $start)).toFixed(1))"
}

echo "| What | Tiles | --threads 1 (tiles/s) | --threads 2 (tiles/s) |"
echo "|---|---|---|---|"
row() {  # LABEL SUMMARY1 SUMMARY2
  echo "| $1 | $(field 'j.tiles' < "$2") | $(field 'j.tiles_per_second' < "$2") | $(field 'j.tiles_per_second' < "$3") |"
}
for threads in 1 2; do
  "$terrain" export "$scene" -o "$work/scene-$threads.pmtiles" --zoom "$scene_zooms" \
    --threads "$threads" > "$work/scene-$threads.json"
  "$planet" export -o "$work/planet-$threads.pmtiles" --zoom "$planet_zooms" \
    --threads "$threads" > "$work/planet-$threads.json"
done
cmp -s "$work/scene-1.pmtiles" "$work/scene-2.pmtiles" || echo "scene packs differ by thread count!" >&2
row "terrain export, mountain-range z$scene_zooms, terrain-RGB PMTiles" "$work/scene-1.json" "$work/scene-2.json"
row "planet export, default z$planet_zooms, terrain-RGB PMTiles" "$work/planet-1.json" "$work/planet-2.json"

urls "$work/scene-1.json" "" png > "$work/scene-urls"
urls "$work/planet-1.json" "" png > "$work/planet-urls"
s1="$(server_rate "$work/scene-urls" 1 /api/v1/scenes/mountain-range/tiles)"
s2="$(server_rate "$work/scene-urls" 2 /api/v1/scenes/mountain-range/tiles)"
p1="$(server_rate "$work/planet-urls" 1 /api/v1/planets/default/tiles)"
p2="$(server_rate "$work/planet-urls" 2 /api/v1/planets/default/tiles)"
echo "| terrain-server uncached, the same scene tiles (less the warm-up one) | $(wc -l < "$work/scene-urls") | $s1 | $s2 |"
echo "| terrain-server uncached, the same planet tiles (less the warm-up one) | $(wc -l < "$work/planet-urls") | $p1 | $p2 |"
