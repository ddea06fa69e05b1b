// What the browser tests share: the real terrain-server on a loopback port, Debian's headless
// Chromium (WebGL2 on SwiftShader) through playwright-core, pages of the viewer, PNG round trips
// through the browser and pixel comparison.
import { spawn } from 'node:child_process';
import { mkdtempSync, rmSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { join } from 'node:path';
import { chromium } from 'playwright-core';

/// Counts failed checks; each check prints one line.
export class Checks {
  failures = 0;
  check(ok, what) {
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${what}`);
    if (!ok) this.failures += 1;
  }
}

/// Starts terrain-server on a free port with an empty data directory, serving client_web/.
/// `writeToken` turns writes (POST, PUT, live edits) on with that bearer token; `corsOrigins`
/// lets pages of those origins read the API.
export async function startServer(serverBinary, repoRoot, { writeToken = '', corsOrigins = '' } = {}) {
  const data = mkdtempSync(join(tmpdir(), 'browser-test-'));
  const flags = writeToken ? ['--write-token', writeToken] : [];
  if (corsOrigins) flags.push('--cors-origins', corsOrigins);
  const server = spawn(serverBinary, ['--config', '/dev/null', '--port', '0', '--data-dir', data,
    '--client-dir', join(repoRoot, 'client_web'), '--log-level', 'warn', ...flags], { cwd: repoRoot });
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

/// Debian's Chromium, headless; WebGL2 on SwiftShader unless `args` says otherwise (a machine
/// with a GPU: bench/browser_frames.mjs --browser-arg).
export function launchBrowser(args = ['--use-angle=swiftshader', '--enable-unsafe-swiftshader']) {
  return chromium.launch({
    executablePath: '/usr/bin/chromium',
    args: [...args, '--no-sandbox', '--disable-gpu-sandbox'],
  });
}

/// A page of the viewer at `url`, width × height CSS pixels at one device pixel each (or
/// `deviceScaleFactor`: below 1 a large page traces few pixels), collecting console errors.
/// `beforeLoad(page)` runs before the page opens (routes, init scripts).
export async function openViewer(browser, url, width, height, { deviceScaleFactor = 1, beforeLoad } = {}) {
  const page = await browser.newPage({ viewport: { width, height }, deviceScaleFactor });
  const consoleErrors = [];
  page.on('console', (m) => { if (m.type() === 'error') consoleErrors.push(m.text()); });
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  if (beforeLoad) await beforeLoad(page);
  const start = Date.now();
  await page.goto(url);
  return { page, consoleErrors, start };
}

/// Waits until the viewer has drawn its view in full, or shows an error; returns the error.
export async function waitIdle(page, timeout) {
  await page.waitForFunction(() => window.terrainViewer &&
    ((window.terrainViewer.idle && window.terrainViewer.drawn > 0) || window.terrainViewer.state.error),
    null, { timeout, polling: 50 });
  return page.evaluate(() => window.terrainViewer.state.error);
}

/// RGBA bytes, top row first, of a PNG decoded by the browser.
export async function decodePng(page, bytes) {
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

export async function encodePng(page, rgba, width, height) {
  const b64 = await page.evaluate(({ data, w, h }) => {
    const c = document.createElement('canvas');
    c.width = w;
    c.height = h;
    c.getContext('2d').putImageData(new ImageData(new Uint8ClampedArray(data), w, h), 0, 0);
    return c.toDataURL('image/png').split(',')[1];
  }, { data: rgba, w: width, h: height });
  return Buffer.from(b64, 'base64');
}

/// The share of pixels whose RGB channels are all within `tolerance`, and the largest difference.
export function comparePixels(a, b, tolerance) {
  let within = 0;
  let worst = 0;
  const n = a.length / 4;
  for (let i = 0; i < n; ++i) {
    let d = 0;
    for (let c = 0; c < 3; ++c) d = Math.max(d, Math.abs(a[4 * i + c] - b[4 * i + c]));
    worst = Math.max(worst, d);
    if (d <= tolerance) within += 1;
  }
  return { share: within / n, worst };
}
