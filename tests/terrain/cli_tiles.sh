#!/usr/bin/env bash
# Every tile format from the CLI, as a user would run it, checked by outside tools: gdalinfo reads
# the GeoTIFF's CRS and the colour JPEG, the glTF Validator accepts the .glb, and bad addresses
# fail with a message.
set -euo pipefail
cli="$1"
scene="$2"
validator="$3"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

for encoding in terrain-rgb terrarium gray16 normals hillshade color; do
  "$cli" tile "$scene" 2 1 1 --encoding "$encoding" -o "$out/$encoding.png" > /dev/null
  [ -s "$out/$encoding.png" ]
done
# Colour imagery as JPEG: three bands of 256² as GDAL reads it.
"$cli" tile "$scene" 2 1 1 -o "$out/color.jpg" > /dev/null
gdalinfo "$out/color.jpg" | grep -q 'Driver: JPEG'
gdalinfo "$out/color.jpg" | grep -q 'Size is 256, 256'
[ "$(gdalinfo "$out/color.jpg" | grep -c '^Band ')" = 3 ]
"$cli" tile "$scene" 14 8500 5900 --scheme webmercator -o "$out/tile.tif" > /dev/null
gdalinfo "$out/tile.tif" | grep -q 'Pseudo-Mercator'
"$cli" tile "$scene" 2 1 1 -o "$out/tile.glb" > /dev/null
"$cli" tile "$scene" 2 1 1 -o "$out/tile.drc" > /dev/null
[ -s "$out/tile.drc" ]
node "$validator" "$out/tile.glb" > /dev/null
"$cli" tile "$scene" 12 4191 3139 --scheme geographic -o "$out/tile.terrain" > /dev/null
gzip -t "$out/tile.terrain"
"$cli" layer-json "$scene" | grep -q '"quantized-mesh-1.0"'

# Bad requests: non-zero exit and a message naming the field.
expect_error() {
  local pattern="$1"
  shift
  if "$cli" "$@" > /dev/null 2> "$out/err"; then
    echo "expected failure: $*" >&2
    exit 1
  fi
  grep -q -- "$pattern" "$out/err" || { echo "no '$pattern' in: $(cat "$out/err")" >&2; exit 1; }
}
expect_error '/x' tile "$scene" 2 4 0 -o "$out/x.png"
expect_error '/y' tile "$scene" 2 0 -1 -o "$out/x.png"
expect_error '/z' tile "$scene" 30 0 0 -o "$out/x.png"
expect_error '/format' tile "$scene" 0 0 0 -o "$out/x.webp"
expect_error '/encoding' tile "$scene" 0 0 0 --encoding rainbow -o "$out/x.png"
expect_error '/scheme' tile "$scene" 0 0 0 -o "$out/x.terrain"
expect_error 'integers' tile "$scene" 0 0 99999999999999999999999 -o "$out/x.png"
echo "all tile formats written and checked"
