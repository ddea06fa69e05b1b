// Browser test of live editing (docs/live.md; client_web/js/live.js, edit_mode.js) in Debian's
// headless Chromium (WebGL2 on SwiftShader), driven by playwright-core against the real
// terrain-server started with a write token. Two pages of the viewer follow one small scene:
//   - both show its version and hash, without console errors;
//   - page A turns the editing mode on through its UI; a wrong token is refused visibly and an
//     edit sent with it is rejected with the server's reason, changing nothing;
//   - with the right token, a click on the terrain picks the plateau there; a radius of -5 is
//     rejected with the reason shown, changing nothing;
//   - a new radius typed into A's panel makes a new version: page B shows it (the version and
//     the server's head hash, the author) and draws it (its pixels change);
//   - dragging the plateau on A's canvas moves it (a `replace` of its centre, the camera left
//     alone); B shows that version too; two quick edits of one field both land;
//   - the editing model places primitives through transforms and `ref` instances;
// and, with page C's WebSocket answered by the test itself, how the client handles the channel:
// a gap in the versions makes it resubscribe from the last version it has, a version it already
// has is ignored, and a dropped connection is resubscribed with `since` = its version.
//
// Usage: node live_test.mjs SERVER_BINARY REPO_ROOT
import {
  Checks, comparePixels, launchBrowser, openViewer, startServer, waitIdle,
} from './browser_harness.mjs';

const TOKEN = 'live-test-token';
const SCENE_ID = 'live-test';
// Two plateaus on flat ground: cheap to trace, and a radius change is plain to see.
const SCENE = {
  format: 'terrain-scene/1',
  name: 'Live editing test',
  extent: { min: [-1000, -1000], max: [1000, 1000] },
  root: { type: 'blend', children: [
    { type: 'disc', center: [-350, 0], radius: 450, elevation: 250 },
    { type: 'disc', center: [400, 250], radius: 350, elevation: 150 },
  ] },
};
const VIEW = `#scene=${SCENE_ID}&eye=0,-2000,1500&target=0,0,0&fov=50`;
const PIXEL_TOLERANCE = 6;
const TIMEOUT = 90000;

const [serverBinary, repoRoot] = process.argv.slice(2);
if (!serverBinary || !repoRoot) {
  console.error('usage: node live_test.mjs SERVER_BINARY REPO_ROOT');
  process.exit(2);
}

const started = Date.now();
const checks = new Checks();
const { port, stop } = await startServer(serverBinary, repoRoot, { writeToken: TOKEN });
const base = `http://127.0.0.1:${port}`;

/// The scene's head: version, hash (the ETag) and canonical JSON.
async function head() {
  const r = await fetch(`${base}/api/v1/scenes/${SCENE_ID}`);
  return { version: Number(r.headers.get('x-scene-version')), hash: JSON.parse(r.headers.get('etag')), doc: await r.json() };
}

/// What the page's live readout says: { text, version, hash }.
function shown(page) {
  return page.$eval('#live-status', (e) => ({ text: e.textContent, version: Number(e.dataset.version), hash: e.dataset.hash }));
}

/// Waits until the page shows `version` (with its hash) and has drawn it in full.
async function waitShown(page, version) {
  await page.waitForFunction((v) => {
    const status = document.getElementById('live-status');
    return status?.dataset.version === String(v) && status.dataset.hash && window.terrainViewer.idle;
  }, version, { timeout: TIMEOUT, polling: 50 });
}

async function waitText(page, selector, pattern) {
  await page.waitForFunction(([s, source]) => new RegExp(source).test(document.querySelector(s)?.textContent ?? ''),
    [selector, pattern.source], { timeout: TIMEOUT, polling: 50 });
  return page.$eval(selector, (e) => e.textContent);
}

/// Where a point of the scene (metres) is on the page, in CSS pixels, under its current camera.
function onScreen(page, point) {
  return page.evaluate(async (p) => {
    const { projectPoint } = await import('./js/camera.js');
    const canvas = document.getElementById('view');
    const at = projectPoint(window.terrainViewer.state.camera, p, canvas.width, canvas.height);
    return { x: (at.x * canvas.clientWidth) / canvas.width, y: (at.y * canvas.clientHeight) / canvas.height };
  }, point);
}

/// Waits until `condition()` (in this process) holds.
async function until(condition) {
  const end = Date.now() + TIMEOUT;
  while (!condition()) {
    if (Date.now() > end) throw new Error(`timed out waiting for ${condition}`);
    await new Promise((resolve) => setTimeout(resolve, 50));
  }
}

const capture = (page) => page.evaluate(() => window.terrainViewer.capture());

/// Types a value into one of A's number fields and commits it (Enter), then waits for the
/// status line to say how it went.
async function typeAndSend(page, selector, value) {
  const before = await page.$eval('#edit-status', (e) => e.textContent);
  await page.fill(selector, String(value));
  await page.press(selector, 'Enter');
  await page.waitForFunction((b) => {
    const s = document.getElementById('edit-status');
    return s.className !== 'pending' && s.textContent !== b && s.textContent !== '';
  }, before, { timeout: TIMEOUT, polling: 50 });
  return page.$eval('#edit-status', (e) => ({ text: e.textContent, kind: e.className }));
}

const created = await fetch(`${base}/api/v1/scenes?id=${SCENE_ID}`, {
  method: 'POST', headers: { Authorization: `Bearer ${TOKEN}`, 'Content-Type': 'application/json' },
  body: JSON.stringify(SCENE),
});
checks.check(created.status === 201, `the test scene is created (${created.status})`);

const browser = await launchBrowser();
try {
  // A: the editor, a page large enough for the panel, traced at an eighth of its pixels (80×60)
  // so SwiftShader keeps up. B: a viewer, 64×40.
  const a = await openViewer(browser, `${base}/${VIEW}`, 640, 480, { deviceScaleFactor: 0.125 });
  const b = await openViewer(browser, `${base}/${VIEW}`, 64, 40);
  for (const [name, p] of [['A', a], ['B', b]]) {
    const error = await waitIdle(p.page, TIMEOUT);
    checks.check(!error, `page ${name} draws the scene${error ? ` (${error})` : ''}`);
  }
  const first = await head();
  for (const [name, p] of [['A', a], ['B', b]]) {
    await waitShown(p.page, first.version);
    const s = await shown(p.page);
    checks.check(s.version === 1 && s.hash === first.hash, `page ${name} shows version ${s.version} (${s.text}), hash ${s.hash.slice(0, 15)}…`);
  }

  // Editing mode with a wrong token: refused at subscribe, and an edit is rejected.
  await a.page.click('#edit-toggle');
  checks.check(await a.page.isVisible('#edit-panel'), 'the Edit button opens the editing panel');
  await a.page.fill('#edit-token', 'not-the-token');
  await a.page.fill('#edit-name', 'alice');
  await a.page.click('#edit-credentials button[type=submit]');
  const refused = await waitText(a.page, '#edit-access', /refused/);
  checks.check(true, `a wrong token is refused visibly ("${refused}")`);
  await a.page.waitForFunction(() => document.querySelectorAll('#edit-primitive option').length === 2, null, { timeout: TIMEOUT });
  checks.check(true, 'the panel lists the scene\'s two primitives');

  // Pick the larger plateau with a click on its top.
  await waitIdle(a.page, TIMEOUT);
  const plateau = await onScreen(a.page, [-350, 0, 250]);
  await a.page.mouse.click(plateau.x, plateau.y);
  const pointer = await a.page.$eval('#edit-pointer', (e) => e.textContent);
  const radiusField = await a.page.$eval('#edit-radius', (e) => e.value);
  checks.check(pointer === '/root/children/0' && radiusField === '450',
    `a click on the plateau selects it (${pointer}, radius ${radiusField})`);

  const noToken = await typeAndSend(a.page, '#edit-radius', 300);
  checks.check(noToken.kind === 'error' && /401|403/.test(noToken.text), `an edit without an accepted token is rejected: "${noToken.text}"`);
  checks.check((await head()).version === 1, 'and changes nothing');

  // The right token.
  await a.page.fill('#edit-token', TOKEN);
  await a.page.click('#edit-credentials button[type=submit]');
  const access = await waitText(a.page, '#edit-access', /Editing as alice/);
  checks.check(true, `the right token is accepted ("${access}")`);

  const negative = await typeAndSend(a.page, '#edit-radius', -5);
  checks.check(negative.kind === 'error' && /400/.test(negative.text) && /radius/.test(negative.text),
    `a radius of -5 is rejected with the reason: "${negative.text}"`);
  checks.check((await head()).version === 1, 'and changes nothing');
  checks.check(await a.page.$eval('#edit-radius', (e) => e.value) === '450', 'the radius field shows the scene\'s radius again');

  // A smaller radius: a new version that B shows and draws.
  const bBefore = await capture(b.page);
  const editStart = Date.now();
  const resized = await typeAndSend(a.page, '#edit-radius', 200);
  checks.check(resized.kind === 'ok' && /version 2/.test(resized.text), `a radius of 200 is saved: "${resized.text}"`);
  const second = await head();
  checks.check(second.version === 2 && second.doc.root.children[0].radius === 200,
    `the server's head is version ${second.version} with radius ${second.doc.root.children[0].radius}`);
  await waitShown(b.page, 2);
  console.log(`     page B drew version 2 ${Date.now() - editStart} ms after the edit was typed`);
  const bShown = await shown(b.page);
  checks.check(bShown.hash === second.hash, `page B shows the head's hash ${bShown.hash.slice(0, 15)}… (${bShown.text})`);
  checks.check(/alice/.test(bShown.text), 'and its author');
  const bAfter = await capture(b.page);
  const change = comparePixels(bBefore.rgba, bAfter.rgba, PIXEL_TOLERANCE);
  checks.check(change.share < 0.99, `page B redrew: ${((1 - change.share) * 100).toFixed(1)}% of its pixels changed`);

  // Drag the plateau 60 CSS pixels to the right on A's canvas: its centre moves east.
  await waitShown(a.page, 2);
  await a.page.waitForFunction(() => document.getElementById('edit-radius').value === '200', null, { timeout: TIMEOUT });
  const cameraBefore = await a.page.evaluate(() => window.terrainViewer.state.camera.eye.join(','));
  const from = await onScreen(a.page, [-350, 0, 250]);
  await a.page.mouse.move(from.x, from.y);
  await a.page.mouse.down();
  await a.page.mouse.move(from.x + 30, from.y, { steps: 3 });
  await a.page.mouse.move(from.x + 60, from.y, { steps: 3 });
  await a.page.mouse.up();
  await a.page.waitForFunction(() => /version 3/.test(document.getElementById('edit-status').textContent), null, { timeout: TIMEOUT });
  const third = await head();
  const [cx, cy] = third.doc.root.children[0].center;
  checks.check(third.version === 3 && cx > -300 && Math.abs(cy) < 60,
    `dragging the plateau moves its centre from (-350, 0) to (${cx}, ${cy}) in version ${third.version}`);
  const cameraAfter = await a.page.evaluate(() => window.terrainViewer.state.camera.eye.join(','));
  checks.check(cameraAfter === cameraBefore, 'the drag moved the plateau, not the camera');
  await waitShown(b.page, 3);
  checks.check((await shown(b.page)).hash === third.hash, 'page B shows version 3 with the head\'s hash');

  // Two quick changes of one field: the second waits for the first and builds on it (sent at
  // once with the same base, the server would refuse it as a conflict).
  await a.page.fill('#edit-elevation', '260');
  await a.page.press('#edit-elevation', 'Enter');
  const twice = await typeAndSend(a.page, '#edit-elevation', 270);
  await a.page.waitForFunction(() => /version 5/.test(document.getElementById('edit-status').textContent), null, { timeout: TIMEOUT })
    .catch(() => {});
  const fifth = await head();
  checks.check(fifth.version === 5 && fifth.doc.root.children[0].elevation === 270,
    `two quick elevation edits make versions 4 and 5 (head ${fifth.version}, elevation ${fifth.doc.root.children[0].elevation}; "${twice.text}")`);
  await waitShown(b.page, 5);

  for (const [name, p] of [['A', a], ['B', b]]) {
    checks.check(p.consoleErrors.length === 0, `page ${name}: no console errors${p.consoleErrors.length ? `: ${p.consoleErrors.join(' | ')}` : ''}`);
  }

  // The editing model (js/scene_edit.js) through transforms and instancing, in the page.
  const model = await b.page.evaluate(async () => {
    const m = await import('./js/scene_edit.js');
    const doc = { definitions: { hill: { type: 'disc', center: [0, 0], radius: 30 } },
      root: { type: 'blend', children: [
        { type: 'transform', translate: [100, 0], rotate: 90, scale: [2, 2], children: [{ type: 'disc', center: [10, 0], radius: 50 }] },
        { type: 'transform', translate: [-500, 0], children: [{ ref: 'hill' }] },
        { type: 'transform', translate: [500, 0], children: [{ ref: 'hill' }] },
      ] } };
    const registry = await (await fetch('/api/v1/node-types')).json();
    const list = m.listPrimitives(doc, m.primitiveTypes(registry));
    return {
      pointers: list.map((p) => p.pointer),
      centres: list.map((p) => m.worldCentre(p).map((v) => Math.round(v * 1000) / 1000)),
      picks: [[100, 110], [510, 0], [0, 0]].map((q) => m.pickPrimitive(list, q)),
      move: m.moveOps(list[0], [0, 20]),
    };
  });
  checks.check(JSON.stringify(model.pointers) === JSON.stringify(['/root/children/0/children/0', '/definitions/hill', '/definitions/hill']) &&
    JSON.stringify(model.centres) === JSON.stringify([[100, 20], [-500, 0], [500, 0]]),
    `primitives are placed through transforms and per instance (${JSON.stringify(model.centres)})`);
  checks.check(JSON.stringify(model.picks) === JSON.stringify([0, 2, -1]), `picks inside supports only (${model.picks})`);
  checks.check(JSON.stringify(model.move[0].value) === JSON.stringify([20, 0]),
    `a drag north by 20 m under rotate 90°, scale 2 moves the centre by (10, 0) in its frame (${JSON.stringify(model.move[0].value)})`);
  await a.page.close();
  await b.page.close();

  // Page C's channel answered by the test: the versions it is sent are real (made here with
  // PUT), the order of events is ours.
  const put = async (radius) => {
    const doc = (await head()).doc;
    doc.root.children[1].radius = radius;
    const r = await fetch(`${base}/api/v1/scenes/${SCENE_ID}`, {
      method: 'PUT', headers: { Authorization: `Bearer ${TOKEN}`, 'Content-Type': 'application/json' },
      body: JSON.stringify(doc),
    });
    return r.json();
  };
  const subscribes = [];
  const sockets = [];
  const welcome = (version, hash) => JSON.stringify({ type: 'welcome', scene: SCENE_ID, head: version, hash, can_edit: false,
    limits: { max_message_bytes: 1048576, edits_per_second: 10, edit_burst: 20 } });
  const event = (v, previous, hash) => JSON.stringify({ type: 'version', scene: SCENE_ID, version: v, previous, hash,
    author: 'api', created_ms: Date.now(), ops: null, changed: { everything: true, box: null, formats: 'all' } });
  const now = await head();
  const n = now.version;
  let v4, v5;  // the PUT answers of versions n + 1 and n + 2
  const c = await openViewer(browser, `${base}/${VIEW}`, 64, 40, {
    beforeLoad: (page) => page.routeWebSocket(/\/live$/, (ws) => {
      sockets.push(ws);
      ws.onMessage((text) => {
        const m = JSON.parse(text);
        if (m.type !== 'subscribe') return;
        subscribes.push(m.since);
        if (subscribes.length === 1) {
          ws.send(welcome(n, now.hash));
        } else if (subscribes.length === 2) {
          // The catch-up after the gap, then a version it already has.
          ws.send(welcome(n + 2, v5.hash));
          ws.send(event(n + 1, n, v4.hash));
          ws.send(event(n + 2, n + 1, v5.hash));
          ws.send(event(n + 1, n, v4.hash));
        } else {
          ws.send(welcome(n + 2, v5.hash));
        }
      });
    }),
  });
  await waitShown(c.page, n);
  v4 = await put(300);
  v5 = await put(250);
  sockets[0].send(event(n + 2, n + 1, v5.hash));  // version n + 1 went missing
  await waitShown(c.page, n + 2);
  checks.check(subscribes[0] === n && subscribes[1] === n,
    `page C subscribed with since ${subscribes[0]}, and after a gap (${n + 1} missing) again with since ${subscribes[1]}`);
  checks.check((await shown(c.page)).hash === v5.hash, `page C caught up to version ${n + 2}, the head`);
  sockets[1].close({ code: 1001, reason: 'going away' });
  await until(() => subscribes.length >= 3);
  checks.check(subscribes.length === 3 && subscribes[2] === n + 2, `a dropped connection is resubscribed with since ${subscribes[2]}`);
  await c.page.waitForFunction((v) => document.getElementById('live-status').textContent === `v${v} · api`, n + 2, { timeout: TIMEOUT });
  checks.check(c.consoleErrors.length === 0, `page C: no console errors${c.consoleErrors.length ? `: ${c.consoleErrors.join(' | ')}` : ''}`);
  await c.page.close();
} finally {
  await browser.close();
  stop();
}
console.log(`     ${((Date.now() - started) / 1000).toFixed(1)} s in all`);
console.log(checks.failures === 0 ? 'all live editing checks passed' : `${checks.failures} live editing check(s) failed`);
process.exit(checks.failures === 0 ? 0 : 1);
