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
import { spawn } from 'node:child_process';
import { mkdtempSync, readFileSync, rmSync, writeFileSync, existsSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

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

let failures = 0;
function check(ok, what) {
  console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
  if (!ok) failures += 1;
}

async function startServer() {
  const data = mkdtempSync(join(tmpdir(), 'viewer-test-'));
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
  return { server, port, stop: () => { server.kill('SIGTERM'); rmSync(data, { recursive: true, force: true }); } };
}

async function openViewer(browser, url) {
  const page = await browser.newPage({ viewport: { width: WIDTH, height: HEIGHT }, deviceScaleFactor: 1 });
  const consoleErrors = [];
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  await page.goto(url);
  return { page, consoleErrors };
}

async function waitIdle(page) {
  await page.waitForFunction(() => window.terrainViewer &&
    ((window.terrainViewer.idle && window.terrainViewer.drawn > 0) || window.terrainViewer.state.error),
    null, { timeout: 300000, polling: 100 });
  return page.evaluate(() => window.terrainViewer.state.error);
}

// RGBA bytes, top row first, of a PNG decoded by the browser.
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
try {
  const scenes = (await (await fetch(`${base}/api/v1/scenes`)).json()).scenes.map((s) => s.id)
    .filter((id) => !only || id === only);
  check(scenes.length > 0, `the server lists scenes (${scenes.join(', ')})`);
  for (const id of scenes) {
    const bundle = await (await fetch(`${base}/api/v1/scenes/${id}@1/trace.json`)).json();
    const { eye, target, fov } = bundle.camera;
    const cameraQuery = `eye=${eye.join(',')}&target=${target.join(',')}&fov=${fov}`;
    const { page, consoleErrors } = await openViewer(browser, `${base}/#scene=${id}&${cameraQuery}`);
    const error = await waitIdle(page);
    check(!error, `${id}: the viewer draws the scene${error ? ` (${error})` : ''}`);
    const frame = await page.evaluate(() => window.terrainViewer.capture());
    check(frame.width === WIDTH && frame.height === HEIGHT, `${id}: a ${frame.width}×${frame.height} frame`);
    console.log(`     ${id}: frame ${frame.ms.toFixed(1)} ms under SwiftShader (${WIDTH}×${HEIGHT})`);

    const renderQuery = `${cameraQuery}&width=${WIDTH}&height=${HEIGHT}`;
    const png = await (await fetch(`${base}/api/v1/scenes/${id}@1/render.png?${renderQuery}`)).arrayBuffer();
    const reference = await decodePng(page, new Uint8Array(png));
    const vsServer = compare(frame.rgba, reference.rgba);
    check(vsServer.share >= PIXEL_SHARE,
      `${id}: matches the server's render.png on ${(vsServer.share * 100).toFixed(2)}% of pixels (worst ${vsServer.worst})`);

    const depthBytes = await (await fetch(`${base}/api/v1/scenes/${id}@1/depth.bin?${renderQuery}`)).arrayBuffer();
    const cpuDepth = new Float32Array(depthBytes);
    const chosen = [[WIDTH / 2, HEIGHT / 2], [WIDTH / 4, (3 * HEIGHT) / 4], [(3 * WIDTH) / 4, (2 * HEIGHT) / 3],
      [WIDTH / 8, HEIGHT - 4], [WIDTH - 8, HEIGHT / 2]].map(([x, y]) => [Math.floor(x), Math.floor(y)]);
    for (const [x, y] of chosen) {
      const cpu = cpuDepth[y * WIDTH + x];
      const gpu = frame.depth[y * WIDTH + x];
      const ok = (cpu < 0 && gpu < 0) || (cpu > 0 && Math.abs(gpu - cpu) <= DEPTH_TOLERANCE * cpu);
      check(ok, `${id}: depth at (${x}, ${y}) ${gpu.toFixed(2)} m, the CPU tracer's ${cpu.toFixed(2)} m`);
    }

    const goldenPath = join(repoRoot, 'tests/client/golden', `${id}.png`);
    if (accept) {
      writeFileSync(goldenPath, await encodePng(page, frame.rgba, WIDTH, HEIGHT));
      console.log(`     wrote ${goldenPath}`);
    } else if (!existsSync(goldenPath)) {
      check(false, `${id}: golden screenshot ${goldenPath} exists (run scripts/accept-client-goldens.sh)`);
    } else {
      const golden = await decodePng(page, readFileSync(goldenPath));
      const vsGolden = compare(frame.rgba, golden.rgba);
      check(vsGolden.share >= PIXEL_SHARE,
        `${id}: matches its golden screenshot on ${(vsGolden.share * 100).toFixed(2)}% of pixels (worst ${vsGolden.worst})`);
    }
    check(consoleErrors.length === 0, `${id}: no console errors${consoleErrors.length ? `: ${consoleErrors.join(' | ')}` : ''}`);
    await page.close();
  }

  if (!only) {
    // An unknown scene: a message naming it, and no console error besides the failed fetch.
    const missing = await openViewer(browser, `${base}/#scene=no-such-scene`);
    const message = await waitIdle(missing.page);
    check(/no scene "no-such-scene"/.test(message ?? ''), `an unknown scene is named in a message (${message})`);
    await missing.page.close();

    // A server that went away: the page (served from a copy) says it cannot reach it.
    const unreachable = await browser.newPage();
    await unreachable.route('**/api/v1/**', (route) => route.abort('connectionrefused'));
    await unreachable.goto(`${base}/`);
    await unreachable.waitForFunction(() => window.terrainViewer?.state.error, null, { timeout: 30000 });
    const offline = await unreachable.evaluate(() => window.terrainViewer.state.error);
    check(/unreachable/.test(offline), `an unreachable server is reported (${offline})`);
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
    check(/WebGL2/.test(noGlMessage), `a browser without WebGL2 is told so (${noGlMessage})`);
    await noGl.close();
  }
} finally {
  await browser.close();
  stop();
}
console.log(failures === 0 ? 'all browser checks passed' : `${failures} browser check(s) failed`);
process.exit(failures === 0 ? 0 : 1);
