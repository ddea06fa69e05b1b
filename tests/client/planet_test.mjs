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
import { readFileSync, writeFileSync, existsSync } from 'node:fs';
import { join } from 'node:path';
import {
  Checks, comparePixels, decodePng, encodePng, launchBrowser, openViewer, startServer, waitIdle,
} from './browser_harness.mjs';

const WIDTH = 96;
const HEIGHT = 64;
const PIXEL_TOLERANCE = 6;  // per channel, of 255 (as the scene goldens)
const PIXEL_SHARE = 0.99;
const ORBIT = '#planet=default';
const LOW = '#planet=default&lat=4&lon=-176&alt=6000&heading=0&tilt=75';
const GOLDEN = '#planet=default&lat=4&lon=-176&alt=120000&heading=280&tilt=55';
// Decoded tiles: [z, x, y, tolerance against /sample]. /sample is at full detail; a tile's
// samples come from the planet's refinement level for its sample spacing, so the two agree only
// where that level is the finest: from about zoom 16 on (measured 0.20–0.29 m at zooms 16–20:
// the shared edge heights are rounded to the edge quantum Q = 0.5 m, so up to Q/2, and interior
// heights to q ≤ Q). The zoom-9 tile over a coast (a 256² water mask) is checked for structure
// only: at its level the refinement differs from the finest by up to hundreds of metres.
const DECODED_TILES = [[18, 144179, 96119, 0.5], [20, 1282175, 567396, 0.5], [9, 3, 267, null]];

const [serverBinary, repoRoot, ...rest] = process.argv.slice(2);
const accept = rest.includes('--accept');
if (!serverBinary || !repoRoot) {
  console.error('usage: node planet_test.mjs SERVER_BINARY REPO_ROOT [--accept]');
  process.exit(2);
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

const checks = new Checks();
const { port, stop } = await startServer(serverBinary, repoRoot);
const base = `http://127.0.0.1:${port}`;
const browser = await launchBrowser();
const pct = (x) => `${(100 * x).toFixed(1)}%`;
try {
  // Orbit: the whole globe, the default view.
  {
    const { page, consoleErrors, start } = await openViewer(browser, `${base}/${ORBIT}`, WIDTH, HEIGHT);
    const error = await waitIdle(page, 120000);
    const idleMs = Date.now() - start;
    checks.check(!error, `orbit: the default planet is drawn${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    const stats = await page.evaluate(() => window.terrainViewer.state.planet.view.stats);
    console.log(`     orbit: idle after ${idleMs} ms, frame ${frame.ms.toFixed(1)} ms, ${stats.tiles} tiles, ` +
      `${stats.triangles} triangles under SwiftShader (${WIDTH}×${HEIGHT})`);
    const shares = classify(frame);
    checks.check(frame.complete, 'orbit: every tile the view needs is loaded');
    checks.check(shares.terrain > 0.2 && shares.terrain < 0.8,
      `orbit: the globe covers ${pct(shares.terrain)} of the picture, space the rest`);
    checks.check(shares.water > 0.03 && shares.land > 0.03, `orbit: water ${pct(shares.water)}, land ${pct(shares.land)}`);
    const hash = await page.evaluate(() => location.hash);
    checks.check(/^#planet=default&lat=15&lon=20&alt=\d+/.test(hash), `orbit: the view is in the URL (${hash})`);
    const groups = await page.evaluate(() => [...document.querySelectorAll('#scene-picker optgroup')]
      .map((g) => [g.label, [...g.querySelectorAll('option')].map((o) => o.value)]));
    const planets = groups.find(([label]) => label === 'Planets');
    checks.check(planets && planets[1][0] === 'planet:default', `the picker lists the planets, default first (${JSON.stringify(planets)})`);

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
      checks.check(decoded.count > 0 && decoded.triangles > 0 && decoded.normals === decoded.count,
        `${name}: ${decoded.count} vertices, ${decoded.triangles} triangles, a normal per vertex`);
      checks.check(decoded.min <= decoded.lo && decoded.hi <= decoded.max && decoded.lo - decoded.min <= 0.5,
        `${name}: heights ${decoded.lo}…${decoded.hi} m within the header's ${decoded.min}…${decoded.max} m, ` +
        'the lowest within one edge quantum (0.5 m) of its minimum');
      checks.check(decoded.edgesOk && decoded.edges.every((n) => n === 65), `${name}: edge lists of 65 vertices on their edges`);
      checks.check(decoded.unit, `${name}: oct-decoded normals are unit vectors`);
      checks.check(decoded.mask === 1 || decoded.mask === 65536, `${name}: a water mask of ${decoded.mask} bytes`);
      if (tolerance === null) continue;
      let worst = 0;
      for (const p of decoded.points) {
        const sample = await (await fetch(`${base}/api/v1/planets/default/sample?lat=${p.lat}&lon=${p.lon}`)).json();
        worst = Math.max(worst, Math.abs(sample.ground - p.h));
      }
      checks.check(worst <= tolerance, `${name}: vertex heights match /sample at ${decoded.points.length} vertices ` +
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
    const afterError = await waitIdle(page, 120000);
    const after = await page.evaluate(() => ({ ...window.terrainViewer.state.planet.camera }));
    checks.check(!afterError && after.alt < before.alt * 0.7 && after.lon < before.lon && after.lat > before.lat && after.tilt > 0,
      `the controls zoom (alt ${before.alt} → ${after.alt.toFixed(0)}), move (${before.lat}, ${before.lon} → ` +
      `${after.lat.toFixed(2)}, ${after.lon.toFixed(2)}) and tilt (${after.tilt}°), and the view is drawn again`);

    await hideHud.evaluate((e) => e.remove());

    // Switching to a scene and back through the picker.
    await page.selectOption('#scene-picker', 'butte');
    const sceneError = await page.waitForFunction(() => window.terrainViewer.state.sceneId === 'butte' &&
      window.terrainViewer.idle ? 'ok' : window.terrainViewer.state.error, null, { timeout: 120000, polling: 50 });
    checks.check(await sceneError.jsonValue() === 'ok', 'the picker switches from the planet to a scene, which is drawn');
    // Waited for by what it changes: the scene view stays idle until the planet has loaded, so
    // waiting for idle alone returned before the switch (a flaky check: failed once on 2026-12-03).
    await page.selectOption('#scene-picker', 'planet:default');
    const backError = await page.waitForFunction(() => window.terrainViewer.state.planet?.id === 'default' &&
      window.terrainViewer.idle ? 'ok' : window.terrainViewer.state.error, null, { timeout: 120000, polling: 50 });
    checks.check(await backError.jsonValue() === 'ok', 'and back to the planet, which is drawn');
    checks.check(consoleErrors.length === 0, `orbit: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  // Low and tilted: 6 km up over high land near a coast (980 m in generation 17), looking north
  // at the horizon.
  {
    const { page, consoleErrors, start } = await openViewer(browser, `${base}/${LOW}`, WIDTH, HEIGHT);
    const error = await waitIdle(page, 120000);
    const idleMs = Date.now() - start;
    checks.check(!error, `low view: drawn${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    const info = await page.evaluate(() => {
      const p = window.terrainViewer.state.planet;
      return { stats: p.view.stats, ground: p.view.heightAt(p.camera.lat, p.camera.lon), alt: p.camera.alt };
    });
    console.log(`     low view: idle after ${idleMs} ms, frame ${frame.ms.toFixed(1)} ms, ${info.stats.tiles} tiles, ` +
      `${info.stats.triangles} triangles under SwiftShader (${WIDTH}×${HEIGHT})`);
    const shares = classify(frame);
    checks.check(frame.complete, 'low view: every tile the view needs is loaded');
    checks.check(shares.terrain > 0.5 && shares.terrain < 0.97, `low view: terrain ${pct(shares.terrain)}, sky above the horizon`);
    checks.check(info.ground > 500 && info.ground < info.alt, `low view: the camera (${info.alt} m) is above the ground (${info.ground.toFixed(0)} m)`);
    checks.check(consoleErrors.length === 0, `low view: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  // The golden view: a coast from 120 km, tilted.
  {
    const { page, consoleErrors } = await openViewer(browser, `${base}/${GOLDEN}`, WIDTH, HEIGHT);
    const error = await waitIdle(page, 120000);
    checks.check(!error, `golden view: drawn${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    const shares = classify(frame);
    checks.check(shares.water > 0.05 && shares.land > 0.05, `golden view: water ${pct(shares.water)}, land ${pct(shares.land)}`);
    const goldenPath = join(repoRoot, 'tests/client/golden', 'planet-default.png');
    if (accept) {
      writeFileSync(goldenPath, await encodePng(page, frame.rgba, WIDTH, HEIGHT));
      console.log(`     wrote ${goldenPath}`);
    } else if (!existsSync(goldenPath)) {
      checks.check(false, `golden screenshot ${goldenPath} exists (run scripts/accept-client-goldens.sh)`);
    } else {
      const golden = await decodePng(page, readFileSync(goldenPath));
      const vsGolden = comparePixels(frame.rgba, golden.rgba, PIXEL_TOLERANCE);
      checks.check(vsGolden.share >= PIXEL_SHARE,
        `golden view: matches its golden screenshot on ${pct(vsGolden.share)} of pixels (worst ${vsGolden.worst})`);
    }
    checks.check(consoleErrors.length === 0, `golden view: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  // An unknown planet: a message naming it.
  {
    const { page } = await openViewer(browser, `${base}/#planet=no-such-planet`, WIDTH, HEIGHT);
    const message = await waitIdle(page, 120000);
    checks.check(/no planet "no-such-planet"/.test(message ?? ''), `an unknown planet is named in a message (${message})`);
    await page.close();
    const hex = 'a'.repeat(64);
    const missing = await openViewer(browser, `${base}/#planet=${hex}`, WIDTH, HEIGHT);
    const message404 = await waitIdle(missing.page, 120000);
    checks.check(message404 === `There is no planet "${hex}".`, `an unknown planet id is named in a message (${message404})`);
    await missing.page.close();
  }
} finally {
  await browser.close();
  stop();
}
console.log(checks.failures === 0 ? 'all planet checks passed' : `${checks.failures} planet checks.check(s) failed`);
process.exit(checks.failures === 0 ? 0 : 1);
