#!/usr/bin/env bash
# Geomorphometry of planets (issue 20's targets: pits ≤ 0.1 % of land cells, closed depressions
# ≤ 2 % of land outside lakes, Flint's law 0.3 ≤ θ ≤ 0.8 with r² ≥ 0.3): `planet analyze` over
# 512² samples around a land point at the ground spacing of zooms 8, 11 and 14, on the default
# planet and on the same definition with two other seeds. Definitions: docs/analysis.md.
# Then the land's hypsometry of the three planets, and a survey of land squares over each.
# Usage: bench/planet_realism.sh [BUILD_DIR]   (default build/release)
# RELIEF_MODEL=displacement measures the same planets with that relief model (planet.md "Relief
# models"); the default is each definition's own (drainage since generation 16).
set -euo pipefail
cd "$(dirname "$0")/.."
build="${1:-build/release}"
planet="$build/tools/planet"
[ -x "$planet" ] || { echo "missing $planet: build planet_cli" >&2; exit 1; }
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
# A definition and a land point of each planet: the first point of a fixed scan (latitudes 5, 15,
# 25, 35, −5, −15, −25; longitudes −175 to 175 in steps of 10) where `planet sample` reports land
# there and 0.1° north, south, east and west of it (generation 9 planets; seed 42's again at
# generation 19, whose sea beside the cone points regrew its continents).
model="${RELIEF_MODEL:-}"
seeded() {
  python3 -c "import json,sys; d=json.load(open('config/planets/default.json')); d['seed']=int(sys.argv[1])
if sys.argv[2]: d['relief_model']=sys.argv[2]
print(json.dumps(d))" "$1" "$model" > "$work/seed-$1.json"
  echo "$work/seed-$1.json"
}
default=config/planets/default.json
if [ -n "$model" ]; then
  default="$(seeded 20110627)"
fi
# Then three squares of the default planet's relief regions (generation 13): a plateau's top, its
# escarpment and a coastal plain about 45 km from the sea.
planets=("default $default 5 -175" "seed-7 $(seeded 7) 5 -165"
  "seed-42 $(seeded 42) 5 -145" "plateau $default -35 110"
  "escarpment $default -32 105" "coastal $default -35 98.6")
# channel_km2: the channel threshold the drop analysis chose (docs/analysis.md), * where no
# candidate kept a constant drop and it is 1% of the square.
printf '%-12s %4s %8s %8s %8s %7s %6s %8s %6s %6s %12s %8s\n' planet zoom cell_m pits_% closed_% theta r2 theta_in r2_in R_b channel_km2 seconds
for entry in "${planets[@]}"; do
  read -r name definition lat lon <<< "$entry"
  for zoom in 8 11 14; do
    start=$(date +%s.%N)
    "$planet" analyze "$definition" "$lat" "$lon" --zoom "$zoom" > "$work/out.json"
    seconds=$(echo "$(date +%s.%N) - $start" | bc)
    python3 - "$work/out.json" "$name" "$zoom" "$seconds" << 'PY'
import json, sys
d = json.load(open(sys.argv[1]))
f = d["flint"] or {}
inside = d["flint_inside"] or {}
def fmt(v, spec):
    return format(v, spec) if isinstance(v, (int, float)) else "-"
rb = d["strahler"]["bifurcation_ratio"]
channels = d["channels"]
threshold = f"{channels['area_threshold_m2'] / 1e6:.4g}"
if channels["threshold_rule"] != "constant drop":
    threshold += "*"
print(f"{sys.argv[2]:<12} {sys.argv[3]:>4} {d['input']['cell_size_m']:8.1f} "
      f"{100 * d['pits']['share']:8.3f} {100 * d['closed_depression_share']:8.2f} "
      f"{fmt(f.get('theta'), '7.3f'):>7} {fmt(f.get('r_squared'), '6.3f'):>6} "
      f"{fmt(inside.get('theta'), '8.3f'):>8} {fmt(inside.get('r_squared'), '6.3f'):>6} {fmt(rb, '6.2f'):>6} "
      f"{threshold:>12} {float(sys.argv[4]):8.2f}")
PY
  done
done
# The land's hypsometry over each whole planet (`planet hypsometry`: 20 000 equal-area points at
# 200 m detail; docs/analysis.md "Hypsometry"). Earth's land averages about 850 m.
echo
printf '%-12s %8s %8s %8s %8s %8s %9s\n' planet mean_m median_m '<500m_%' '<1km_%' '<2km_%' integral
for definition in "$default" "$work/seed-7.json" "$work/seed-42.json"; do
  "$planet" hypsometry "$definition" > "$work/hypsometry.json"
  python3 - "$work/hypsometry.json" "$(basename "$definition" .json)" << 'PY'
import json, sys
d = json.load(open(sys.argv[1]))
e = d["elevation_m"]
below = {b["altitude_m"]: 100 * b["share"] for b in d["land_below"]}
print(f"{sys.argv[2]:<12} {e['mean']:8.0f} {e['median']:8.0f} {below[500]:8.1f} {below[1000]:8.1f} "
      f"{below[2000]:8.1f} {d['hypsometric_integral']:9.3f}")
PY
done
# Land squares over each whole planet (`planet survey`: a 512² square at each land point of a
# 64-point equal-area lattice; docs/analysis.md "Surveys"): how many meet each target and all of
# them, and the medians. The fixed squares above are where the rules were tuned; these are not.
# SURVEY_POINTS=0 skips it (about 25 s a planet and zoom). SURVEY_MARGIN=K drains each square with
# K samples more on every side (`--margin`; docs/analysis.md "A square's edge"), three to six
# times as long at 512.
points="${SURVEY_POINTS:-64}"
margin="${SURVEY_MARGIN:-0}"
if [ "$points" -gt 0 ]; then
  echo
  [ "$margin" -gt 0 ] && echo "surveys drained with a margin of $margin samples"
  printf '%-12s %4s %7s %5s %5s %7s %6s %8s %9s %7s %6s %9s %8s %6s\n' planet zoom squares all \
    pits closed flint 'pits_%' 'closed_%' theta r2 flint_in theta_in r2_in
  for definition in "$default" "$work/seed-7.json" "$work/seed-42.json"; do
    for zoom in 8 11 14; do
      "$planet" survey "$definition" --points "$points" --zoom "$zoom" --margin "$margin" \
        > "$work/survey.json"
      python3 - "$work/survey.json" "$(basename "$definition" .json)" "$zoom" << 'PY'
import json, sys
d = json.load(open(sys.argv[1]))
s, m = d["summary"], d["summary"]["median"]
inside = s["flint_inside"]
def fmt(v, scale, spec):
    return format(scale * v, spec) if isinstance(v, (int, float)) else "-"
print(f"{sys.argv[2]:<12} {sys.argv[3]:>4} {s['squares']:7d} {s['meeting_all']:5d} "
      f"{s['meeting']['pits']:5d} {s['meeting']['closed_depressions']:7d} {s['meeting']['flint']:6d} "
      f"{fmt(m['pit_share'], 100, '8.3f')} {fmt(m['closed_depression_share'], 100, '9.2f')} "
      f"{fmt(m['theta'], 1, '7.3f')} {fmt(m['r_squared'], 1, '6.3f')} {inside['meeting']:9d} "
      f"{fmt(inside['median']['theta'], 1, '8.3f')} {fmt(inside['median']['r_squared'], 1, '6.3f')}")
PY
    done
  done
fi
