#!/usr/bin/env bash
# Builds the libFuzzer targets (clang, the fuzz preset) and runs each for a bounded time, starting
# from seed corpora: the example scenes and planets, a few request targets, the live messages of
# docs/live.md and the small images in fuzz/corpus/. Usage: scripts/fuzz.sh [SECONDS]
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-30}"
fuzzers=(scene_json_fuzz request_router_fuzz live_message_fuzz planet_definition_fuzz
         heightfield_decode_fuzz)
cmake --preset fuzz > /dev/null
cmake --build --preset fuzz --target "${fuzzers[@]}" -j "$(nproc)"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
mkdir -p "$work/scenes" "$work/requests" "$work/live" "$work/planets" "$work/images"
cp config/scenes/*.json "$work/scenes/"
i=0
for target in 'scenes' 'scenes/hills-river' 'scenes/craters@1/tiles/3/1/2.png?encoding=terrarium' \
              'scenes/lake-dunes/mesh/2/1/1.terrain?scheme=geographic' 'scenes/butte/sample?x=1&y=2' \
              'scenes/mountain-range/render.png?width=64&eye=1,2,3' 'openapi.json'; do
  printf 'A%s\n"etag"\n{"format":"terrain-scene/1"}' "$target" > "$work/requests/seed$i"
  i=$((i + 1))
done
# Live messages, one a line (fuzz/live_message_fuzz.cpp); '>' lines come from a second editor.
printf '%s\n' '{"type":"ping"}' > "$work/live/ping"
printf '%s\n' '{"type":"subscribe","since":0,"token":"token","name":"alice"}' '{"type":"ping"}' \
  > "$work/live/subscribe-since"
printf '%s\n' '{"type":"edit","request":"r17","base":1,"ops":[{"op":"replace","path":"/root/children/0/center","value":[100,200]},{"op":"add","path":"/root/children/-","value":{"type":"disc","center":[0,0],"radius":300}},{"op":"remove","path":"/root/children/1"}]}' \
  > "$work/live/edit"
printf '%s\n' '{"type":"edit","base":1,"ops":[{"op":"replace","path":"/root/children/0/elevation","value":250}]}' \
  '>{"type":"edit","base":1,"ops":[{"op":"replace","path":"/root/children/0/elevation","value":10}]}' \
  '>{"type":"edit","base":1,"ops":[{"op":"move","from":"/root/children/2","path":"/root/children/0"},{"op":"test","path":"/seed","value":1}]}' \
  > "$work/live/conflict"
printf '%s\n' '{"type":"edit","base":1,"ops":[{"op":"copy","from":"/root/children/0","path":"/root/children/-"},{"op":"replace","path":"/seed","value":7}]}' \
  '{"type":"edit","base":1,"ops":[]}' '{"type":"dance"}' 'not json' > "$work/live/rebase"
cp config/planets/*.json "$work/planets/"
# Images: a first byte choosing the stored media type (0 image/png, 1 image/tiff), then the bytes.
for image in fuzz/corpus/heightfield/*; do
  case "$image" in *.tif) type='\001' ;; *) type='\000' ;; esac
  { printf "$type"; cat "$image"; } > "$work/images/$(basename "$image")"
done
run() {  # fuzzer, max_len, corpus
  local log="$work/$1.log"
  if ! build/fuzz/fuzz/"$1" -max_total_time="$seconds" -max_len="$2" -timeout=10 \
      -print_final_stats=1 "$3" > "$log" 2>&1; then
    tail -60 "$log"
    echo "fuzzing: $1 failed; the input is in ./crash-*, leak-*, timeout-* or oom-*" >&2
    exit 1
  fi
  echo "$1: $(grep -E 'stat::(number_of_executed_units|new_units_added)' "$log" | tr '\n' ' ')"
}
run scene_json_fuzz 16384 "$work/scenes"
run request_router_fuzz 4096 "$work/requests"
# 16 KiB, like the scenes: room for every kind of message, and too little for the hundreds of
# thousands of nested arrays that overflowed the live handler's stack (fixed apart, in app_live.cpp)
# to dominate the run.
run live_message_fuzz 16384 "$work/live"
run planet_definition_fuzz 4096 "$work/planets"
run heightfield_decode_fuzz 8192 "$work/images"
echo "fuzzing: no crash in ${seconds}s per target"
