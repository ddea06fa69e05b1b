// Browser tests of the viewer's planet mode (client_web/js/planet_view.js) in Debian's headless
// Chromium (WebGL2 on SwiftShader), driven by playwright-core against the real terrain-server:
//   - the default planet loads from orbit and from a low, tilted view without console errors and
//     reaches idle (every tile the view needs loaded and drawn);
//   - the pictures are not blank: terrain covers a good share of pixels, some of them water and
//     some land, and the low view shows sky above the horizon;
//   - the quantized-mesh decoder (js/quantized_mesh.js), run in the page on the server's tiles,
//     agrees with the tile headers and with GET …/sample at vertex positions;
//   - a fixed view matches its golden screenshot (tests/client/golden/planet-default.png);
//     `--accept` writes it instead (scripts/accept-client-goldens.sh);
//   - the picker lists the planets ("default" first) and switches to a scene and back;
//   - an unknown planet is named in a message.
//
// Usage: node planet_test.mjs SERVER_BINARY REPO_ROOT [--accept]
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync, writeFileSync, existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

const WIDTH = 96;
const HEIGHT = 64;
const PIXEL_TOLERANCE = 6;  // per channel, of 255 (as the scene goldens)
const PIXEL_SHARE = 0.99;
const ORBIT = '#planet=default';
const LOW = '#planet=default&lat=6.5&lon=40&alt=6000&heading=0&tilt=75';
const GOLDEN = '#planet=default&lat=4&lon=40&alt=120000&heading=10&tilt=55';
// Decoded tiles: [z, x, y, tolerance against /sample]. /sample is at full detail; a tile's
// samples come from the planet's refinement level for its sample spacing, so the two agree only
// where that level is the finest: from about zoom 16 on (measured 0.20–0.29 m at zooms 16–20:
// the shared edge heights are rounded to the edge quantum Q = 0.5 m, so up to Q/2, and interior
// heights to q ≤ Q). The zoom-9 tile over a coast (a 256² water mask) is checked for structure
// only: at its level the refinement differs from the finest by up to hundreds of metres.
const DECODED_TILES = [[18, 144179, 96119, 0.5], [20, 1282175, 567396, 0.5], [9, 625, 277, null]];

const [serverBinary, repoRoot, ...rest] = process.argv.slice(2);
const accept = rest.includes('--accept');
if (!serverBinary || !repoRoot) {
  console.error('usage: node planet_test.mjs SERVER_BINARY REPO_ROOT [--accept]');
  process.exit(2);
}

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures += 1;
}

async function startServer() {
  const data = mkdtempSync(join(tmpdir(), 'planet-test-'));
  const server = spawn(serverBinary, ['--config', '/dev/null', '--port', '0', '--data-dir', data,
    '--client-dir', join(repoRoot, 'client_web'), '--log-level', 'warn'], { cwd: repoRoot });
  let errors = '';
  server.stderr.on('data', (d) => { errors += d; });
  const port = await new Promise((resolve, reject) => {
    let out = '';
    const timer = setTimeout(() => reject(new Error(`server did not start: ${errors}`)), 30000);
    server.stdout.on('data', (d) => {
      out += d;
      const m = out.match(/listening on http:\/\/[^:]+:(\d+)/);
      if (m) { clearTimeout(timer); resolve(Number(m[1])); }
    });
    server.on('exit', (code) => reject(new Error(`server exited (${code}): ${errors}`)));
  });
  return { port, stop: () => { server.kill('SIGTERM'); rmSync(data, { recursive: true, force: true }); } };
}

async function openViewer(browser, url) {
  const page = await browser.newPage({ viewport: { width: WIDTH, height: HEIGHT }, deviceScaleFactor: 1 });
  const consoleErrors = [];
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  const start = Date.now();
  await page.goto(url);
  return { page, consoleErrors, start };
}

async function waitIdle(page) {
  await page.waitForFunction(() => window.terrainViewer &&
    ((window.terrainViewer.idle && window.terrainViewer.drawn > 0) || window.terrainViewer.state.error),
    null, { timeout: 120000, polling: 50 });
  return page.evaluate(() => window.terrainViewer.state.error);
}

// Shares of the picture: terrain (a distance was written), and among terrain pixels water
// (blue well above red and at least green) and land.
function classify(frame) {
  let terrain = 0, water = 0, land = 0;
  const n = frame.width * frame.height;
  for (let i = 0; i < n; ++i) {
    if (!(frame.depth[i] > 0)) continue;
    terrain += 1;
    const [r, g, b] = frame.rgba.slice(4 * i, 4 * i + 3);
    if (b > r + 25 && b >= g) water += 1;
    else land += 1;
  }
  return { terrain: terrain / n, water: water / n, land: land / n };
}

async function decodePng(page, bytes) {
  const b64 = Buffer.from(bytes).toString('base64');
  return page.evaluate(async (data) => {
    const image = new Image();
    image.src = `data:image/png;base64,${data}`;
    await image.decode();
    const c = document.createElement('canvas');
    c.width = image.width;
    c.height = image.height;
    const g = c.getContext('2d');
    g.drawImage(image, 0, 0);
    return { width: c.width, height: c.height, rgba: Array.from(g.getImageData(0, 0, c.width, c.height).data) };
  }, b64);
}

async function encodePng(page, rgba, width, height) {
  const b64 = await page.evaluate(({ data, w, h }) => {
    const c = document.createElement('canvas');
    c.width = w;
    c.height = h;
    c.getContext('2d').putImageData(new ImageData(new Uint8ClampedArray(data), w, h), 0, 0);
    return c.toDataURL('image/png').split(',')[1];
  }, { data: rgba, w: width, h: height });
  return Buffer.from(b64, 'base64');
}

function compare(a, b) {
  let within = 0;
  let worst = 0;
  const n = a.length / 4;
  for (let i = 0; i < n; ++i) {
    let d = 0;
    for (let c = 0; c < 3; ++c) d = Math.max(d, Math.abs(a[4 * i + c] - b[4 * i + c]));
    worst = Math.max(worst, d);
    if (d <= PIXEL_TOLERANCE) within += 1;
  }
  return { share: within / n, worst };
}

const { port, stop } = await startServer();
const base = `http://127.0.0.1:${port}`;
const browser = await chromium.launch({
  executablePath: '/usr/bin/chromium',
  args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-sandbox', '--disable-gpu-sandbox'],
});
const pct = (x) => `${(100 * x).toFixed(1)}%`;
try {
  // Orbit: the whole globe, the default view.
  {
    const { page, consoleErrors, start } = await openViewer(browser, `${base}/${ORBIT}`);
    const error = await waitIdle(page);
    const idleMs = Date.now() - start;
    check(!error, `orbit: the default planet is drawn${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    const stats = await page.evaluate(() => window.terrainViewer.state.planet.view.stats);
    console.log(`     orbit: idle after ${idleMs} ms, frame ${frame.ms.toFixed(1)} ms, ${stats.tiles} tiles, ` +
      `${stats.triangles} triangles under SwiftShader (${WIDTH}×${HEIGHT})`);
    const shares = classify(frame);
    check(frame.complete, 'orbit: every tile the view needs is loaded');
    check(shares.terrain > 0.2 && shares.terrain < 0.8,
      `orbit: the globe covers ${pct(shares.terrain)} of the picture, space the rest`);
    check(shares.water > 0.03 && shares.land > 0.03, `orbit: water ${pct(shares.water)}, land ${pct(shares.land)}`);
    const hash = await page.evaluate(() => location.hash);
    check(/^#planet=default&lat=15&lon=20&alt=\d+/.test(hash), `orbit: the view is in the URL (${hash})`);
    const groups = await page.evaluate(() => [...document.querySelectorAll('#scene-picker optgroup')]
      .map((g) => [g.label, [...g.querySelectorAll('option')].map((o) => o.value)]));
    const planets = groups.find(([label]) => label === 'Planets');
    check(planets && planets[1][0] === 'planet:default', `the picker lists the planets, default first (${JSON.stringify(planets)})`);

    // The decoder on the server's tiles (the browser un-gzips them as it would for the viewer).
    for (const [z, x, y, tolerance] of DECODED_TILES) {
      const decoded = await page.evaluate(async ({ z, x, y }) => {
        const { decodeQuantizedMesh } = await import('/js/quantized_mesh.js');
        const { tileBounds } = await import('/js/planet_view.js');
        const response = await fetch(`/api/v1/planets/default/mesh/${z}/${x}/${y}.terrain`, {
          headers: { Accept: 'application/vnd.quantized-mesh;extensions=octvertexnormals-watermask' },
        });
        const mesh = decodeQuantizedMesh(await response.arrayBuffer());
        const b = tileBounds(z, x, y);
        let lo = Infinity, hi = -Infinity;
        for (const h of mesh.heights) { lo = Math.min(lo, h); hi = Math.max(hi, h); }
        const edgesOk = [...mesh.edges.west].every((i) => mesh.u[i] === 0) &&
          [...mesh.edges.east].every((i) => mesh.u[i] === 32767) &&
          [...mesh.edges.south].every((i) => mesh.v[i] === 0) &&
          [...mesh.edges.north].every((i) => mesh.v[i] === 32767);
        let unit = true;
        for (let i = 0; i < mesh.vertexCount; ++i) {
          const l = Math.hypot(mesh.normals[3 * i], mesh.normals[3 * i + 1], mesh.normals[3 * i + 2]);
          if (Math.abs(l - 1) > 1e-5) unit = false;
        }
        // Every 37th vertex: its latitude, longitude and height.
        const points = [];
        for (let i = 0; i < mesh.vertexCount; i += 37) {
          points.push({ lat: b.south + ((b.north - b.south) * mesh.v[i]) / 32767,
            lon: b.west + ((b.east - b.west) * mesh.u[i]) / 32767, h: mesh.heights[i] });
        }
        return { count: mesh.vertexCount, triangles: mesh.indices.length / 3, min: mesh.header.minimumHeight,
          max: mesh.header.maximumHeight, lo, hi, edgesOk, unit, normals: mesh.normals.length / 3,
          mask: mesh.waterMask?.length ?? 0, points, edges: Object.values(mesh.edges).map((e) => e.length) };
      }, { z, x, y });
      const name = `tile ${z}/${x}/${y}`;
      check(decoded.count > 0 && decoded.triangles > 0 && decoded.normals === decoded.count,
        `${name}: ${decoded.count} vertices, ${decoded.triangles} triangles, a normal per vertex`);
      check(decoded.min <= decoded.lo && decoded.hi <= decoded.max && decoded.lo - decoded.min <= 0.5,
        `${name}: heights ${decoded.lo}…${decoded.hi} m within the header's ${decoded.min}…${decoded.max} m, ` +
        'the lowest within one edge quantum (0.5 m) of its minimum');
      check(decoded.edgesOk && decoded.edges.every((n) => n === 65), `${name}: edge lists of 65 vertices on their edges`);
      check(decoded.unit, `${name}: oct-decoded normals are unit vectors`);
      check(decoded.mask === 1 || decoded.mask === 65536, `${name}: a water mask of ${decoded.mask} bytes`);
      if (tolerance === null) continue;
      let worst = 0;
      for (const p of decoded.points) {
        const sample = await (await fetch(`${base}/api/v1/planets/default/sample?lat=${p.lat}&lon=${p.lon}`)).json();
        worst = Math.max(worst, Math.abs(sample.ground - p.h));
      }
      check(worst <= tolerance, `${name}: vertex heights match /sample at ${decoded.points.length} vertices ` +
        `within ${worst.toFixed(3)} m (tolerance ${tolerance} m)`);
    }

    // Controls: the wheel zooms (exponentially in the height above ground), a drag moves the
    // globe, shift-drag tilts; the view reaches idle again.
    // (At 96×64 the HUD covers the canvas: hide it so that the pointer reaches the canvas.)
    const hideHud = await page.addStyleTag({ content: '#hud, #help { display: none !important; }' });
    const before = await page.evaluate(() => ({ ...window.terrainViewer.state.planet.camera }));
    await page.mouse.move(WIDTH / 2, HEIGHT / 2);
    await page.mouse.wheel(0, -400);
    await page.mouse.down();
    await page.mouse.move(WIDTH / 2 + 20, HEIGHT / 2 + 10, { steps: 4 });
    await page.mouse.up();
    await page.keyboard.down('Shift');
    await page.mouse.down();
    await page.mouse.move(WIDTH / 2 + 20, HEIGHT / 2 - 30, { steps: 4 });
    await page.mouse.up();
    await page.keyboard.up('Shift');
    const afterError = await waitIdle(page);
    const after = await page.evaluate(() => ({ ...window.terrainViewer.state.planet.camera }));
    check(!afterError && after.alt < before.alt * 0.7 && after.lon < before.lon && after.lat > before.lat && after.tilt > 0,
      `the controls zoom (alt ${before.alt} → ${after.alt.toFixed(0)}), move (${before.lat}, ${before.lon} → ` +
      `${after.lat.toFixed(2)}, ${after.lon.toFixed(2)}) and tilt (${after.tilt}°), and the view is drawn again`);

    await hideHud.evaluate((e) => e.remove());

    // Switching to a scene and back through the picker.
    await page.selectOption('#scene-picker', 'butte');
    const sceneError = await page.waitForFunction(() => window.terrainViewer.state.sceneId === 'butte' &&
      window.terrainViewer.idle ? 'ok' : window.terrainViewer.state.error, null, { timeout: 120000, polling: 50 });
    check(await sceneError.jsonValue() === 'ok', 'the picker switches from the planet to a scene, which is drawn');
    await page.selectOption('#scene-picker', 'planet:default');
    const back = await waitIdle(page);
    const mode = await page.evaluate(() => window.terrainViewer.state.planet?.id);
    check(!back && mode === 'default', 'and back to the planet');
    check(consoleErrors.length === 0, `orbit: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  // Low and tilted: 2 km above a plateau near a coast, looking north at the horizon.
  {
    const { page, consoleErrors, start } = await openViewer(browser, `${base}/${LOW}`);
    const error = await waitIdle(page);
    const idleMs = Date.now() - start;
    check(!error, `low view: drawn${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    const info = await page.evaluate(() => {
      const p = window.terrainViewer.state.planet;
      return { stats: p.view.stats, ground: p.view.heightAt(p.camera.lat, p.camera.lon), alt: p.camera.alt };
    });
    console.log(`     low view: idle after ${idleMs} ms, frame ${frame.ms.toFixed(1)} ms, ${info.stats.tiles} tiles, ` +
      `${info.stats.triangles} triangles under SwiftShader (${WIDTH}×${HEIGHT})`);
    const shares = classify(frame);
    check(frame.complete, 'low view: every tile the view needs is loaded');
    check(shares.terrain > 0.5 && shares.terrain < 0.97, `low view: terrain ${pct(shares.terrain)}, sky above the horizon`);
    check(info.ground > 1000 && info.ground < info.alt, `low view: the camera (${info.alt} m) is above the ground (${info.ground.toFixed(0)} m)`);
    check(consoleErrors.length === 0, `low view: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  // The golden view: a coast from 120 km, tilted.
  {
    const { page, consoleErrors } = await openViewer(browser, `${base}/${GOLDEN}`);
    const error = await waitIdle(page);
    check(!error, `golden view: drawn${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    const shares = classify(frame);
    check(shares.water > 0.05 && shares.land > 0.05, `golden view: water ${pct(shares.water)}, land ${pct(shares.land)}`);
    const goldenPath = join(repoRoot, 'tests/client/golden', 'planet-default.png');
    if (accept) {
      writeFileSync(goldenPath, await encodePng(page, frame.rgba, WIDTH, HEIGHT));
      console.log(`     wrote ${goldenPath}`);
    } else if (!existsSync(goldenPath)) {
      check(false, `golden screenshot ${goldenPath} exists (run scripts/accept-client-goldens.sh)`);
    } else {
      const golden = await decodePng(page, readFileSync(goldenPath));
      const vsGolden = compare(frame.rgba, golden.rgba);
      check(vsGolden.share >= PIXEL_SHARE,
        `golden view: matches its golden screenshot on ${pct(vsGolden.share)} of pixels (worst ${vsGolden.worst})`);
    }
    check(consoleErrors.length === 0, `golden view: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  // An unknown planet: a message naming it.
  {
    const { page } = await openViewer(browser, `${base}/#planet=no-such-planet`);
    const message = await waitIdle(page);
    check(/no planet "no-such-planet"/.test(message ?? ''), `an unknown planet is named in a message (${message})`);
    await page.close();
    const hex = 'a'.repeat(64);
    const missing = await openViewer(browser, `${base}/#planet=${hex}`);
    const message404 = await waitIdle(missing.page);
    check(message404 === `There is no planet "${hex}".`, `an unknown planet id is named in a message (${message404})`);
    await missing.page.close();
  }
} finally {
  await browser.close();
  stop();
}
console.log(failures === 0 ? 'all planet checks passed' : `${failures} planet check(s) failed`);
process.exit(failures === 0 ? 0 : 1);
