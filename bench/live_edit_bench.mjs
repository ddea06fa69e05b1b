// How long a live edit under an erosion node takes to reach a viewer (issue 19, item 4: a live
// edit of a 512² erosion scene reaches viewers in ≤ 1 s). Two WebSocket clients follow the
// scene's live channel (docs/live.md): an editor that changes the elevation of a disc inside the
// scene's first erosion node (so the erosion is baked again, and every tile of its support
// changes), and a read-only viewer. For each edit it measures, from the moment the editor sends
// it:
//   - version: the viewer receives the new version's `version` event;
//   - tile: the viewer then has the new version's local zoom-0 terrain-RGB tile (the whole
//     scene), and its bytes differ from the previous version's (checked, or the run fails).
// Edit k raises the disc by (k + 1) × step metres, so every edit is an input the server has
// never baked: no cache can answer it.
//
// Usage: node --experimental-websocket bench/live_edit_bench.mjs SERVER_BINARY
//          [--scene river-basin] [--edits 8] [--step 40]
// The server runs on its embedded defaults (SQLite in a temporary directory) with a write token.
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';
import { performance } from 'node:perf_hooks';
import { startServer } from '../tests/client/browser_harness.mjs';

const argv = process.argv.slice(2);
const option = (name, fallback) => {
  const i = argv.indexOf(name);
  return i >= 0 ? argv[i + 1] : fallback;
};
const serverBinary = argv[0];
if (!serverBinary || serverBinary.startsWith('--') || typeof WebSocket === 'undefined') {
  console.error('usage: node --experimental-websocket bench/live_edit_bench.mjs SERVER_BINARY ' +
    '[--scene S] [--edits N] [--step M]');
  process.exit(2);
}
const sceneId = option('--scene', 'river-basin');
const edits = Number(option('--edits', '8'));
const step = Number(option('--step', '40'));
const token = 'live-edit-bench';

/// The JSON pointer of the first `elevation` of a node inside the first erosion node, and its
/// value: the parameter the edits move.
function erosionInput(node, path) {
  if (node.type === 'erosion') {
    const inside = (n, p) => {
      if (typeof n.elevation === 'number' && n.type !== 'erosion') return { path: `${p}/elevation`, value: n.elevation };
      for (const [i, child] of (n.children ?? []).entries()) {
        const found = inside(child, `${p}/children/${i}`);
        if (found) return found;
      }
      return null;
    };
    return inside(node, path);
  }
  for (const [i, child] of (node.children ?? []).entries()) {
    const found = erosionInput(child, `${path}/children/${i}`);
    if (found) return found;
  }
  return null;
}

/// A live connection whose messages are awaited one type at a time.
function connect(url, subscribe) {
  return new Promise((resolve, reject) => {
    const socket = new WebSocket(url);
    const queue = [];
    const waiting = [];
    socket.onmessage = (e) => {
      const message = JSON.parse(e.data);
      const i = waiting.findIndex((w) => w.type === message.type);
      if (i >= 0) waiting.splice(i, 1)[0].resolve(message);
      else queue.push(message);
    };
    socket.onerror = () => reject(new Error(`WebSocket ${url} failed`));
    const next = (type, ms = 60000) => {
      const i = queue.findIndex((m) => m.type === type);
      if (i >= 0) return Promise.resolve(queue.splice(i, 1)[0]);
      return new Promise((res, rej) => {
        const timer = setTimeout(() => rej(new Error(`no ${type} within ${ms} ms`)), ms);
        waiting.push({ type, resolve: (m) => { clearTimeout(timer); res(m); } });
      });
    };
    socket.onopen = async () => {
      socket.send(JSON.stringify(subscribe));
      resolve({ socket, next, welcome: await next('welcome') });
    };
  });
}

const median = (values) => {
  const sorted = [...values].sort((a, b) => a - b);
  return sorted[Math.floor(sorted.length / 2)];
};

const repoRoot = join(dirname(fileURLToPath(import.meta.url)), '..');
const { port, stop } = await startServer(serverBinary, repoRoot, { writeToken: token });
const base = `http://127.0.0.1:${port}`;
const tileOf = async (version) => {
  const r = await fetch(`${base}/api/v1/scenes/${sceneId}@${version}/tiles/0/0/0.png?scheme=local`);
  if (r.status !== 200) throw new Error(`tile of version ${version}: HTTP ${r.status}`);
  return Buffer.from(await r.arrayBuffer());
};
let failed = false;
try {
  const scene = await (await fetch(`${base}/api/v1/scenes/${sceneId}`)).json();
  const target = erosionInput(scene.root, '/root');
  if (!target) throw new Error(`${sceneId} has no erosion node with an elevation inside`);
  const live = `ws://127.0.0.1:${port}/api/v1/scenes/${sceneId}/live`;
  const editor = await connect(live, { type: 'subscribe', token, name: 'bench' });
  const viewer = await connect(live, { type: 'subscribe' });
  let head = viewer.welcome.head;
  const bakeStart = performance.now();
  let previousTile = await tileOf(head);
  console.log(`${sceneId}: edits of ${target.path} (${target.value} m, raised by ${step} m an edit); first load of ` +
    `version ${head} (its bake) ${(performance.now() - bakeStart).toFixed(0)} ms`);
  console.log('| edit | version | version event at the viewer | new tile at the viewer |');
  console.log('|---|---|---|---|');
  const toVersion = [], toTile = [];
  for (let k = 0; k < edits; ++k) {
    const value = target.value + step * (k + 1);
    const t0 = performance.now();
    editor.socket.send(JSON.stringify({ type: 'edit', request: `e${k}`, base: head,
      ops: [{ op: 'replace', path: target.path, value }] }));
    const event = await viewer.next('version');
    const t1 = performance.now();
    const tile = await tileOf(event.version);
    const t2 = performance.now();
    const ack = await editor.next('ack');
    if (ack.version !== event.version) throw new Error(`ack ${ack.version}, event ${event.version}`);
    if (event.changed?.everything !== true && !event.changed?.box) {
      throw new Error(`version ${event.version} says nothing changed`);
    }
    if (tile.equals(previousTile)) throw new Error(`version ${event.version}'s tile is unchanged`);
    previousTile = tile;
    head = event.version;
    toVersion.push(t1 - t0);
    toTile.push(t2 - t0);
    console.log(`| ${k + 1} (${value} m) | ${event.version} | ${(t1 - t0).toFixed(0)} ms | ` +
      `${(t2 - t0).toFixed(0)} ms |`);
  }
  console.log(`\nmedian of ${edits}: version ${median(toVersion).toFixed(0)} ms, tile ${median(toTile).toFixed(0)} ms; ` +
    `slowest tile ${Math.max(...toTile).toFixed(0)} ms`);
  editor.socket.close();
  viewer.socket.close();
} catch (e) {
  console.error(`failed: ${e.message}`);
  failed = true;
} finally {
  stop();
}
process.exit(failed ? 1 : 0);
