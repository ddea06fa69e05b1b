#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, the fuzz preset) and runs each for a bounded time, starting
# from seed corpora (the example scenes; a few request targets). Usage: scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
cmake --preset fuzz > /dev/null
cmake --build --preset fuzz --target scene_json_fuzz request_router_fuzz -j "$(nproc)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/scenes" "$work/requests"
cp config/scenes/*.json "$work/scenes/"
i=0
for target in 'scenes' 'scenes/hills-river' 'scenes/craters@1/tiles/3/1/2.png?encoding=terrarium' \
              'scenes/lake-dunes/mesh/2/1/1.terrain?scheme=geographic' 'scenes/butte/sample?x=1&y=2' \
              'scenes/mountain-range/render.png?width=64&eye=1,2,3' 'openapi.json'; do
  printf 'A%s\n"etag"\n{"format":"terrain-scene/1"}' "$target" > "$work/requests/seed$i"
  i=$((i + 1))
done
build/fuzz/fuzz/scene_json_fuzz -max_total_time="$seconds" -max_len=16384 -timeout=10 \
  -print_final_stats=1 "$work/scenes" 2>&1 | tail -4
build/fuzz/fuzz/request_router_fuzz -max_total_time="$seconds" -max_len=4096 -timeout=10 \
  -print_final_stats=1 "$work/requests" 2>&1 | tail -4
echo "fuzzing: no crash in ${seconds}s per target"
