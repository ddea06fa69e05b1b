// MapLibre GL JS draws a terrain-RGB PMTiles pack made by `terrain export`, read through the
// `pmtiles` npm package's protocol from a plain HTTP server that answers Range requests (no
// terrain-server involved), in Debian's headless Chromium (SwiftShader):
//   - no console or map errors, and the raster-dem source loads tiles (range requests reach the
//     pack, 'data' events name the source's tiles, the map goes idle);
//   - the hillshaded picture is not blank (pixel variance);
//   - with the pack as terrain, map.queryTerrainElevation at points of the scene agrees with
//     `terrain sample` at the tiles' level of detail, within the allowance explained below.
//
// Usage: node pmtiles_test.mjs TERRAIN_CLI REPO_ROOT
import { execFileSync } from 'node:child_process';
import { createReadStream, mkdtempSync, readFileSync, rmSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { tmpdir } from 'node:os';
import { extname, join, normalize } from 'node:path';
import { Checks, decodePng, launchBrowser } from './browser_harness.mjs';

const [cli, repoRoot] = process.argv.slice(2);
if (!cli || !repoRoot) {
  console.error('usage: node pmtiles_test.mjs TERRAIN_CLI REPO_ROOT');
  process.exit(2);
}
const SCENE = join(repoRoot, 'config/scenes/mountain-range.json');
const ZOOMS = [10, 13];
const WIDTH = 512;
const HEIGHT = 384;

const checks = new Checks();
const work = mkdtempSync(join(tmpdir(), 'pmtiles-test-'));
const pack = join(work, 'pack.pmtiles');
const summary = JSON.parse(execFileSync(cli, ['export', SCENE, '-o', pack, '--zoom', ZOOMS.join('-'),
  '--threads', '2'], { encoding: 'utf8' }));
console.log(`     pack: ${summary.tiles} tiles, ${summary.bytes} bytes in ${summary.seconds} s`);
const scene = JSON.parse(readFileSync(SCENE, 'utf8'));
const geo = scene.georeference;

// The scene's georeference frame (terrain/src/tile_source.cpp, GeoFrame): WGS84 ECEF offsets
// from the origin projected on the tangent plane's east and north, turned by the heading.
function toScene(lat, lon) {
  const a = 6378137, f = 1 / 298.257223563, e2 = f * (2 - f), d = Math.PI / 180;
  const ecef = (phi, lambda) => {
    const n = a / Math.sqrt(1 - e2 * Math.sin(phi) ** 2);
    return [n * Math.cos(phi) * Math.cos(lambda), n * Math.cos(phi) * Math.sin(lambda),
      n * (1 - e2) * Math.sin(phi)];
  };
  const p0 = ecef(geo.latitude * d, geo.longitude * d), p = ecef(lat * d, lon * d);
  const dx = [p[0] - p0[0], p[1] - p0[1], p[2] - p0[2]];
  const sl = Math.sin(geo.latitude * d), cl = Math.cos(geo.latitude * d);
  const so = Math.sin(geo.longitude * d), co = Math.cos(geo.longitude * d);
  const east = -so * dx[0] + co * dx[1];
  const north = -sl * co * dx[0] - sl * so * dx[1] + cl * dx[2];
  const ch = Math.cos((geo.heading ?? 0) * d), sh = Math.sin((geo.heading ?? 0) * d);
  return [east * ch - north * sh, east * sh + north * ch];
}

// `terrain sample` at the level of detail of the deepest tiles: octaves finer than their
// sample spacing are faded out of the tiles, so a full-detail sample would not match.
const lodSpacing = (2 * Math.PI * 6378137 * Math.cos(geo.latitude * Math.PI / 180)) / (2 ** ZOOMS[1] * 256);
function sceneHeight(lat, lon) {
  const [x, y] = toScene(lat, lon);
  const out = JSON.parse(execFileSync(cli, ['sample', SCENE, String(x), String(y), '--lod',
    String(lodSpacing)], { encoding: 'utf8' }));
  return out.elevation;
}

// A static server for the page, the two packages' files and the pack, with byte ranges.
const types = { '.html': 'text/html', '.mjs': 'text/javascript', '.js': 'text/javascript',
  '.css': 'text/css', '.pmtiles': 'application/vnd.pmtiles' };
const roots = {
  '/maplibre/': join(repoRoot, 'node_modules/maplibre-gl/dist'),
  '/pmtiles/': join(repoRoot, 'node_modules/pmtiles/dist'),
};
let rangeRequests = 0;
const notFound = [];
const page = (port) => `<!doctype html><html><head><meta charset="utf-8">
<link rel="stylesheet" href="/maplibre/maplibre-gl.css">
<style>body { margin: 0 } #map { width: ${WIDTH}px; height: ${HEIGHT}px }</style>
<script src="/pmtiles/pmtiles.js"></script></head><body><div id="map"></div>
<script type="module">
import * as maplibregl from '/maplibre/maplibre-gl.mjs';
const state = window.state = { errors: [], tiles: new Set(), idle: 0, ready: false };
try {
  maplibregl.addProtocol('pmtiles', new pmtiles.Protocol().tile);
  const url = 'pmtiles://http://127.0.0.1:${port}/pack.pmtiles';
  const map = window.map = new maplibregl.Map({
    container: 'map', center: [${geo.longitude}, ${geo.latitude}], zoom: 12.6, fadeDuration: 0,
    attributionControl: false,
    style: { version: 8, sources: {
        hills: { type: 'raster-dem', url, encoding: 'mapbox', tileSize: 256 },
        ground: { type: 'raster-dem', url, encoding: 'mapbox', tileSize: 256 } },
      layers: [{ id: 'paper', type: 'background', paint: { 'background-color': '#ffffff' } },
        { id: 'shade', type: 'hillshade', source: 'hills' }] } });
  map.on('error', (e) => state.errors.push(String(e.error?.message ?? e.error ?? e)));
  map.on('data', (e) => { if (e.sourceId === 'hills' && e.tile) state.tiles.add(e.tile.tileID.key); });
  map.on('idle', () => { state.idle += 1; });
  state.ready = true;
} catch (e) { state.errors.push(String(e)); }
</script></body></html>`;

const server = createServer((req, res) => {
  const url = new URL(req.url, 'http://x');
  let file = null;
  if (url.pathname === '/') {
    res.writeHead(200, { 'Content-Type': 'text/html' });
    res.end(page(server.address().port));
    return;
  }
  if (url.pathname === '/favicon.ico') {
    res.writeHead(204);
    res.end();
    return;
  }
  if (url.pathname === '/pack.pmtiles') file = pack;
  for (const [prefix, dir] of Object.entries(roots)) {
    if (url.pathname.startsWith(prefix)) file = join(dir, normalize(url.pathname.slice(prefix.length)));
  }
  let size = 0;
  try { size = file ? statSync(file).size : 0; } catch { file = null; }
  if (!file) {
    notFound.push(url.pathname);
    res.writeHead(404);
    res.end();
    return;
  }
  const headers = { 'Content-Type': types[extname(file)] ?? 'application/octet-stream',
    'Accept-Ranges': 'bytes' };
  const range = /^bytes=(\d+)-(\d*)$/.exec(req.headers.range ?? '');
  if (range) {
    rangeRequests += file === pack ? 1 : 0;
    const start = Number(range[1]);
    const end = Math.min(range[2] ? Number(range[2]) : size - 1, size - 1);
    if (start >= size) {
      res.writeHead(416, { 'Content-Range': `bytes */${size}` });
      res.end();
      return;
    }
    res.writeHead(206, { ...headers, 'Content-Range': `bytes ${start}-${end}/${size}`,
      'Content-Length': end - start + 1 });
    createReadStream(file, { start, end }).pipe(res);
    return;
  }
  res.writeHead(200, { ...headers, 'Content-Length': size });
  createReadStream(file).pipe(res);
});
await new Promise((resolve) => server.listen(0, '127.0.0.1', resolve));
const port = server.address().port;

const browser = await launchBrowser();
try {
  const tab = await browser.newPage({ viewport: { width: WIDTH, height: HEIGHT } });
  const consoleErrors = [];
  tab.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  tab.on('pageerror', (e) => consoleErrors.push(String(e)));
  await tab.goto(`http://127.0.0.1:${port}/`);
  await tab.waitForFunction(() => window.state && (window.state.idle > 0 || window.state.errors.length > 0),
    null, { timeout: 180000, polling: 100 });
  const first = await tab.evaluate(() => ({ errors: window.state.errors, tiles: window.state.tiles.size }));
  checks.check(first.errors.length === 0, `no map errors${first.errors.length ? `: ${first.errors.join('; ')}` : ''}`);
  checks.check(first.tiles > 0, `the raster-dem source loaded ${first.tiles} tiles from the pack`);
  checks.check(rangeRequests > 1, `${rangeRequests} range requests reached the pack`);

  // Not blank: hillshading varies across the picture.
  const shot = await decodePng(tab, await tab.screenshot({ clip: { x: 0, y: 0, width: WIDTH, height: HEIGHT } }));
  let sum = 0, sum2 = 0;
  const n = shot.width * shot.height;
  for (let i = 0; i < n; ++i) {
    const v = (shot.rgba[4 * i] + shot.rgba[4 * i + 1] + shot.rgba[4 * i + 2]) / 3;
    sum += v;
    sum2 += v * v;
  }
  const variance = sum2 / n - (sum / n) ** 2;
  checks.check(variance > 20, `the hillshade is not blank (grey variance ${variance.toFixed(1)})`);

  // Heights: the pack as terrain at the deepest zoom's tiles.
  await tab.evaluate(() => {
    window.state.idle = 0;
    window.map.setTerrain({ source: 'ground', exaggeration: 1 });
    window.map.jumpTo({ zoom: 13.2 });
  });
  await tab.waitForFunction(() => window.state.idle > 0 || window.state.errors.length > 0, null,
    { timeout: 180000, polling: 100 });
  // What MapLibre samples: the drawn terrain mesh (128×128 cells per tile, vertex heights from
  // the DEM bilinearly between pixel centres), so a queried height is a weighted mean of DEM
  // samples within about three pixel spacings (a two-pixel mesh cell plus the bilinear pixel).
  // Each DEM sample is the scene's height at the tiles' level of detail rounded to 0.1 m. So
  // |MapLibre − terrain sample| ≤ 0.05 m + the largest change of the height within that radius,
  // which we measure with `terrain sample` on two rings around the point (with 25 % margin for
  // the ring missing the true maximum: at this level of detail the surface is smooth).
  const radiusM = 3 * Math.SQRT2 * lodSpacing;
  const mPerDegLat = 111320, mPerDegLon = 111320 * Math.cos(geo.latitude * Math.PI / 180);
  const points = [[0.3, 0.2], [-0.4, 0.1], [0.15, -0.35], [-0.2, -0.25]].map(([u, v]) =>
    [geo.latitude + (v * 4500) / mPerDegLat, geo.longitude + (u * 4500) / mPerDegLon]);
  for (const [lat, lon] of points) {
    const drawn = await tab.evaluate(([la, lo]) => window.map.queryTerrainElevation([lo, la]), [lat, lon]);
    const truth = sceneHeight(lat, lon);
    let spread = 0;
    for (const r of [radiusM, radiusM / 2]) {
      for (let k = 0; k < 8; ++k) {
        const a = (k * Math.PI) / 4;
        const h = sceneHeight(lat + (r * Math.sin(a)) / mPerDegLat, lon + (r * Math.cos(a)) / mPerDegLon);
        spread = Math.max(spread, Math.abs(h - truth));
      }
    }
    const tolerance = 0.05 + 1.25 * spread;
    const error = drawn === null ? Infinity : Math.abs(drawn - truth);
    checks.check(error <= tolerance, `elevation at ${lat.toFixed(5)}, ${lon.toFixed(5)}: MapLibre ${drawn?.toFixed(2)} m, ` +
      `terrain sample ${truth.toFixed(2)} m (|Δ| ${error.toFixed(2)} ≤ ${tolerance.toFixed(2)} m)`);
  }
  const late = await tab.evaluate(() => window.state.errors);
  checks.check(notFound.length === 0, `every file the page asked for exists${notFound.length ? ` (not: ${notFound.join(', ')})` : ''}`);
  checks.check(late.length === 0 && consoleErrors.length === 0,
    `no console or map errors${late.length || consoleErrors.length ? `: ${[...late, ...consoleErrors].join('; ')}` : ''}`);
} finally {
  await browser.close();
  server.close();
  rmSync(work, { recursive: true, force: true });
}
if (checks.failures > 0) {
  console.log(`${checks.failures} check(s) failed`);
  process.exit(1);
}
console.log('all PMTiles browser checks passed');
