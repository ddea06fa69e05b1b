#!/usr/bin/env bash
# `terrain export` and `planet export` as a user runs them: GDAL reads a terrain-RGB MBTiles pack
# (driver, size, bands, georeferencing), the `pmtiles` npm reader finds the CLI's tile bytes in a
# PMTiles pack (terrain-RGB, and colour imagery as JPEG), an export killed with SIGKILL resumes to the same file, a pack made with other
# parameters is refused, and bad ranges fail naming the option before any file is created.
set -euo pipefail
cli="$1"
planet="$2"
scene="$3"
reader="$4"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT

# A field of the JSON on stdin, e.g. field 'j.tiles'.
field() { node -e "const j = JSON.parse(require('fs').readFileSync(0, 'utf8')); console.log($1)"; }
fail() { echo "FAIL: $*" >&2; exit 1; }

# MBTiles, terrain-RGB in Web Mercator, as GDAL sees it.
"$cli" export "$scene" -o "$out/a.mbtiles" --zoom 9-11 --threads 2 > "$out/a.json"
[ "$(field 'j.made' < "$out/a.json")" -gt 0 ] || fail "no tiles made"
info="$(gdalinfo "$out/a.mbtiles")"
grep -q 'Driver: MBTiles/MBTiles' <<< "$info" || fail "GDAL does not read it as MBTiles: $info"
grep -q 'Pseudo-Mercator' <<< "$info" || fail "no Web Mercator CRS: $info"
grep -q '^Band 3 ' <<< "$info" || fail "no RGB bands: $info"
# The size and origin of the deepest zoom's tiles.
read -r width height west north pixel < <(field "(() => { const r = j.ranges[j.ranges.length - 1];
  const size = 40075016.685578488 / 2 ** r[0];
  return [(r[3] - r[1] + 1) * 256, (r[4] - r[2] + 1) * 256, -20037508.342789244 + r[1] * size,
          20037508.342789244 - r[2] * size, size / 256].join(' '); })()" < "$out/a.json")
grep -q "Size is $width, $height" <<< "$info" || fail "expected size $width x $height: $info"
origin="$(grep -o 'Origin = ([^)]*)' <<< "$info" | tr -d 'Origin=() ')"
size="$(grep -o 'Pixel Size = ([^)]*)' <<< "$info" | tr -d 'PixelSz=() ')"
node -e "const [x, y] = '$origin'.split(',').map(Number), [px, py] = '$size'.split(',').map(Number);
  process.exit(Math.abs(x - $west) < 0.01 && Math.abs(y - $north) < 0.01 &&
    Math.abs(px - $pixel) < 1e-6 && Math.abs(py + $pixel) < 1e-6 ? 0 : 1)" ||
  fail "origin $origin / pixel $size, expected $west,$north / $pixel"

# PMTiles: the npm reader finds the bytes `terrain tile` makes.
# Zooms 13-15: a few hundred tiles, enough for an export to be killed midway.
"$cli" export "$scene" -o "$out/full.pmtiles" --zoom 13-15 --threads 2 > "$out/full.json"
read -r z x y < <(field "j.ranges[1].slice(0, 3).join(' ')" < "$out/full.json")
node "$reader" "$out/full.pmtiles" "$z" "$x" "$y" "$out/from-pack.png" > "$out/read.json"
[ "$(field 'j.header.tileType' < "$out/read.json")" = 2 ] || fail "tile type is not png"
[ "$(field 'j.metadata.tile_scheme' < "$out/read.json")" = webmercator ] || fail "no tile scheme"
"$cli" tile "$scene" "$z" "$x" "$y" --scheme webmercator -o "$out/served.png" > /dev/null
cmp "$out/from-pack.png" "$out/served.png" || fail "tile $z/$x/$y differs from terrain tile"

# Colour imagery: a JPEG PMTiles pack as the npm reader sees it, holding `terrain tile`'s bytes.
"$cli" export "$scene" -o "$out/colour.pmtiles" --zoom 12-12 --format jpg > "$out/colour.json"
read -r z x y < <(field "j.ranges[0].slice(0, 3).join(' ')" < "$out/colour.json")
node "$reader" "$out/colour.pmtiles" "$z" "$x" "$y" "$out/colour-pack.jpg" > "$out/colour-read.json"
[ "$(field 'j.header.tileType' < "$out/colour-read.json")" = 3 ] || fail "tile type is not jpeg"
"$cli" tile "$scene" "$z" "$x" "$y" --scheme webmercator -o "$out/colour-served.jpg" > /dev/null
cmp "$out/colour-pack.jpg" "$out/colour-served.jpg" || fail "colour tile $z/$x/$y differs"

# Killed exports resume: the PMTiles file is byte-identical to the uninterrupted one; the
# MBTiles pack holds the same pixels.
kill_midway() {  # FILE-TO-WATCH COMMAND...
  local watch="$1"
  shift
  "$@" > /dev/null &
  local pid=$!
  for _ in $(seq 1 600); do
    [ -f "$watch" ] && [ "$(stat -c %s "$watch")" -gt 400000 ] && break
    sleep 0.05
  done
  kill -KILL "$pid" 2> /dev/null || fail "the export ended before it could be killed"
  { wait "$pid"; } 2> /dev/null && fail "the killed export exited normally" || true
}
kill_midway "$out/k.pmtiles.partial" \
  "$cli" export "$scene" -o "$out/k.pmtiles" --zoom 13-15 --threads 1 --commit-every 2
[ ! -e "$out/k.pmtiles" ] || fail "a killed PMTiles export left a final file"
"$cli" export "$scene" -o "$out/k.pmtiles" --zoom 13-15 --threads 2 > "$out/k.json"
[ "$(field 'j.resumed' < "$out/k.json")" -gt 0 ] || fail "nothing resumed: $(cat "$out/k.json")"
[ "$(field 'j.made' < "$out/k.json")" -gt 0 ] || fail "nothing left to make: $(cat "$out/k.json")"
cmp "$out/k.pmtiles" "$out/full.pmtiles" || fail "the resumed PMTiles pack differs"
[ ! -e "$out/k.pmtiles.partial" ] || fail "the scratch file is left"

"$cli" export "$scene" -o "$out/ref.mbtiles" --zoom 13-15 --threads 2 > /dev/null
kill_midway "$out/k.mbtiles" \
  "$cli" export "$scene" -o "$out/k.mbtiles" --zoom 13-15 --threads 1 --commit-every 2
"$cli" export "$scene" -o "$out/k.mbtiles" --zoom 13-15 --threads 2 > "$out/km.json"
[ "$(field 'j.resumed' < "$out/km.json")" -gt 0 ] || fail "nothing resumed: $(cat "$out/km.json")"
[ "$(field 'j.made' < "$out/km.json")" -gt 0 ] || fail "nothing left to make: $(cat "$out/km.json")"
[ "$(gdalinfo -checksum "$out/k.mbtiles" | grep Checksum)" = \
  "$(gdalinfo -checksum "$out/ref.mbtiles" | grep Checksum)" ] || fail "resumed MBTiles pixels differ"

# Another export into an existing pack is refused, and the pack is left as it was.
expect_error() {  # PATTERN FILE-THAT-MUST-NOT-APPEAR COMMAND...
  local pattern="$1" file="$2"
  shift 2
  if "$@" > /dev/null 2> "$out/err"; then fail "expected failure: $*"; fi
  grep -q -- "$pattern" "$out/err" || fail "no '$pattern' in: $(cat "$out/err")"
  [ -z "$file" ] || [ ! -e "$file" ] || fail "$file was created by: $*"
  [ -z "$file" ] || [ ! -e "$file.partial" ] || fail "$file.partial was created by: $*"
}
cp "$out/full.pmtiles" "$out/before.pmtiles"
expect_error 'other parameters' '' "$cli" export "$scene" -o "$out/full.pmtiles" --zoom 13-15 \
  --encoding terrarium
expect_error 'other parameters' '' "$cli" export "$scene" -o "$out/a.mbtiles" --zoom 9-10
cmp "$out/full.pmtiles" "$out/before.pmtiles" || fail "a refused export changed the pack"

# Bad ranges: refused before anything is made or written.
bad="$out/bad.pmtiles"
expect_error '--zoom' "$bad" "$cli" export "$scene" -o "$bad" --zoom 5-3
expect_error '--zoom' "$bad" "$cli" export "$scene" -o "$bad" --zoom 0-25
expect_error '--zoom' "$bad" "$cli" export "$scene" -o "$bad" --zoom five
expect_error '--bbox' "$bad" "$cli" export "$scene" -o "$bad" --zoom 3 --bbox 0,0,10,86
expect_error '--bbox' "$bad" "$cli" export "$scene" -o "$bad" --zoom 3 --bbox 10,0,5,5
expect_error '--bbox' "$bad" "$cli" export "$scene" -o "$bad" --zoom 3 --bbox 1,2,3
expect_error '--max-tiles' "$bad" "$cli" export "$scene" -o "$bad" --zoom 0-12 \
  --bbox -180,-85,180,85
expect_error '--max-tiles' "$bad" "$cli" export "$scene" -o "$bad" --zoom 13-15 --max-tiles 3
expect_error '--encoding' "$bad" "$cli" export "$scene" -o "$bad" --zoom 3 --encoding gray16
expect_error '--encoding' "$bad" "$cli" export "$scene" -o "$bad" --zoom 3 --format jpg \
  --encoding terrarium
expect_error '--format' "$bad" "$cli" export "$scene" -o "$bad" --zoom 3 --format glb
expect_error '-o' "$out/bad.zip" "$cli" export "$scene" -o "$out/bad.zip" --zoom 3
expect_error '--bbox' "$out/p.mbtiles" "$planet" export -o "$out/p.mbtiles" --zoom 2 \
  --bbox 0,0,190,10

# The default planet: height images on Web Mercator (GDAL places them), meshes geographic,
# stored one PMTiles zoom down.
"$planet" export -o "$out/p.pmtiles" --zoom 0-1 --threads 2 > "$out/p.json"
[ "$(field 'j.tiles' < "$out/p.json")" = 5 ] || fail "a planet's Web Mercator zooms 0-1 are 5 tiles"
node "$reader" "$out/p.pmtiles" 1 1 0 "$out/p-from-pack.png" > "$out/p-read.json"
[ "$(field 'j.metadata.crs' < "$out/p-read.json")" = EPSG:3857 ] || fail "planet pack CRS"
"$planet" tile "$(dirname "$scene")/../planets/default.json" 1 1 0 --scheme webmercator \
  -o "$out/p-served.png" > /dev/null
cmp "$out/p-from-pack.png" "$out/p-served.png" || fail "planet tile 1/1/0 differs"
"$planet" export default -o "$out/p-png.mbtiles" --zoom 0-1 > /dev/null
gdalinfo "$out/p-png.mbtiles" > "$out/p-gdalinfo.txt" || fail "gdalinfo cannot read the planet pack"
grep -q 'Pseudo-Mercator' "$out/p-gdalinfo.txt" || fail "planet MBTiles pack is not Web Mercator"
"$planet" export default -o "$out/p.mbtiles" --zoom 0 --format terrain > "$out/pm.json"
[ "$(field 'j.tiles' < "$out/pm.json")" = 2 ] || fail "a planet's zoom 0 is 2 tiles"
echo "exports written, read back and checked"
