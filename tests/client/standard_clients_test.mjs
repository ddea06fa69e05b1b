// The example pages (client_web/examples/) with the real npm packages of CesiumJS and MapLibre GL
// JS in Debian's headless Chromium (WebGL2 on SwiftShader), driven by playwright-core against
// the real terrain-server. The pages come from http://localhost:PORT and the tiles from
// http://127.0.0.1:PORT: another origin, so CORS is exercised as a user's own page would.
//   - CesiumJS with CesiumTerrainProvider's default options (requestVertexNormals and
//     requestWaterMask on, metadata on by default): a scene and the default planet draw tiles,
//     with no console, page or terrain-provider errors, every request answered 2xx/304, and a
//     picture that is not blank;
//   - heights CesiumJS samples (sampleTerrainMostDetailed) at vertices of the deepest tiles agree
//     with GET …/sample within the encoding's quantum;
//   - the globe from afar (tiles of zooms 0–3): the drawn surface, picked along rays through the
//     view, dips under the true surface by no more than the geometric error CesiumJS assumes for
//     the level drawn there (no facets);
//   - MapLibre: a raster-dem source given only the TileJSON, hillshade and 3D terrain, for a
//     scene and the default planet (Web Mercator tiles); queryTerrainElevation at the DEM's pixel centres agrees with /sample within the
//     terrain-RGB quantum.
//
// The libraries load from the URLs the pages name (cesium.com, unpkg.com); the test answers those
// requests with the pinned copies in node_modules and refuses any other request off loopback.
//
// Usage: node standard_clients_test.mjs SERVER_BINARY REPO_ROOT
import { existsSync, readFileSync, writeFileSync } from 'node:fs';
import { join, normalize } from 'node:path';
import { decodeQuantizedMesh } from '../../client_web/js/quantized_mesh.js';
import { Checks, decodePng, launchBrowser, startServer } from './browser_harness.mjs';

const [serverBinary, repoRoot] = process.argv.slice(2);
if (!serverBinary || !repoRoot) {
  console.error('usage: node standard_clients_test.mjs SERVER_BINARY REPO_ROOT');
  process.exit(2);
}

const WIDTH = 480;
const HEIGHT = 320;
const SCENE = 'mountain-range';  // georeferenced with a heading of 15°: the mapping is exercised
const EARTH_RADIUS = 6378137;
const LIBRARIES = [
  { prefix: 'https://cesium.com/downloads/cesiumjs/releases/1.145/Build/Cesium/',
    folder: join(repoRoot, 'node_modules/cesium/Build/Cesium') },
  { prefix: 'https://unpkg.com/maplibre-gl@6.17.0/dist/',
    folder: join(repoRoot, 'node_modules/maplibre-gl/dist') },
];
const MEDIA_TYPES = { '.js': 'text/javascript', '.mjs': 'text/javascript', '.css': 'text/css',
  '.json': 'application/json', '.png': 'image/png', '.jpg': 'image/jpeg', '.wasm': 'application/wasm',
  '.svg': 'image/svg+xml', '.xml': 'text/xml' };

const checks = new Checks();
const check = (ok, what) => checks.check(ok, what);
// The pages' origin (localhost) differs from the API's (127.0.0.1), as a user's own page would.
const server = await startServer(serverBinary, repoRoot, { corsOrigins: '*' });
const api = `http://127.0.0.1:${server.port}`;
const pages = `http://localhost:${server.port}/examples`;
const browser = await launchBrowser();

// --- helpers ----------------------------------------------------------------------------------

async function getJson(url, headers = {}) {
  const r = await fetch(url, { headers });
  if (!r.ok) throw new Error(`${url}: ${r.status} ${await r.text()}`);
  return r.json();
}

/// A page of an example with the libraries answered from node_modules, every request recorded.
async function openExample(path) {
  const context = await browser.newContext({ viewport: { width: WIDTH, height: HEIGHT } });
  const seen = { responses: [], refused: [], consoleErrors: [] };
  await context.route(/^https?:\/\//, async (route) => {
    const url = route.request().url();
    const library = LIBRARIES.find((l) => url.startsWith(l.prefix));
    if (library) {
      const relative = decodeURIComponent(new URL(url).pathname)
        .slice(new URL(library.prefix).pathname.length);
      const file = normalize(join(library.folder, relative));
      if (file.startsWith(library.folder) && existsSync(file)) {
        const type = MEDIA_TYPES[file.slice(file.lastIndexOf('.'))] || 'application/octet-stream';
        return route.fulfill({ status: 200, body: readFileSync(file), contentType: type,
                               headers: { 'Access-Control-Allow-Origin': '*' } });
      }
      return route.fulfill({ status: 404, body: `not in node_modules: ${relative}` });
    }
    const host = new URL(url).hostname;
    if (host === '127.0.0.1' || host === 'localhost') return route.continue();
    seen.refused.push(url);
    return route.abort();
  });
  const page = await context.newPage();
  page.on('console', (m) => { if (m.type() === 'error') seen.consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => seen.consoleErrors.push(String(e)));
  page.on('response', (r) => {
    if (r.url().startsWith(api)) seen.responses.push({ url: r.url(), status: r.status() });
  });
  await page.goto(`${pages}/${path}`);
  return { page, context, seen };
}

/// Waits for `predicate` in the page (a function source); false, with a failed check, when the
/// page reports an error first or the time runs out.
async function waitFor(page, predicate, timeout, what) {
  try {
    await page.waitForFunction(`(${predicate})() || (window.terrainExample &&
      window.terrainExample.errors.length > 0)`, null, { timeout, polling: 250 });
  } catch (e) {
    check(false, `${what}: timed out after ${timeout} ms`);
    return false;
  }
  const errors = await page.evaluate(() => window.terrainExample.errors);
  if (errors.length > 0) check(false, `${what}: the page reported ${errors.slice(0, 3).join(' | ')}`);
  return errors.length === 0;
}

function reportRequests(seen, name) {
  const tiles = seen.responses.filter((r) => /\/(mesh|tiles)\//.test(r.url));
  const bad = seen.responses.filter((r) => !(r.status >= 200 && r.status < 300) && r.status !== 304);
  console.log(`     ${name}: ${seen.responses.length} requests to the server, ${tiles.length} tiles`);
  check(tiles.length > 0, `${name}: tiles were requested`);
  check(bad.length === 0, `${name}: every request answered 2xx/304` +
    (bad.length ? ` (${bad.slice(0, 3).map((b) => `${b.status} ${b.url}`).join('; ')})` : ''));
  check(seen.refused.length === 0, `${name}: no request off loopback` +
    (seen.refused.length ? ` (${seen.refused.slice(0, 3).join(', ')})` : ''));
}

/// `lit`: the picture must also be in daylight (mean luminance above 28 of 255; a close view of
/// the planet at night under the page's lighting averaged 17).
async function checkPicture(page, name, { lit = false } = {}) {
  const png = await page.screenshot();
  // TERRAIN_SCREENSHOT_DIR=folder keeps the pictures (docs/client.md shows them).
  if (process.env.TERRAIN_SCREENSHOT_DIR) {
    writeFileSync(join(process.env.TERRAIN_SCREENSHOT_DIR,
                       `${name.replace(/[^a-z0-9]+/gi, '-').toLowerCase()}.png`), png);
  }
  const { rgba } = await decodePng(page, png);
  const colours = new Set();
  let sum = 0, sum2 = 0;
  const n = rgba.length / 4;
  for (let i = 0; i < rgba.length; i += 4) {
    const luminance = 0.299 * rgba[i] + 0.587 * rgba[i + 1] + 0.114 * rgba[i + 2];
    sum += luminance;
    sum2 += luminance * luminance;
    colours.add((rgba[i] >> 3) << 10 | (rgba[i + 1] >> 3) << 5 | (rgba[i + 2] >> 3));
  }
  const deviation = Math.sqrt(Math.max(0, sum2 / n - (sum / n) ** 2));
  console.log(`     ${name}: picture luminance deviation ${deviation.toFixed(1)}, ` +
              `${colours.size} colours`);
  check(deviation > 8 && colours.size > 64, `${name}: the picture is not blank`);
  if (lit) {
    console.log(`     ${name}: mean luminance ${(sum / n).toFixed(1)}`);
    check(sum / n > 28, `${name}: the ground is in daylight`);
  }
}

function checkNoErrors(page, seen, report, name) {
  const errors = [...seen.consoleErrors, ...(report.errors || [])];
  check(errors.length === 0, `${name}: no console, page or client errors` +
    (errors.length ? ` (${errors.slice(0, 3).join(' | ')})` : ''));
}

/// Scene coordinates (metres) of points [lon, lat], through the georeference as docs/tiles.md
/// defines it: east and north of the point on the WGS84 ellipsoid in the local tangent frame at
/// the origin ("up" dropped), turned by the heading.
function sceneXY(g, points) {
  const a = 6378137, f = 1 / 298.257223563, e2 = f * (2 - f);
  const ecef = (lon, lat) => {
    const l = lon * Math.PI / 180, p = lat * Math.PI / 180;
    const n = a / Math.sqrt(1 - e2 * Math.sin(p) ** 2);
    return [n * Math.cos(p) * Math.cos(l), n * Math.cos(p) * Math.sin(l), n * (1 - e2) * Math.sin(p)];
  };
  const o = ecef(g.longitude, g.latitude);
  const l0 = g.longitude * Math.PI / 180, p0 = g.latitude * Math.PI / 180;
  const east = [-Math.sin(l0), Math.cos(l0), 0];
  const north = [-Math.sin(p0) * Math.cos(l0), -Math.sin(p0) * Math.sin(l0), Math.cos(p0)];
  const h = g.heading * Math.PI / 180;
  const dot = (u, v) => u[0] * v[0] + u[1] * v[1] + u[2] * v[2];
  return points.map(([lon, lat]) => {
    const q = ecef(lon, lat).map((v, k) => v - o[k]);
    const e = dot(q, east), n = dot(q, north);
    return [e * Math.cos(h) - n * Math.sin(h), e * Math.sin(h) + n * Math.cos(h)];
  });
}

/// Vertices inside the deepest geographic tile around (lon, lat): [lon, lat, height] each, and
/// the tile's height quantum. Decoded with the viewer's decoder (tested against the server).
async function deepestVertices(meshUrl, maxzoom, lon, lat, count) {
  const step = 180 / 2 ** maxzoom;
  const x = Math.floor((lon + 180) / step), y = Math.floor((lat + 90) / step);
  const r = await fetch(`${meshUrl}/${maxzoom}/${x}/${y}.terrain`, {
    headers: { Accept: 'application/vnd.quantized-mesh;extensions=octvertexnormals-watermask-metadata' },
  });
  if (!r.ok) throw new Error(`tile ${maxzoom}/${x}/${y}: ${r.status}`);
  const mesh = decodeQuantizedMesh(new Uint8Array(await r.arrayBuffer()));
  const west = -180 + x * step, south = -90 + y * step;
  const { minimumHeight, maximumHeight } = mesh.header;
  const quantum = (maximumHeight - minimumHeight) / 32767;
  // Inner vertices only (edge vertices are rounded to the edge quantum), spread over the tile.
  const inner = [];
  for (let k = 0; k < mesh.vertexCount; ++k) {
    const u = mesh.u[k] / 32767, v = mesh.v[k] / 32767;
    if (u > 0 && u < 1 && v > 0 && v < 1) inner.push(k);
  }
  const chosen = [];
  const stride = Math.max(1, Math.floor(inner.length / count));
  for (let i = 0; i < inner.length && chosen.length < count; i += stride) {
    const k = inner[i];
    chosen.push([west + (mesh.u[k] / 32767) * step, south + (mesh.v[k] / 32767) * step, mesh.heights[k]]);
  }
  return { vertices: chosen, quantum, z: maxzoom, x, y };
}

async function cesiumHeights(page, points) {
  return page.evaluate(async (points) => {
    const { Cesium: C, terrainProvider } = window.terrainExample;
    const positions = points.map(([lon, lat]) => C.Cartographic.fromDegrees(lon, lat));
    const sampled = await C.sampleTerrainMostDetailed(terrainProvider, positions);
    return sampled.map((p) => p.height);
  }, points);
}

// --- CesiumJS: a scene ------------------------------------------------------------------------

/// Opens cesium.html on `query` and waits until Cesium has drawn tiles; checks the tiles, the
/// errors and the picture. Returns the page (null when it never drew) and the levels drawn.
async function openCesium(name, query) {
  const opened = await openExample(`cesium.html?server=${encodeURIComponent(api)}&${query}`);
  const { page, context, seen } = opened;
  const ready = await waitFor(page, () => window.terrainExample?.ready &&
    window.terrainExample.drawnTiles > 0 && window.terrainExample.viewer.scene.globe.tilesLoaded,
    240000, `${name}: tiles drawn`);
  if (!ready) { await context.close(); return null; }
  await page.waitForTimeout(1000);
  const report = await page.evaluate(() => {
    const r = window.terrainExample;
    const levels = r.viewer.scene.globe._surface._tilesToRender.map((t) => t.level);
    return { errors: r.errors, drawnTiles: r.drawnTiles, tileRequests: r.tileRequests,
             tilesReceived: r.tilesReceived, imageryReceived: r.imageryReceived,
             levels: [...new Set(levels)].sort((a, b) => a - b) };
  });
  console.log(`     ${name}: ${report.tileRequests} tile requests, ${report.tilesReceived} meshes ` +
              `decoded, ${report.imageryReceived} colour tiles, ${report.drawnTiles} tiles drawn ` +
              `at levels ${report.levels.join(', ')}`);
  check(report.drawnTiles > 0 && report.tilesReceived > 0, `${name}: tiles drawn`);
  const colour = seen.responses.filter((r) => /\/tiles\/.*\.jpg\?encoding=color/.test(r.url));
  check(report.imageryReceived > 0 && colour.length > 0 &&
        colour.every((r) => r.status === 200 || r.status === 304),
        `${name}: colour imagery tiles draped (${colour.length} answered)`);
  checkNoErrors(page, seen, report, name);
  await checkPicture(page, name);
  return { ...opened, levels: report.levels };
}


async function cesiumScene() {
  const name = `CesiumJS scene ${SCENE}`;
  const opened = await openCesium(name, `scene=${SCENE}`);
  if (!opened) return;
  const { page, context, seen, levels } = opened;
  check(Math.max(...levels) >= 10, `${name}: the view reaches the scene's detail (level ≥ 10)`);

  // Heights at vertices of the deepest tiles: CesiumJS against /sample.
  const layer = await getJson(`${api}/api/v1/scenes/${SCENE}/layer.json`);
  const g = { latitude: 0, longitude: 0, heading: 0, ...(await getJson(`${api}/api/v1/scenes/${SCENE}`)).georeference };
  const meshUrl = `${api}/api/v1/scenes/${SCENE}/mesh`;
  const tile = await deepestVertices(meshUrl, layer.maxzoom, g.longitude + 0.004,
                                     g.latitude + 0.003, 24);
  const xy = sceneXY(g, tile.vertices);
  // The mesh's samples are at the level of detail of its spacing (docs/tiles.md).
  const spacing = Math.PI * EARTH_RADIUS * Math.cos(g.latitude * Math.PI / 180) /
                  (2 ** tile.z * 64);
  const truth = await Promise.all(xy.map(async ([x, y]) =>
    (await getJson(`${api}/api/v1/scenes/${SCENE}/sample?x=${x}&y=${y}&lod=${spacing}`)).elevation));
  const seenByCesium = await cesiumHeights(page, tile.vertices);
  let worst = 0;
  for (let i = 0; i < truth.length; ++i) worst = Math.max(worst, Math.abs(seenByCesium[i] - truth[i]));
  // A vertex's height is rounded to the tile's quantum; its position to 1/32767 of the tile.
  const allowance = tile.quantum + 0.02;
  console.log(`     ${name}: ${truth.length} vertices of tile ${tile.z}/${tile.x}/${tile.y}: ` +
              `largest |Cesium − /sample| ${worst.toFixed(3)} m (quantum ${tile.quantum.toFixed(3)} m)`);
  check(truth.length >= 10 && worst <= allowance,
        `${name}: sampleTerrainMostDetailed agrees with /sample within the quantum`);
  reportRequests(seen, name);
  await context.close();
}

// --- CesiumJS: the default planet, near and far -------------------------------------------------

async function cesiumPlanet() {
  const name = 'CesiumJS planet default';
  const opened = await openCesium(name, 'planet=default');
  if (!opened) return;
  const { page, context, seen } = opened;

  // No facets, from orbit and from nearer (tiles of zooms 0–3): rays through the view hit the
  // drawn globe; where they hit, the drawn surface may lie under the true one (the planet's
  // /sample at full detail) by at most the geometric error CesiumJS assumes for the level of
  // the tile drawn there.
  const levelsSeen = new Set();
  for (const altitude of [1.5e7, 6e6, 2.5e6]) {
    await page.evaluate((altitude) => {
      const { Cesium: C, viewer } = window.terrainExample;
      viewer.camera.setView({ destination: C.Cartesian3.fromDegrees(20, 15, altitude) });
    }, altitude);
    await page.waitForTimeout(1500);  // frames that start the new view's loads
    await waitFor(page, () => window.terrainExample.viewer.scene.globe.tilesLoaded, 120000,
                  `${name}: view from ${altitude / 1000} km loaded`);
    await page.waitForTimeout(500);
    const picks = await page.evaluate(() => {
      const { Cesium: C, viewer } = window.terrainExample;
      const scene = viewer.scene, globe = scene.globe;
      const tiles = globe._surface._tilesToRender;
      const out = [];
      const canvas = scene.canvas;
      for (let j = 1; j < 24; ++j) {
        for (let i = 1; i < 36; ++i) {
          const ray = viewer.camera.getPickRay(
            new C.Cartesian2(canvas.clientWidth * i / 36, canvas.clientHeight * j / 24));
          const hit = ray && globe.pick(ray, scene);
          if (!hit) continue;
          const c = C.Cartographic.fromCartesian(hit);
          const tile = tiles.find((t) => C.Rectangle.contains(t.rectangle, c));
          if (!tile) continue;
          out.push({ lon: C.Math.toDegrees(c.longitude), lat: C.Math.toDegrees(c.latitude),
                     height: c.height, level: tile.level,
                     declared: viewer.terrainProvider.getLevelMaximumGeometricError(tile.level) });
        }
      }
      return out;
    });
    let worstShare = 0, worstDip = 0;
    for (const p of picks) {
      levelsSeen.add(p.level);
      const s = await getJson(`${api}/api/v1/planets/default/sample?lat=${p.lat}&lon=${p.lon}`);
      const dip = Math.max(s.ground, s.water ?? -Infinity) - p.height;
      if (dip / p.declared > worstShare) { worstShare = dip / p.declared; worstDip = dip; }
    }
    const levels = [...new Set(picks.map((p) => p.level))].sort((a, b) => a - b);
    console.log(`     ${name}: from ${altitude / 1000} km, ${picks.length} picks on tiles of levels ` +
                `${levels.join(', ')}; largest dip under the surface ${(worstDip / 1000).toFixed(2)} km ` +
                `= ${(100 * worstShare).toFixed(0)}% of the declared error`);
    check(picks.length > 200 && worstShare <= 1, `${name}: from ${altitude / 1000} km the globe ` +
          'dips no more than the declared geometric error (no facets)');
  }
  check([0, 1, 2, 3].filter((l) => levelsSeen.has(l)).length >= 3 &&
        Math.max(...levelsSeen) <= 4, `${name}: the far views draw tiles of zooms 0–3`);

  // Near the ground: fly low over land, let the deep tiles load, compare heights at vertices.
  const layer = await getJson(`${api}/api/v1/planets/default/layer.json`);
  const land = { lon: -175, lat: 5 };
  await page.evaluate(({ lon, lat }) => {
    const { Cesium: C, viewer } = window.terrainExample;
    viewer.camera.setView({ destination: C.Cartesian3.fromDegrees(lon, lat - 0.08, 9000),
                            orientation: { heading: 0, pitch: C.Math.toRadians(-30), roll: 0 } });
  }, land);
  await waitFor(page, () => window.terrainExample.viewer.scene.globe.tilesLoaded &&
    Math.max(...window.terrainExample.viewer.scene.globe._surface._tilesToRender.map((t) => t.level)) >= 10,
    240000, `${name}: close view loaded`);
  // The page's sun follows the camera: the view is in the morning, not 175° from it in the night.
  await checkPicture(page, `${name} (close)`, { lit: true });
  const tile = await deepestVertices(`${api}/api/v1/planets/default/mesh`, layer.maxzoom,
                                     land.lon, land.lat, 16);
  const seenByCesium = await cesiumHeights(page, tile.vertices);
  let worst = 0;
  for (let i = 0; i < tile.vertices.length; ++i) {
    const [lon, lat] = tile.vertices[i];
    const s = await getJson(`${api}/api/v1/planets/default/sample?lat=${lat}&lon=${lon}`);
    worst = Math.max(worst, Math.abs(seenByCesium[i] - s.ground));
  }
  // The planet's edge quantum is 0.5 m and inner heights are rounded to q ≤ Q (planet_test.mjs).
  console.log(`     ${name}: ${tile.vertices.length} vertices of tile ${tile.z}/${tile.x}/${tile.y}: ` +
              `largest |Cesium − /sample| ${worst.toFixed(3)} m (quantum ${tile.quantum.toFixed(3)} m)`);
  check(tile.vertices.length >= 8 && worst <= Math.max(tile.quantum, 0.5),
        `${name}: sampleTerrainMostDetailed agrees with /sample within the quantum`);
  checkNoErrors(page, seen, await page.evaluate(() => ({ errors: window.terrainExample.errors })),
                `${name} (close)`);
  reportRequests(seen, name);
  await context.close();
}

// --- MapLibre: a scene and the default planet -------------------------------------------------

/// How to ask /sample for the height of a DEM pixel of Web Mercator zoom z: [lon, lat] → metres.
async function sceneSampler(z) {
  const g = { latitude: 0, longitude: 0, heading: 0,
              ...(await getJson(`${api}/api/v1/scenes/${SCENE}`)).georeference };
  // A tile's samples are at the level of detail of its spacing (docs/tiles.md).
  const lod = 2 * Math.PI * EARTH_RADIUS * Math.cos(g.latitude * Math.PI / 180) / (2 ** z * 256);
  return async ([lon, lat]) => {
    const [[x, y]] = sceneXY(g, [[lon, lat]]);
    return (await getJson(`${api}/api/v1/scenes/${SCENE}/sample?x=${x}&y=${y}&lod=${lod}`)).elevation;
  };
}

async function planetSampler(z) {
  const { radius } = await getJson(`${api}/api/v1/planets/default`);
  // A Web Mercator planet tile spans the longitude of a geographic tile one zoom up (docs/planet.md).
  const lod = 2 * Math.PI * radius / (2 ** z * 256);
  return async ([lon, lat]) =>
    (await getJson(`${api}/api/v1/planets/default/sample?lat=${lat}&lon=${lon}&lod=${lod}`)).ground;
}

async function maplibre(name, query, samplerFor) {
  const { page, context, seen } = await openExample(
    `maplibre.html?server=${encodeURIComponent(api)}&${query}`);
  const ready = await waitFor(page, () => window.terrainExample?.ready &&
    window.terrainExample.map.loaded() && window.terrainExample.demTilesLoaded.length > 0,
    240000, `${name}: map loaded`);
  if (!ready) { await context.close(); return; }
  await page.evaluate(() => new Promise((resolve) => {
    const map = window.terrainExample.map;
    if (map.loaded() && !map.isMoving()) resolve(); else map.once('idle', resolve);
  }));
  const report = await page.evaluate(() => ({ errors: window.terrainExample.errors,
                                              dem: window.terrainExample.demTilesLoaded }));
  console.log(`     ${name}: ${report.dem.length} DEM tiles decoded`);
  check(report.dem.length > 0, `${name}: DEM tiles loaded`);
  const colour = seen.responses.filter((r) => /\/tiles\/.*\.jpg\?encoding=color/.test(r.url));
  check(colour.length > 0 && colour.every((r) => r.status === 200 || r.status === 304),
        `${name}: colour imagery tiles draped (${colour.length} answered)`);
  checkNoErrors(page, seen, report, name);
  await checkPicture(page, name);

  // Elevations at pixel centres of a DEM tile where MapLibre draws it, against /sample at the
  // DEM tile's level of detail. MapLibre's terrain drapes a drawn tile over the DEM of a tile
  // above it (its terrain internals say which): the points lie in the drawn tile's part of it.
  const drawn = await page.evaluate(() => {
    const manager = window.terrainExample.map.terrain.tileManager;
    return manager.getRenderableTiles().map((t) => ({
      tile: { ...t.tileID.canonical },
      dem: { ...manager.getSourceTile(t.tileID, true)?.tileID?.canonical },
    })).filter((d) => Number.isInteger(d.dem.z));
  });
  check(drawn.length > 0, `${name}: drawn tiles have DEM data`);
  if (drawn.length === 0) { await context.close(); return; }
  const { tile, dem } = drawn.reduce((a, b) => (b.dem.z > a.dem.z ? b : a));
  const part = 256 >> (tile.z - dem.z);
  const left = (tile.x - (dem.x << (tile.z - dem.z))) * part;
  const top = (tile.y - (dem.y << (tile.z - dem.z))) * part;
  const points = [];
  for (const [i, j] of [[0.1, 0.1], [0.5, 0.5], [0.8, 0.2], [0.3, 0.75], [0.9, 0.9], [0.05, 0.6]]) {
    const px = left + Math.floor(i * part), py = top + Math.floor(j * part);
    const mx = (dem.x + (px + 0.5) / 256) / 2 ** dem.z;
    const my = (dem.y + (py + 0.5) / 256) / 2 ** dem.z;
    points.push([mx * 360 - 180, Math.atan(Math.sinh(Math.PI * (1 - 2 * my))) * 180 / Math.PI]);
  }
  const elevations = await page.evaluate((points) =>
    points.map((p) => window.terrainExample.map.queryTerrainElevation(p)), points);
  const sample = await samplerFor(dem.z);
  let worst = 0;
  for (let k = 0; k < points.length; ++k) {
    worst = Math.max(worst, Math.abs(elevations[k] - await sample(points[k])));
  }
  console.log(`     ${name}: ${points.length} pixel centres of DEM tile ${dem.z}/${dem.x}/${dem.y} ` +
              `drawn under ${tile.z}/${tile.x}/${tile.y}: largest |queryTerrainElevation − /sample| ` +
              `${worst.toFixed(3)} m`);
  // terrain-RGB rounds to 0.1 m: half of it, and a little for the pixel centre's position.
  check(elevations.every((e) => typeof e === 'number') && worst <= 0.06,
        `${name}: queryTerrainElevation agrees with /sample within the terrain-RGB quantum`);
  reportRequests(seen, name);
  await context.close();
}

try {
  const index = await fetch(`${pages}/`);
  check(index.ok && (await index.text()).includes('cesium.html'), '/examples/ lists the example pages');
  await cesiumScene();
  await cesiumPlanet();
  await maplibre(`MapLibre scene ${SCENE}`, `scene=${SCENE}`, sceneSampler);
  await maplibre('MapLibre planet default', 'planet=default', planetSampler);
} catch (e) {
  check(false, `unexpected: ${e.stack || e}`);
} finally {
  await browser.close();
  server.stop();
}
console.log(checks.failures === 0 ? 'all checks passed' : `${checks.failures} check(s) failed`);
process.exit(checks.failures === 0 ? 0 : 1);
