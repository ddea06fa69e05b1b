#!/usr/bin/env bash
# The six squares of bench/planet_realism.sh through ./floors at ZOOMS (default "8 11 14"); the
# EXP_* knobs pass through the environment. Run from the repository root:
#   docs/experiments/drain-floors/squares.sh /tmp/floors
set -euo pipefail
floors="${1:?usage: squares.sh FLOORS_BINARY}"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
for s in 7 42; do
  python3 -c "import json,sys; d=json.load(open('config/planets/default.json')); d['seed']=int(sys.argv[1]); print(json.dumps(d))" "$s" > "$work/seed-$s.json"
done
entries=("default config/planets/default.json 5 -175" "seed-7 $work/seed-7.json 5 -165"
  "seed-42 $work/seed-42.json 5 -175" "plateau config/planets/default.json -35 110"
  "escarpment config/planets/default.json -32 105" "coastal config/planets/default.json -35 98.6")
for zoom in ${ZOOMS:-8 11 14}; do
  for e in "${entries[@]}"; do
    read -r name def lat lon <<< "$e"
    ( "$floors" "$def" "$lat" "$lon" "$zoom" > "$work/$name-$zoom.txt" ) &
  done
  wait
  for e in "${entries[@]}"; do
    read -r name _ <<< "$e"
    printf '%-11s ' "$name"
    cat "$work/$name-$zoom.txt"
  done
done
