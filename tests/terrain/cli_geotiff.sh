#!/usr/bin/env bash
# GeoTIFFs from the CLI as GIS tools read them: gdalinfo's CRS, origin and pixel size for a local
# tile, a Web Mercator tile, a geographic tile and a `terrain grid`, and gdallocationinfo's value
# at a pixel centre against `terrain sample` at the same scene point.
set -euo pipefail
cli="$1"
scene="$2"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

fail() {
  echo "FAIL: $*" >&2
  exit 1
}
# near A B TOLERANCE: |A − B| ≤ TOLERANCE.
near() {
  awk -v a="$1" -v b="$2" -v t="$3" 'BEGIN { d = a - b; if (d < 0) d = -d; exit !(d <= t) }'
}
geotransform() {  # FILE INDEX
  gdalinfo -json "$1" | jq -r ".geoTransform[$2]"
}
wkt() {
  gdalinfo -json "$1" | jq -r '.coordinateSystem.wkt'
}
# The scene plane's CRS: projected, orthographic around the georeference, in metres.
expect_scene_plane_crs() {
  local file="$1" text
  text="$(wkt "$file")"
  grep -q '^PROJCRS\[' <<< "$text" || fail "$file: not a projected CRS: $text"
  grep -q 'Orthographic' <<< "$text" || fail "$file: not orthographic: $text"
  grep -q 'LENGTHUNIT\["metre",1' <<< "$text" || fail "$file: not in metres: $text"
  gdalsrsinfo -o proj4 "$file" | grep -q '+units=m' || fail "$file: PROJ sees no metres"
  local lat lon
  lat="$(jq -r '.georeference.latitude' "$scene")"
  lon="$(jq -r '.georeference.longitude' "$scene")"
  gdalsrsinfo -o proj4 "$file" | grep -q "+lat_0=$lat +lon_0=$lon" ||
    fail "$file: not centred on the georeference $lat, $lon"
}
# expect_value FILE X Y LOD: the raster at scene point (X, Y) is `terrain sample` there.
expect_value() {
  local file="$1" x="$2" y="$3" lod="$4" raster sampled
  raster="$(gdallocationinfo -valonly -geoloc "$file" "$x" "$y")"
  sampled="$("$cli" sample "$scene" "$x" "$y" --lod "$lod" | jq -r '.elevation')"
  near "$raster" "$sampled" 0.01 || fail "$file at ($x, $y): raster $raster, terrain sample $sampled"
}

# Local tile 1/0/1: cell centres, 256² pixels over the north-west... quarter of the scene square.
"$cli" tile "$scene" 1 0 1 -o "$out/local.tif" > /dev/null
expect_scene_plane_crs "$out/local.tif"
gdalinfo -json "$out/local.tif" | jq -e '.metadata[""].AREA_OR_POINT == "Area"' > /dev/null ||
  fail "local tile: not pixel-is-area"
x0="$(geotransform "$out/local.tif" 0)"
y0="$(geotransform "$out/local.tif" 3)"
step="$(geotransform "$out/local.tif" 1)"
near "$(geotransform "$out/local.tif" 5)" "-$step" 1e-12 || fail "local tile: pixels not square"
# Zoom 1 halves the zoom-0 tile, which spans the scene square: the same origin, half the pixel.
"$cli" tile "$scene" 0 0 0 -o "$out/local0.tif" > /dev/null
near "$(geotransform "$out/local0.tif" 1)" "$(awk -v s="$step" 'BEGIN { print 2 * s }')" 1e-9 ||
  fail "local tiles: zoom 0 pixel is not twice zoom 1's"
near "$(geotransform "$out/local0.tif" 0)" "$x0" 1e-9 || fail "local tiles: west edges differ"
# Pixel (100, 50)'s centre in scene metres.
x="$(awk -v o="$x0" -v s="$step" 'BEGIN { printf "%.10f", o + 100.5 * s }')"
y="$(awk -v o="$y0" -v s="$step" 'BEGIN { printf "%.10f", o - 50.5 * s }')"
expect_value "$out/local.tif" "$x" "$y" "$step"

# terrain grid: samples at origin + i·step (pixel-is-point), row 0 north; the CLI reports both.
"$cli" grid "$scene" -o "$out/grid.tif" --size 129 > "$out/grid.json"
expect_scene_plane_crs "$out/grid.tif"
gdalinfo -json "$out/grid.tif" | jq -e '.metadata[""].AREA_OR_POINT == "Point"' > /dev/null ||
  fail "grid: not pixel-is-point"
gx="$(jq -r '.origin[0]' "$out/grid.json")"
gy="$(jq -r '.origin[1]' "$out/grid.json")"
gstep="$(jq -r '.step' "$out/grid.json")"
# GDAL's geotransform starts at the outer corner of pixel (0, 0), half a step out.
near "$(geotransform "$out/grid.tif" 0)" "$(awk -v o="$gx" -v s="$gstep" 'BEGIN { printf "%.10f", o - s / 2 }')" 1e-6 ||
  fail "grid: west edge $(geotransform "$out/grid.tif" 0), origin $gx"
near "$(geotransform "$out/grid.tif" 3)" "$(awk -v o="$gy" -v s="$gstep" 'BEGIN { printf "%.10f", o + 128.5 * s }')" 1e-6 ||
  fail "grid: north edge $(geotransform "$out/grid.tif" 3), origin $gy"
near "$(geotransform "$out/grid.tif" 1)" "$gstep" 1e-9 || fail "grid: pixel width"
near "$(geotransform "$out/grid.tif" 5)" "-$gstep" 1e-9 || fail "grid: pixel height"
# Sample (40, 30): 40 steps east of the origin, 128 − 30 north.
x="$(awk -v o="$gx" -v s="$gstep" 'BEGIN { printf "%.10f", o + 40 * s }')"
y="$(awk -v o="$gy" -v s="$gstep" 'BEGIN { printf "%.10f", o + 98 * s }')"
expect_value "$out/grid.tif" "$x" "$y" "$gstep"

# Web Mercator tile 14/8500/5900: EPSG:3857, origin and pixel from the address.
"$cli" tile "$scene" 14 8500 5900 --scheme webmercator -o "$out/web.tif" > /dev/null
gdalinfo -json "$out/web.tif" | jq -e '.stac["proj:epsg"] == 3857' > /dev/null ||
  wkt "$out/web.tif" | grep -q 'ID\["EPSG",3857\]' || fail "web: not EPSG:3857"
half=20037508.342789244
near "$(geotransform "$out/web.tif" 0)" "$(awk -v h="$half" 'BEGIN { printf "%.6f", -h + 8500 * 2 * h / 16384 }')" 1e-3 ||
  fail "web: west edge"
near "$(geotransform "$out/web.tif" 3)" "$(awk -v h="$half" 'BEGIN { printf "%.6f", h - 5900 * 2 * h / 16384 }')" 1e-3 ||
  fail "web: north edge"
near "$(geotransform "$out/web.tif" 1)" "$(awk -v h="$half" 'BEGIN { printf "%.9f", 2 * h / 16384 / 256 }')" 1e-6 ||
  fail "web: pixel size"

# Geographic tile 12/4191/3139 (TMS, y north): EPSG:4326, origin and pixel in degrees.
"$cli" tile "$scene" 12 4191 3139 --scheme geographic -o "$out/geo.tif" > /dev/null
wkt "$out/geo.tif" | grep -q 'ID\["EPSG",4326\]' || fail "geographic: not EPSG:4326"
near "$(geotransform "$out/geo.tif" 0)" "$(awk 'BEGIN { printf "%.12f", -180 + 4191 * 180 / 4096 }')" 1e-9 ||
  fail "geographic: west edge"
near "$(geotransform "$out/geo.tif" 3)" "$(awk 'BEGIN { printf "%.12f", -90 + 3140 * 180 / 4096 }')" 1e-9 ||
  fail "geographic: north edge"
near "$(geotransform "$out/geo.tif" 1)" "$(awk 'BEGIN { printf "%.15f", 180 / 4096 / 256 }')" 1e-12 ||
  fail "geographic: pixel size"
echo "GeoTIFF CRS, origins, pixel sizes and values checked"
