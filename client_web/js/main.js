// The browser viewer: picks a scene, fetches its compiled program and sphere-traces it locally
// (scene_view.js), with orbit/fly controls, a frame-time readout and the view in the URL; or
// picks a planet and streams its quantized-mesh tiles (planet_view.js) under a globe camera.
// In scene mode it follows the scene's live channel (live.js): every new version, whoever made
// it, is fetched and drawn under the same camera, and the editing mode (edit_mode.js) sends
// edits over the same channel.
import { ApiError, fetchJson, fetchText } from './api.js';
import { Camera, projectPoint, rayThrough, readViewFromHash, writeViewToHash } from './camera.js';
import { Controls } from './controls.js';
import { EditMode } from './edit_mode.js';
import { LiveChannel } from './live.js';
import { SceneView } from './scene_view.js';
import { PlanetView } from './planet_view.js';
import { GlobeCamera, GlobeControls, readPlanetHash, writePlanetHash } from './planet_camera.js';

const canvas = document.getElementById('view');
const picker = document.getElementById('scene-picker');
const modeButton = document.getElementById('mode');
const resetButton = document.getElementById('reset');
const shareLink = document.getElementById('share');
const frameTime = document.getElementById('frame-time');
const messageBox = document.getElementById('message');
const helpLine = document.getElementById('help');
const editToggle = document.getElementById('edit-toggle');
const liveStatus = document.getElementById('live-status');
const SCENE_HELP = helpLine.textContent;
const PLANET_HELP = 'Drag to move the globe · right-drag or shift-drag to turn and tilt · wheel or pinch to zoom · ' +
  'arrows / WASD move, Q E turn, R F tilt, + − zoom';
const PLANET_PREFIX = 'planet:';  // picker values of planets

// A planet's picker label: its id's start, and its relief model where it is not the default.
function planetLabel(planet) {
  const model = planet.definition?.relief_model;
  return `planet ${planet.id.slice(0, 12)}${model ? ` (${model} relief)` : ''}`;
}
// How the tracer evaluates programs (SceneView.create): `?glsl=pruned`, `unrolled` or
// `interpreter` in the page's address compares the modes on a given GPU; the default is
// 'automatic'.
const SHADER_MODE = (() => {
  const asked = new URLSearchParams(location.search).get('glsl');
  return ['automatic', 'pruned', 'unrolled', 'interpreter'].includes(asked) ? asked : 'automatic';
})();

const state = {
  gl: null,
  glsl: null,      // the shared GLSL, fetched once
  sceneId: null,
  bundle: null,    // the scene's trace bundle (program, bounds, setup, default camera)
  liveId: null,    // the scene's own id (the bundle's scene_id: "default" may alias it)
  shown: null,     // the version drawn: { version, hash, author }
  versions: new Map(),  // version -> { hash, author, created_ms } from the live channel
  newest: null,    // the newest version the live channel announced
  live: null,      // LiveChannel of the scene shown
  liveState: 'connecting',
  versionLoads: new Map(),  // version -> AbortController of its trace bundle's fetch
  view: null,      // SceneView
  camera: null,
  controls: null,
  dirty: true,
  moving: false,   // previews at reduced resolution while the camera moves
  lastMove: 0,
  resolution: 0.5, // fraction of device pixels a preview traces, adapted to frame time
  band: null,      // the full-resolution view being drawn: next row, rows per band, time so far
  bandRows: 0,
  loading: null,
  error: null,
  // Planet mode, when state.planet is set: { id, view: PlanetView, camera: GlobeCamera,
  // controls: GlobeControls }; the scene fields above are then empty.
  planet: null,
  planets: [],     // GET /api/v1/planets: the list and which id "default" stands for
};

// Tests and scripts: whether the viewer is idle (a full-resolution frame of the current view is
// on the canvas), and the state behind it.
window.terrainViewer = {
  state,
  idle: false,
  drawn: 0,
  /// The current view traced (scene) or drawn (planet) at the canvas size:
  /// { width, height, rgba, depth, ms }.
  capture: () => (state.planet ?
    state.planet.view.capture(state.planet.camera, canvas.width, canvas.height) :
    state.view.capture(state.camera, canvas.width, canvas.height)),
};

function showMessage(text) {
  messageBox.textContent = text;
  messageBox.hidden = !text;
  state.error = text || null;
}

function viewUrl() {
  if (state.planet) return writePlanetHash(state.planet.id, state.planet.camera);
  return writeViewToHash({ scene: state.sceneId, camera: state.camera, mode: state.controls?.mode });
}

let hashTimer = 0;
function updateHash() {
  clearTimeout(hashTimer);
  hashTimer = setTimeout(() => {
    const hash = viewUrl();
    if (location.hash !== hash) history.replaceState(null, '', hash);
    shareLink.href = hash;
  }, 250);
}

function markDirty(reason) {
  state.dirty = true;
  window.terrainViewer.idle = false;
  if (reason === 'camera' || reason === 'keys') {
    state.moving = true;
    state.lastMove = performance.now();
  }
  if (reason === 'mode' && state.controls) modeButton.textContent = state.controls.mode === 'fly' ? 'Fly' : 'Orbit';
  updateHash();
}

async function loadScene(id, camera) {
  const token = Symbol(id);
  state.loading = token;
  showMessage('');
  try {
    const bundle = await fetchJson(`/api/v1/scenes/${encodeURIComponent(id)}/trace.json`);
    if (state.loading !== token) return;
    const view = SceneView.create(state.gl, state.glsl, bundle, SHADER_MODE);
    leavePlanetMode();
    state.view?.dispose();
    state.view = view;
    state.bundle = bundle;
    state.sceneId = id;
    state.camera = camera ?? new Camera(bundle.camera);
    state.controls.setCamera(state.camera);
    picker.value = id;
    followLive(bundle.scene_id ?? id, bundle.version);
    markDirty('scene');
  } catch (e) {
    if (state.loading !== token) return;
    const why = e instanceof ApiError && e.status === 404 ? `There is no scene "${id}".` :
      e instanceof ApiError && e.status >= 400 && e.status < 500 ? `The scene "${id}" is invalid: ${e.message}` :
      e.message;
    showMessage(why);
  } finally {
    if (state.loading === token) state.loading = null;
  }
}

// ---- Live updates ----------------------------------------------------------------------------

/// Follows `sceneId`'s live channel from `version` (the one drawn) on.
function followLive(sceneId, version) {
  stopLive();
  state.liveId = sceneId;
  state.shown = { version, hash: null, author: null };
  state.newest = version;
  const live = new LiveChannel(sceneId, { since: version, ...editMode.credentials() });
  state.live = live;
  live.addEventListener('status', (e) => {
    state.liveState = e.detail.state;
    showLiveStatus();
    editMode.showAccess();
  });
  live.addEventListener('welcome', (e) => {
    const w = e.detail;
    if (w.head === state.shown?.version && !state.shown.hash) state.shown.hash = w.hash;
    showLiveStatus();
    editMode.showAccess();
  });
  live.addEventListener('version', (e) => {
    const v = e.detail;
    state.versions.set(v.version, { hash: v.hash, author: v.author, created_ms: v.created_ms });
    state.newest = Math.max(state.newest ?? 0, v.version);
    showLiveStatus();
    loadVersion(v.version);
    editMode.follow();
  });
  live.addEventListener('refused', () => editMode.showAccess());
  // The server no longer has the version shown (a new store): start again from its head.
  live.addEventListener('reset', () => {
    if (state.live === live && state.sceneId) loadScene(state.sceneId, state.camera);
  });
  live.addEventListener('error', (e) => editMode.setStatus(`The server refused a message: ${e.detail.detail || e.detail.title}`, 'error'));
  editMode.reset();
  liveStatus.hidden = false;
  showLiveStatus();
}

function stopLive() {
  state.live?.close();
  state.live = null;
  state.liveId = null;
  state.shown = null;
  state.newest = null;
  state.versions.clear();
  for (const controller of state.versionLoads.values()) controller.abort();
  state.versionLoads.clear();
  liveStatus.hidden = true;
}

let versionError = null;  // the message of a version that could not be drawn, until one is

/// Fetches and draws version `version` (pinned, so cached for good) under the current camera.
/// Versions only go forwards: a fetch for an older one than drawn is aborted or dropped.
async function loadVersion(version) {
  const scene = state.liveId;
  if (!scene || version <= state.shown.version || state.versionLoads.has(version)) return;
  const controller = new AbortController();
  state.versionLoads.set(version, controller);
  try {
    const bundle = await fetchJson(`/api/v1/scenes/${encodeURIComponent(scene)}@${version}/trace.json`,
      { signal: controller.signal });
    if (state.liveId !== scene || !state.view || version <= state.shown.version) return;
    if (!state.view.replaceBundle(bundle)) {
      const view = SceneView.create(state.gl, state.glsl, bundle, SHADER_MODE);
      state.view.dispose();
      state.view = view;
    }
    state.bundle = bundle;
    const info = state.versions.get(version) ?? {};
    state.shown = { version, hash: info.hash ?? null, author: info.author ?? null };
    if (versionError && state.error === versionError) showMessage('');
    versionError = null;
    // What was on its way for older versions is of no use now.
    for (const [v, c] of state.versionLoads) {
      if (v < version) {
        c.abort();
        state.versionLoads.delete(v);
      }
    }
    markDirty('version');
  } catch (e) {
    if (e.name === 'AbortError' || state.liveId !== scene) return;
    versionError = `Version ${version} of "${scene}" could not be drawn: ${e.message}`;
    showMessage(versionError);
  } finally {
    if (state.versionLoads.get(version) === controller) state.versionLoads.delete(version);
    showLiveStatus();
  }
}

// The discreet readout of the version drawn (its author when a live event named one) and of the
// channel: "v7 · alice", "v7 · loading v8", "v7 · offline".
function showLiveStatus() {
  const shown = state.shown;
  if (!shown) return;
  const parts = [`v${shown.version}`];
  if (shown.author) parts.push(shown.author);
  if (state.newest > shown.version) parts.push(`loading v${state.newest}`);
  const offline = state.liveState === 'waiting';
  if (offline) parts.push('offline, reconnecting');
  else if (state.liveState === 'connecting') parts.push('connecting');
  liveStatus.textContent = parts.join(' · ');
  liveStatus.classList.toggle('offline', offline);
  liveStatus.dataset.version = String(shown.version);
  liveStatus.dataset.hash = shown.hash ?? '';
  const when = state.versions.get(shown.version)?.created_ms;
  liveStatus.title = `Version ${shown.version}${shown.author ? ` by ${shown.author}` : ''}` +
    `${when ? `, ${new Date(when).toLocaleString()}` : ''}${shown.hash ? `\n${shown.hash}` : ''}` +
    (offline ? '\nThe live channel is reconnecting; changes made meanwhile will follow.' : '\nLive: others’ edits appear here.');
}

// ---- Editing ---------------------------------------------------------------------------------

// Canvas pixels (CSS) to the device pixels the tracer draws.
function devicePoint(x, y) {
  return [(x * canvas.width) / Math.max(canvas.clientWidth, 1), (y * canvas.height) / Math.max(canvas.clientHeight, 1)];
}

/// Where the ray through canvas point (x, y) (CSS pixels) meets the level z, or null.
function planeAt(x, y, z) {
  if (!state.camera) return null;
  const { origin, direction } = rayThrough(state.camera, ...devicePoint(x, y), canvas.width, canvas.height);
  if (Math.abs(direction[2]) < 1e-9) return null;
  const t = (z - origin[2]) / direction[2];
  return t > 0 ? [origin[0] + t * direction[0], origin[1] + t * direction[1], z] : null;
}

const editMode = new EditMode(canvas, {
  sceneId: () => state.liveId,
  version: () => state.newest,
  live: () => state.live,
  // The ground under canvas point (x, y): the traced distance of the picture on the canvas;
  // while no picture shows the current camera, the middle of the scene's height range.
  groundAt: (x, y) => {
    if (!state.view || !state.camera) return null;
    const [dx, dy] = devicePoint(x, y);
    const depth = state.view.depthAt(state.camera, dx, dy, canvas.width, canvas.height);
    if (depth === null) return planeAt(x, y, editModeElevationHint());
    if (!(depth > 0)) return null;  // sky
    const { origin, direction } = rayThrough(state.camera, dx, dy, canvas.width, canvas.height);
    return [0, 1, 2].map((k) => origin[k] + depth * direction[k]);
  },
  planeAt,
  project: (point) => {
    if (!state.camera) return null;
    const at = projectPoint(state.camera, point, canvas.width, canvas.height);
    if (!at) return null;
    const r = canvas.getBoundingClientRect();
    return { x: r.left + (at.x * canvas.clientWidth) / canvas.width, y: r.top + (at.y * canvas.clientHeight) / canvas.height };
  },
  elevationHint: editModeElevationHint,
  onCredentials: () => state.live?.setCredentials(editMode.credentials()),
});

function editModeElevationHint() {
  const e = state.bundle?.setup?.elevation;
  return e ? (e[0] + e[1]) / 2 : 0;
}

// Scene mode's orbit/fly controls; planet mode replaces them with GlobeControls (both listen to
// the same canvas, so only one set exists at a time).
function makeSceneControls(mode = 'orbit') {
  const controls = new Controls(canvas, state.camera, {
    onChange: markDirty,
    scaleHint: () => {
      const a = state.bundle?.setup?.area;
      return a ? Math.max(a[2] - a[0], a[3] - a[1]) : 1000;
    },
  });
  if (mode === 'fly') controls.mode = 'fly';
  return controls;
}

function leavePlanetMode() {
  if (!state.planet) return;
  state.planet.controls.dispose();
  state.planet.view.dispose();
  state.planet = null;
  modeButton.hidden = false;
  editToggle.hidden = false;
  helpLine.textContent = SCENE_HELP;
  if (!state.controls) state.controls = makeSceneControls();
}

/// The view a planet opens with: the whole globe, from two radii above the ground.
function defaultGlobeCamera(view) {
  return new GlobeCamera({ lat: 15, lon: 20, alt: 2 * view.radius, heading: 0, tilt: 0 });
}

function pickerValueOfPlanet(id) {
  const value = PLANET_PREFIX + id;
  if (![...picker.options].some((o) => o.value === value)) {
    const option = document.createElement('option');
    option.value = value;
    option.textContent = `planet ${id.slice(0, 12)}`;
    (picker.querySelector('optgroup[label="Planets"]') ?? picker).append(option);
  }
  return value;
}

async function loadPlanet(id, camera) {
  const token = Symbol(id);
  state.loading = token;
  showMessage('');
  try {
    const view = await PlanetView.open(state.gl, id);
    if (state.loading !== token) {
      view.dispose();
      return;
    }
    leavePlanetMode();
    stopLive();
    if (editMode.enabled) editMode.setEnabled(false);
    editToggle.hidden = true;
    state.view?.dispose();
    state.view = null;
    state.bundle = null;
    state.sceneId = null;
    state.camera = null;
    state.controls?.dispose();
    state.controls = null;
    const planet = { id, view, camera: camera ?? defaultGlobeCamera(view), controls: null };
    planet.controls = new GlobeControls(canvas, planet.camera, {
      onChange: markDirty,
      radius: view.radius,
      ground: (c) => view.heightAt(c.lat, c.lon),
    });
    state.planet = planet;
    picker.value = pickerValueOfPlanet(id);
    modeButton.hidden = true;
    helpLine.textContent = PLANET_HELP;
    markDirty('scene');
  } catch (e) {
    if (state.loading !== token) return;
    showMessage(e.message);
  } finally {
    if (state.loading === token) state.loading = null;
  }
}

// Planet mode's frame: draws whenever the camera moved or a tile arrived. Every draw selects
// the tiles, requests the missing ones and draws the best loaded stand-ins, so a frame is
// cheap; the viewer is idle once a draw found every tile it needed.
let tileError = null;
function planetFrame(dt) {
  const p = state.planet;
  if (p.controls.update(dt)) markDirty('keys');
  resize();
  if (p.view.takeArrived()) {
    state.dirty = true;
    // Finer tiles may show ground above the camera: lift it.
    if (p.controls.clamp()) updateHash();
  }
  if (!state.dirty) return;
  state.dirty = false;
  const s = p.view.draw(p.camera, canvas.width, canvas.height);
  frameTime.textContent = `${s.ms.toFixed(1)} ms · ${s.tiles} tiles · ${Math.round(s.triangles / 1000)}k triangles` +
    (s.complete ? '' : ` · loading ${s.loading}`);
  if (p.view.error) {
    tileError = p.view.error;
    showMessage(tileError);
  } else if (tileError && state.error === tileError) {
    tileError = null;
    showMessage('');
  }
  window.terrainViewer.idle = s.complete;
  if (s.complete) window.terrainViewer.drawn += 1;
}

function resize() {
  const dpr = Math.min(window.devicePixelRatio || 1, 2);
  const width = Math.max(1, Math.round(canvas.clientWidth * dpr));
  const height = Math.max(1, Math.round(canvas.clientHeight * dpr));
  if (canvas.width !== width || canvas.height !== height) {
    canvas.width = width;
    canvas.height = height;
    state.dirty = true;
  }
}

// Drawing: while the camera moves, whole previews at a resolution that keeps about 30 frames a
// second; once it rests, the full-resolution view in bands of rows sized to about 30 ms each.
const FRAME_BUDGET_MS = 30;
let previous = performance.now();
function frame(now) {
  requestAnimationFrame(frame);
  const dt = Math.min((now - previous) / 1000, 0.1);
  previous = now;
  if (state.planet) {
    planetFrame(dt);
    return;
  }
  if (!state.view || !state.camera) return;
  if (state.controls.update(dt)) markDirty('keys');
  resize();
  if (editMode.enabled) editMode.updateMarker();
  if (state.moving && now - state.lastMove > 200) state.moving = false;
  const { width, height } = canvas;
  if (state.dirty) {
    state.dirty = false;
    state.band = null;
    const fraction = state.moving ? state.resolution : Math.min(state.resolution, 0.25);
    const ms = state.view.preview(state.camera, width, height, fraction);
    if (state.moving) {
      state.resolution = Math.min(1, Math.max(0.1, state.resolution * Math.sqrt(FRAME_BUDGET_MS / Math.max(ms, 1))));
    }
    frameTime.textContent = `${ms.toFixed(1)} ms at ${Math.round(fraction * 100)}%`;
    if (!state.moving) state.band = { top: 0, rows: state.bandRows || 8, ms: 0, camera: state.camera.clone() };
    return;
  }
  const band = state.band;
  if (!band || state.moving) return;
  const bottom = Math.min(height, band.top + band.rows);
  const ms = state.view.drawBand(band.camera, width, height, band.top, bottom);
  band.ms += ms;
  // Rows per band follow the measured cost per row.
  state.bandRows = band.rows = Math.max(1, Math.min(height, Math.round((band.rows * FRAME_BUDGET_MS) / Math.max(ms, 0.5))));
  band.top = bottom;
  if (band.top < height) {
    frameTime.textContent = `refining ${Math.round((100 * band.top) / height)}%`;
    return;
  }
  state.band = null;
  state.view.fullFrameMs = band.ms;
  frameTime.textContent = `${band.ms.toFixed(0)} ms per full frame (${width}×${height})`;
  window.terrainViewer.idle = true;
  window.terrainViewer.drawn += 1;
}

async function start() {
  const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true });
  if (!gl) {
    showMessage('This browser has no WebGL2, which the viewer needs to draw terrain. ' +
      'Try a current Firefox, Chrome, Edge or Safari, with hardware acceleration on.');
    return;
  }
  state.gl = gl;
  canvas.addEventListener('webglcontextlost', (e) => {
    e.preventDefault();
    showMessage('The graphics context was lost; reload the page to continue.');
  });
  let scenes, planets;
  try {
    [scenes, state.glsl, planets] = await Promise.all([
      fetchJson('/api/v1/scenes'),
      fetchText('/api/v1/glsl/trace.glsl'),
      fetchJson('/api/v1/planets'),
    ]);
  } catch (e) {
    showMessage(e.message);
    return;
  }
  const list = Array.isArray(scenes.scenes) ? scenes.scenes : [];
  for (const s of list) {
    const option = document.createElement('option');
    option.value = s.id;
    option.textContent = s.name ? `${s.name} (${s.id})` : s.id;
    picker.append(option);
  }
  // Planets in their own group, "default" first (the others by id; the default planet's own id
  // is the same planet, so it is not listed twice).
  state.planets = Array.isArray(planets?.planets) ? planets.planets : [];
  const group = document.createElement('optgroup');
  group.label = 'Planets';
  const planetOptions = [['default', 'default planet'],
    ...state.planets.filter((p) => !p.default).map((p) => [p.id, planetLabel(p)])];
  for (const [id, label] of planetOptions) {
    const option = document.createElement('option');
    option.value = PLANET_PREFIX + id;
    option.textContent = label;
    group.append(option);
  }
  if (planets?.default) picker.append(group);
  const view = readViewFromHash(location.hash);
  const planetView = readPlanetHash(location.hash);
  state.controls = makeSceneControls(view.mode);
  modeButton.textContent = state.controls.mode === 'fly' ? 'Fly' : 'Orbit';
  picker.addEventListener('change', () => {
    if (picker.value.startsWith(PLANET_PREFIX)) loadPlanet(picker.value.slice(PLANET_PREFIX.length));
    else loadScene(picker.value);
  });
  modeButton.addEventListener('click', () => state.controls?.setMode(state.controls.mode === 'fly' ? 'orbit' : 'fly'));
  resetButton.addEventListener('click', () => {
    if (state.planet) {
      state.planet.camera = defaultGlobeCamera(state.planet.view);
      state.planet.controls.setCamera(state.planet.camera);
      markDirty('scene');
      return;
    }
    if (!state.bundle) return;
    state.camera = new Camera(state.bundle.camera);
    state.controls.setCamera(state.camera);
    markDirty('scene');
  });
  window.addEventListener('hashchange', () => {
    const planet = readPlanetHash(location.hash);
    if (planet) {
      if (!state.planet || planet.planet !== state.planet.id) {
        loadPlanet(planet.planet, planet.camera);
      } else if (planet.camera && !planet.camera.equals(state.planet.camera)) {
        state.planet.camera = planet.camera;
        state.planet.controls.setCamera(planet.camera);
        markDirty('scene');
      }
      return;
    }
    const next = readViewFromHash(location.hash);
    if (next.scene && next.scene !== state.sceneId) {
      loadScene(next.scene, next.camera);
    } else if (next.camera && !next.camera.equals(state.camera)) {
      state.camera = next.camera;
      state.controls.setCamera(state.camera);
      markDirty('scene');
    }
  });
  if (planetView) {
    requestAnimationFrame(frame);
    await loadPlanet(planetView.planet, planetView.camera);
    return;
  }
  if (list.length === 0) {
    showMessage('The server has no scenes yet.');
    return;
  }
  const wanted = view.scene ?? (list.find((s) => s.id === 'winding-road') ?? list[0]).id;
  requestAnimationFrame(frame);
  await loadScene(wanted, view.camera);
}

start();
