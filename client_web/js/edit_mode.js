// Scene mode's editing mode: the panel (write token, primitive list, position, radius and
// elevation), picking on the terrain, dragging the selected primitive, and the edits it sends
// over the live channel (docs/live.md) with their acks and rejects shown.
//
// What it edits is the canonical JSON of the newest version the viewer knows of
// (GET /api/v1/scenes/{id}@{version}), and every edit names that version as its `base`, so the
// server applies it as written or rebases it onto versions that landed meanwhile.
import { fetchJson } from './api.js';
import {
  applyReplaceOps, elevationOf, elevationOps, listPrimitives, moveOps, pickPrimitive, primitiveTypes, radiusOf, radiusOps,
  worldCentre,
} from './scene_edit.js';

const TOKEN_KEY = 'terrain.writeToken';  // sessionStorage: typed once per tab
const NAME_KEY = 'terrain.authorName';
const CLICK_SLOP_PX = 4;  // a press that moves less than this is a click (select), not a drag

const byId = (id) => document.getElementById(id);

function storage() {
  try {
    return window.sessionStorage;
  } catch {
    return null;  // storage disabled: the token lasts as long as the page
  }
}

function round2(v) {
  return Math.round(v * 100) / 100;
}

export class EditMode {
  /// `host` is the viewer: sceneId(), version() (the newest version known), live() (the
  /// LiveChannel or null), groundAt(x, y) → [x, y, z] | null (the ground under a canvas point,
  /// CSS pixels), planeAt(x, y, z) → [x, y, z] | null (the ray's point at height z),
  /// project([x, y, z]) → { x, y } | null (client pixels),
  /// elevationHint() (a height for the marker when nothing better is known), and
  /// onCredentials() (resubscribe with the token).
  constructor(canvas, host) {
    this.canvas = canvas;
    this.host = host;
    this.enabled = false;
    this.doc = null;           // canonical scene JSON of version docVersion
    this.docVersion = null;
    this.docScene = null;
    this.fetching = null;      // { scene, version, done } of the document being fetched
    this.queue = null;         // the edits' chain: one at a time
    this.acked = 0;            // the newest version one of our edits made
    this.primitives = [];
    this.primitiveTypes = null;  // from the server's node registry, fetched with the first document
    this.selected = null;      // { pointer, instance } survives new versions
    this.drag = null;
    this.press = null;
    this.status = { text: '', kind: '' };
    this.ui = {
      toggle: byId('edit-toggle'),
      panel: byId('edit-panel'),
      tokenForm: byId('edit-credentials'),
      token: byId('edit-token'),
      name: byId('edit-name'),
      access: byId('edit-access'),
      list: byId('edit-primitive'),
      pointer: byId('edit-pointer'),
      x: byId('edit-x'),
      y: byId('edit-y'),
      radius: byId('edit-radius'),
      elevation: byId('edit-elevation'),
      status: byId('edit-status'),
      marker: byId('edit-marker'),
    };
    const store = storage();
    this.token = store?.getItem(TOKEN_KEY) ?? '';
    this.name = store?.getItem(NAME_KEY) ?? '';
    this.ui.token.value = this.token;
    this.ui.name.value = this.name;
    this.ui.toggle.addEventListener('click', () => this.setEnabled(!this.enabled));
    this.ui.tokenForm.addEventListener('submit', (e) => {
      e.preventDefault();
      this.token = this.ui.token.value.trim();
      this.name = this.ui.name.value.trim();
      store?.setItem(TOKEN_KEY, this.token);
      store?.setItem(NAME_KEY, this.name);
      this.host.onCredentials();
      this.showAccess();
    });
    this.ui.list.addEventListener('change', () => this.select(Number(this.ui.list.value)));
    this.ui.x.addEventListener('change', () => this.moveTo(0, this.ui.x.valueAsNumber));
    this.ui.y.addEventListener('change', () => this.moveTo(1, this.ui.y.valueAsNumber));
    this.ui.radius.addEventListener('change', () => this.setValue('radius', this.ui.radius.valueAsNumber));
    this.ui.elevation.addEventListener('change', () => this.setValue('elevation', this.ui.elevation.valueAsNumber));
    // Capture phase on the window: the editor sees a press on the canvas before the camera
    // controls do, and keeps it from them when it starts a drag of the selected primitive.
    window.addEventListener('pointerdown', (e) => this.pointerDown(e), true);
    window.addEventListener('pointermove', (e) => this.pointerMove(e), true);
    window.addEventListener('pointerup', (e) => this.pointerUp(e), true);
    window.addEventListener('pointercancel', () => this.cancelDrag(), true);
    window.addEventListener('keydown', (e) => {
      if (this.enabled && e.key === 'Escape' && !(e.target instanceof HTMLInputElement)) this.select(-1);
    });
  }

  /// What the live channel subscribes with: the token only while editing.
  credentials() {
    return { token: this.enabled ? this.token : '', name: this.name };
  }

  setEnabled(on) {
    this.enabled = on;
    this.ui.toggle.setAttribute('aria-pressed', String(on));
    this.ui.toggle.classList.toggle('active', on);
    this.ui.panel.hidden = !on;
    if (!on) this.cancelDrag();
    this.host.onCredentials();
    this.showAccess();
    if (on) this.follow();
    this.updateMarker();
  }

  /// A new scene is shown: forget the old document and selection.
  reset() {
    this.doc = null;
    this.docVersion = null;
    this.docScene = null;
    this.fetching = null;
    this.acked = 0;
    this.primitives = [];
    this.selected = null;
    this.cancelDrag();
    this.setStatus('', '');
    this.render();
    if (this.enabled) this.follow();
  }

  /// Fetches the newest known version's JSON when the document is older (called on every new
  /// version and when the mode is turned on).
  follow() {
    if (this.enabled) this.loadDoc(this.host.version());
  }

  /// Makes the document at least version `version`; resolves once it is (or could not be).
  /// Versions only go forwards: a slower answer for an older version is dropped.
  async loadDoc(version) {
    const scene = this.host.sceneId();
    if (!scene || !Number.isInteger(version)) return;
    if (this.docScene === scene && this.docVersion >= version) return;
    if (this.fetching?.scene === scene && this.fetching.version >= version) {
      await this.fetching.done;
      return;
    }
    const fetching = { scene, version, done: null };
    this.fetching = fetching;
    fetching.done = (async () => {
      try {
        if (!this.primitiveTypes) this.primitiveTypes = primitiveTypes(await fetchJson('/api/v1/node-types'));
        const doc = await fetchJson(`/api/v1/scenes/${encodeURIComponent(scene)}@${version}`);
        if (this.host.sceneId() !== scene || (this.docScene === scene && this.docVersion >= version)) return;
        this.setDoc(scene, version, doc);
      } catch (e) {
        if (this.host.sceneId() === scene) this.setStatus(`Could not load version ${version}: ${e.message}`, 'error');
      } finally {
        if (this.fetching === fetching) this.fetching = null;
      }
    })();
    await fetching.done;
    // Another version may have come while this one was on its way.
    if (this.enabled && this.host.sceneId() === scene && this.host.version() > version) this.follow();
  }

  setDoc(scene, version, doc) {
    this.doc = doc;
    this.docVersion = version;
    this.docScene = scene;
    this.primitives = listPrimitives(doc, this.primitiveTypes);
    this.render();
  }

  selectedIndex() {
    if (!this.selected) return -1;
    let index = -1;
    this.primitives.forEach((p, i) => {
      if (p.pointer === this.selected.pointer && p.instance === this.selected.instance) index = i;
    });
    return index;
  }

  selectedPrimitive() {
    return this.primitives[this.selectedIndex()] ?? null;
  }

  select(index) {
    const p = this.primitives[index];
    this.selected = p ? { pointer: p.pointer, instance: p.instance } : null;
    this.render();
  }

  showAccess() {
    const live = this.host.live();
    const { access } = this.ui;
    if (!this.token) {
      access.textContent = 'Type the write token to edit (the server’s --write-token).';
    } else if (live?.refused.has('token')) {
      access.textContent = 'The server refused this token (wrong write token): you can look, not edit.';
    } else if (!live?.open) {
      access.textContent = 'Connecting to the live channel…';
    } else if (live.canEdit) {
      access.textContent = `Editing as ${this.name || 'anonymous'}.`;
    } else {
      access.textContent = 'The server did not accept this token: edits will be refused.';
    }
  }

  setStatus(text, kind) {
    this.status = { text, kind };
    this.ui.status.textContent = text;
    this.ui.status.className = kind;
  }

  // The panel from the document and the selection. A field someone is typing in keeps what
  // they typed, unless `force` (after a reject: the document's value is the truth).
  render(force = false) {
    const { list, pointer, x, y, radius, elevation } = this.ui;
    const options = this.primitives.map((p, i) => {
      const option = document.createElement('option');
      option.value = String(i);
      const [x, y] = worldCentre(p).map((v) => Math.round(v));
      option.textContent = `${p.label} at (${x}, ${y})`;
      option.title = p.pointer;
      return option;
    });
    list.replaceChildren(...options);
    const index = this.selectedIndex();
    list.value = String(index);
    const p = this.primitives[index];
    pointer.textContent = p ? `${p.pointer}${p.warped ? ' (under a warp: placed as if unwarped)' : ''}` :
      this.doc ? 'Click the terrain or the list to pick a primitive.' : '';
    const set = (input, value) => {
      input.disabled = value === null || value === undefined;
      const text = input.disabled ? '' : String(round2(value));
      const typing = document.activeElement === input && input.value !== input.dataset.shown;
      if (force || !typing) input.value = text;
      input.dataset.shown = text;
    };
    const centre = p ? worldCentre(p) : null;
    set(x, centre?.[0]);
    set(y, centre?.[1]);
    set(radius, p ? radiusOf(p) : null);
    set(elevation, p ? elevationOf(p) : null);
    this.updateMarker();
  }

  /// Sends an edit of the selected primitive: `makeOps(primitive)` gives its ops. Edits go one
  /// at a time, each computed from the document its predecessor made: two quick changes of
  /// one field would otherwise both name the old version as base, and the server would
  /// refuse the second as a conflict with the first.
  send(what, makeOps) {
    const target = this.selected;
    const scene = this.host.sceneId();
    if (!target || !this.doc) return;
    const run = () => this.sendNow(scene, target, what, makeOps);
    this.queue = (this.queue ?? Promise.resolve()).then(run, run);
  }

  async sendNow(scene, target, what, makeOps) {
    const live = this.host.live();
    if (!live || this.host.sceneId() !== scene) return;
    if (this.acked > this.docVersion) await this.loadDoc(this.acked);
    const p = this.primitives.find((q) => q.pointer === target.pointer && q.instance === target.instance);
    const ops = p ? makeOps(p) : [];
    if (!ops.length) return;
    const base = this.docVersion;
    this.setStatus(`Sending ${what}…`, 'pending');
    try {
      const ack = await live.edit(ops, base);
      if (this.host.sceneId() !== scene) return;
      this.acked = Math.max(this.acked ?? 0, ack.version);
      // Applied as written onto our base: the next document is ours to make, no fetch needed.
      if (!ack.rebased && !ack.unchanged && ack.version === base + 1 && this.docVersion === base) {
        this.setDoc(scene, ack.version, applyReplaceOps(this.doc, ops));
      }
      this.setStatus(ack.unchanged ? `Nothing to change: version ${ack.version} has ${what} so already.` :
        `Saved ${what} as version ${ack.version}${ack.rebased ? ' (rebased onto newer changes)' : ''}.`, 'ok');
    } catch (e) {
      const head = e.status ? `Rejected (${e.status} ${e.title})` : e.title || 'Not sent';
      this.setStatus(`${head}: ${e.detail || e.message}${e.pointer ? ` [at ${e.pointer}]` : ''}`, 'error');
      this.render(true);  // the fields show the document again
    }
  }

  moveTo(axis, value) {
    if (!Number.isFinite(value)) {
      this.render(true);
      return;
    }
    this.send(`the position of ${this.selected?.pointer}`, (p) => {
      const delta = [0, 0];
      delta[axis] = value - worldCentre(p)[axis];
      return moveOps(p, delta);
    });
  }

  setValue(field, value) {
    if (!Number.isFinite(value)) {
      this.setStatus(`The ${field} must be a number.`, 'error');
      this.render(true);
      return;
    }
    this.send(`the ${field} of ${this.selected?.pointer}`,
      (p) => (field === 'radius' ? radiusOps(p, value) : elevationOps(p, value)));
  }

  canvasPoint(e) {
    const r = this.canvas.getBoundingClientRect();
    return [e.clientX - r.left, e.clientY - r.top];
  }

  pointerDown(e) {
    if (!this.enabled || e.target !== this.canvas || e.button !== 0 || e.shiftKey || !this.doc) return;
    const ground = this.host.groundAt(...this.canvasPoint(e));
    const picked = ground ? pickPrimitive(this.primitives, ground) : -1;
    const selected = this.selectedIndex();
    if (picked >= 0 && picked === selected) {
      // A press on the selected primitive drags it; the camera stays put.
      e.stopPropagation();
      e.preventDefault();
      this.canvas.setPointerCapture?.(e.pointerId);
      this.drag = { pointerId: e.pointerId, from: ground, centre: worldCentre(this.primitives[selected]),
        delta: [0, 0], x: e.clientX, y: e.clientY, moved: false };
      return;
    }
    this.press = { pointerId: e.pointerId, x: e.clientX, y: e.clientY, picked };
  }

  pointerMove(e) {
    const drag = this.drag;
    if (!drag || e.pointerId !== drag.pointerId) return;
    e.stopPropagation();
    if (Math.hypot(e.clientX - drag.x, e.clientY - drag.y) >= CLICK_SLOP_PX) drag.moved = true;
    // The ground under the pointer, on the level where the drag started.
    const at = this.host.planeAt(...this.canvasPoint(e), drag.from[2]);
    if (!at) return;
    drag.delta = [at[0] - drag.from[0], at[1] - drag.from[1]];
    const [x, y] = [drag.centre[0] + drag.delta[0], drag.centre[1] + drag.delta[1]];
    this.ui.x.value = String(round2(x));
    this.ui.y.value = String(round2(y));
    this.updateMarker();
  }

  pointerUp(e) {
    const drag = this.drag;
    if (drag && e.pointerId === drag.pointerId) {
      e.stopPropagation();
      this.drag = null;
      const delta = drag.delta;
      if (drag.moved && (delta[0] || delta[1])) {
        this.send(`the position of ${this.selected?.pointer}`, (p) => moveOps(p, delta));
      }
      this.updateMarker();
      return;
    }
    const press = this.press;
    if (press && e.pointerId === press.pointerId) {
      this.press = null;
      if (Math.hypot(e.clientX - press.x, e.clientY - press.y) < CLICK_SLOP_PX) this.select(press.picked);
    }
  }

  cancelDrag() {
    if (!this.drag) return;
    this.drag = null;
    this.render();
  }

  /// Keeps the marker over the selected primitive's centre (called every frame: the camera
  /// moves).
  updateMarker() {
    const marker = this.ui.marker;
    const p = this.enabled ? this.selectedPrimitive() : null;
    let at = null;
    if (p) {
      const centre = worldCentre(p);
      const [x, y] = this.drag ? [this.drag.centre[0] + this.drag.delta[0], this.drag.centre[1] + this.drag.delta[1]] : centre;
      const z = this.drag ? this.drag.from[2] : elevationOf(p) ?? this.host.elevationHint();
      at = this.host.project([x, y, z]);
    }
    marker.hidden = !at;
    if (at) {
      // Every frame while editing: touch the DOM only when the marker moved.
      const left = `${Math.round(at.x)}px`, top = `${Math.round(at.y)}px`;
      if (marker.style.left !== left) marker.style.left = left;
      if (marker.style.top !== top) marker.style.top = top;
      marker.classList.toggle('dragging', Boolean(this.drag));
    }
  }
}
