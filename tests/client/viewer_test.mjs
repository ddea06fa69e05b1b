// Browser tests of the viewer (client_web/) in Debian's headless Chromium (WebGL2 on SwiftShader),
// driven by playwright-core. Starts the real terrain-server on a loopback port and checks, for
// every example scene:
//   - the page loads and draws without console errors;
//   - its picture matches the server's CPU render.png for the same camera: every channel within
//     PIXEL_TOLERANCE on at least 99% of pixels;
//   - the ray distance at chosen pixels matches the CPU sphere tracer's (depth.bin);
//   - its picture matches the golden screenshot beside this file (tests/client/golden/ID.png),
//     within the same tolerance. `--accept` writes the goldens instead (scripts/accept-client-goldens.sh).
// And the messages: an unknown scene, an unreachable server, a browser without WebGL2.
//
// Usage: node viewer_test.mjs SERVER_BINARY REPO_ROOT [--accept] [--only SCENE]
import { readFileSync, writeFileSync, existsSync } from 'node:fs';
import { join } from 'node:path';
import {
  Checks, comparePixels, decodePng, encodePng, launchBrowser, openViewer, startServer, waitIdle,
} from './browser_harness.mjs';

const PIXEL_TOLERANCE = 6;      // per channel, of 255
const PIXEL_SHARE = 0.99;       // pixels that must be within it
const DEPTH_TOLERANCE = 0.005;  // relative ray-distance difference at chosen pixels
const WIDTH = 64;
const HEIGHT = 40;

const [serverBinary, repoRoot, ...rest] = process.argv.slice(2);
const accept = rest.includes('--accept');
const only = rest.includes('--only') ? rest[rest.indexOf('--only') + 1] : null;
if (!serverBinary || !repoRoot) {
  console.error('usage: node viewer_test.mjs SERVER_BINARY REPO_ROOT [--accept] [--only SCENE]');
  process.exit(2);
}


const checks = new Checks();
const { port, stop } = await startServer(serverBinary, repoRoot);
const base = `http://127.0.0.1:${port}`;
const browser = await launchBrowser();
try {
  const scenes = (await (await fetch(`${base}/api/v1/scenes`)).json()).scenes.map((s) => s.id)
    .filter((id) => !only || id === only);
  checks.check(scenes.length > 0, `the server lists scenes (${scenes.join(', ')})`);
  for (const id of scenes) {
    const bundle = await (await fetch(`${base}/api/v1/scenes/${id}@1/trace.json`)).json();
    const { eye, target, fov } = bundle.camera;
    const cameraQuery = `eye=${eye.join(',')}&target=${target.join(',')}&fov=${fov}`;
    const { page, consoleErrors } = await openViewer(browser, `${base}/#scene=${id}&${cameraQuery}`, WIDTH, HEIGHT);
    const error = await waitIdle(page, 300000);
    checks.check(!error, `${id}: the viewer draws the scene${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    checks.check(frame.width === WIDTH && frame.height === HEIGHT, `${id}: a ${frame.width}×${frame.height} frame`);
    console.log(`     ${id}: frame ${frame.ms.toFixed(1)} ms under SwiftShader (${WIDTH}×${HEIGHT})`);

    const renderQuery = `${cameraQuery}&width=${WIDTH}&height=${HEIGHT}`;
    const png = await (await fetch(`${base}/api/v1/scenes/${id}@1/render.png?${renderQuery}`)).arrayBuffer();
    const reference = await decodePng(page, new Uint8Array(png));
    const vsServer = comparePixels(frame.rgba, reference.rgba, PIXEL_TOLERANCE);
    checks.check(vsServer.share >= PIXEL_SHARE,
      `${id}: matches the server's render.png on ${(vsServer.share * 100).toFixed(2)}% of pixels (worst ${vsServer.worst})`);

    const depthBytes = await (await fetch(`${base}/api/v1/scenes/${id}@1/depth.bin?${renderQuery}`)).arrayBuffer();
    const cpuDepth = new Float32Array(depthBytes);
    const chosen = [[WIDTH / 2, HEIGHT / 2], [WIDTH / 4, (3 * HEIGHT) / 4], [(3 * WIDTH) / 4, (2 * HEIGHT) / 3],
      [WIDTH / 8, HEIGHT - 4], [WIDTH - 8, HEIGHT / 2]].map(([x, y]) => [Math.floor(x), Math.floor(y)]);
    for (const [x, y] of chosen) {
      const cpu = cpuDepth[y * WIDTH + x];
      const gpu = frame.depth[y * WIDTH + x];
      const ok = (cpu < 0 && gpu < 0) || (cpu > 0 && Math.abs(gpu - cpu) <= DEPTH_TOLERANCE * cpu);
      checks.check(ok, `${id}: depth at (${x}, ${y}) ${gpu.toFixed(2)} m, the CPU tracer's ${cpu.toFixed(2)} m`);
    }

    const goldenPath = join(repoRoot, 'tests/client/golden', `${id}.png`);
    if (accept) {
      writeFileSync(goldenPath, await encodePng(page, frame.rgba, WIDTH, HEIGHT));
      console.log(`     wrote ${goldenPath}`);
    } else if (!existsSync(goldenPath)) {
      checks.check(false, `${id}: golden screenshot ${goldenPath} exists (run scripts/accept-client-goldens.sh)`);
    } else {
      const golden = await decodePng(page, readFileSync(goldenPath));
      const vsGolden = comparePixels(frame.rgba, golden.rgba, PIXEL_TOLERANCE);
      checks.check(vsGolden.share >= PIXEL_SHARE,
        `${id}: matches its golden screenshot on ${(vsGolden.share * 100).toFixed(2)}% of pixels (worst ${vsGolden.worst})`);
    }
    checks.check(consoleErrors.length === 0, `${id}: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  if (!only) {
    // An unknown scene: a message naming it, and no console error besides the failed fetch.
    const missing = await openViewer(browser, `${base}/#scene=no-such-scene`, WIDTH, HEIGHT);
    const message = await waitIdle(missing.page, 300000);
    checks.check(/no scene "no-such-scene"/.test(message ?? ''), `an unknown scene is named in a message (${message})`);
    await missing.page.close();

    // A server that went away: the page (served from a copy) says it cannot reach it.
    const unreachable = await browser.newPage();
    await unreachable.route('**/api/v1/**', (route) => route.abort('connectionrefused'));
    await unreachable.goto(`${base}/`);
    await unreachable.waitForFunction(() => window.terrainViewer?.state.error, null, { timeout: 30000 });
    const offline = await unreachable.evaluate(() => window.terrainViewer.state.error);
    checks.check(/unreachable/.test(offline), `an unreachable server is reported (${offline})`);
    await unreachable.close();

    // No WebGL2: the page says so instead of failing silently.
    const noGl = await browser.newPage();
    await noGl.addInitScript(() => {
      const original = HTMLCanvasElement.prototype.getContext;
      HTMLCanvasElement.prototype.getContext = function (kind, ...args) {
        return kind === 'webgl2' ? null : original.call(this, kind, ...args);
      };
    });
    await noGl.goto(`${base}/`);
    await noGl.waitForFunction(() => window.terrainViewer?.state.error, null, { timeout: 30000 });
    const noGlMessage = await noGl.evaluate(() => window.terrainViewer.state.error);
    checks.check(/WebGL2/.test(noGlMessage), `a browser without WebGL2 is told so (${noGlMessage})`);
    await noGl.close();

    // A driver that refuses the unrolled tracer (here: a bundle whose program_glsl does not
    // compile): the viewer traces the same picture with the pruned interpreter instead.
    const butte = (await (await fetch(`${base}/api/v1/scenes/butte@1/trace.json`)).json());
    const refused = await openViewer(browser, `${base}/#scene=butte&eye=${butte.camera.eye.join(',')}` +
      `&target=${butte.camera.target.join(',')}&fov=${butte.camera.fov}`, WIDTH, HEIGHT, {
      beforeLoad: (page) => page.route('**/trace.json', async (route) => {
        const bundle = await (await route.fetch()).json();
        route.fulfill({ json: { ...bundle, unroll_pays: true, program_glsl: 'Field evaluate_program(vec2 p0, float s0) { no_such_function(); }' } });
      }),
    });
    const refusedError = await waitIdle(refused.page, 300000);
    const fallback = await refused.page.evaluate(() => ({
      mode: window.terrainViewer.state.view.mode, frame: window.terrainViewer.capture(),
    }));
    const golden = await decodePng(refused.page, readFileSync(join(repoRoot, 'tests/client/golden/butte.png')));
    const vsFallback = comparePixels(fallback.frame.rgba, golden.rgba, PIXEL_TOLERANCE);
    checks.check(!refusedError && fallback.mode === 'pruned' && vsFallback.share >= PIXEL_SHARE &&
      refused.consoleErrors.length === 0,
    `a tracer that does not compile unrolled falls back to the interpreter (mode ${fallback.mode}, ` +
      `${(vsFallback.share * 100).toFixed(2)}% of pixels as the golden, errors: ${refusedError ?? 'none'} ${refused.consoleErrors.join(' | ')})`);
    await refused.page.close();
  }
} finally {
  await browser.close();
  stop();
}
console.log(checks.failures === 0 ? 'all browser checks passed' : `${checks.failures} browser checks.check(s) failed`);
process.exit(checks.failures === 0 ? 0 : 1);
