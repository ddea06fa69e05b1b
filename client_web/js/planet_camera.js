// The globe camera of planet mode, its controls and its place in the URL.
//
// The camera is geographic: latitude and longitude of the point under it, altitude above the
// planet's reference surface (metres, the height tiles carry), heading (degrees clockwise from
// north) and tilt (degrees from looking straight down; 90 looks at the horizon). Everything is
// double precision; planet_view.js turns it into float32 matrices relative to the eye.

import { InputControls } from './input_controls.js';

const DEG = Math.PI / 180;

/// Geodesy on the planet's sphere or ellipsoid of revolution (equatorial radius `radius`,
/// `flattening` as in the definition; 0 is the default sphere).
export class Geodesy {
  constructor(radius, flattening = 0) {
    this.a = radius;
    this.f = flattening;
    this.e2 = flattening * (2 - flattening);
    this.b = radius * (1 - flattening);
  }

  /// ECEF metres of geodetic latitude, longitude (degrees) and height (metres), into `out`.
  ecef(latDeg, lonDeg, height, out = [0, 0, 0]) {
    const phi = latDeg * DEG;
    const lambda = lonDeg * DEG;
    const sinPhi = Math.sin(phi);
    const cosPhi = Math.cos(phi);
    const n = this.a / Math.sqrt(1 - this.e2 * sinPhi * sinPhi);
    out[0] = (n + height) * cosPhi * Math.cos(lambda);
    out[1] = (n + height) * cosPhi * Math.sin(lambda);
    out[2] = (n * (1 - this.e2) + height) * sinPhi;
    return out;
  }

  /// The east, north and up unit vectors at a geodetic latitude and longitude.
  frame(latDeg, lonDeg) {
    const phi = latDeg * DEG;
    const lambda = lonDeg * DEG;
    const sp = Math.sin(phi), cp = Math.cos(phi), sl = Math.sin(lambda), cl = Math.cos(lambda);
    return {
      east: [-sl, cl, 0],
      north: [-sp * cl, -sp * sl, cp],
      up: [cp * cl, cp * sl, sp],
    };
  }
}

export class GlobeCamera {
  constructor({ lat = 20, lon = 0, alt = 1.2e7, heading = 0, tilt = 0, fov = 50 } = {}) {
    this.lat = lat;
    this.lon = lon;
    this.alt = alt;
    this.heading = heading;
    this.tilt = tilt;
    this.fov = fov;
  }

  clone() {
    return new GlobeCamera(this);
  }

  equals(o) {
    return o && ['lat', 'lon', 'alt', 'heading', 'tilt', 'fov'].every((k) => this[k] === o[k]);
  }

  /// Eye position (ECEF, double) and the view basis: forward, up and right unit vectors.
  pose(geodesy) {
    const eye = geodesy.ecef(this.lat, this.lon, this.alt);
    const { east, north, up } = geodesy.frame(this.lat, this.lon);
    const h = this.heading * DEG, t = this.tilt * DEG;
    const ahead = [0, 1, 2].map((i) => north[i] * Math.cos(h) + east[i] * Math.sin(h));
    const forward = [0, 1, 2].map((i) => -up[i] * Math.cos(t) + ahead[i] * Math.sin(t));
    const camUp = [0, 1, 2].map((i) => ahead[i] * Math.cos(t) + up[i] * Math.sin(t));
    const right = [
      forward[1] * camUp[2] - forward[2] * camUp[1],
      forward[2] * camUp[0] - forward[0] * camUp[2],
      forward[0] * camUp[1] - forward[1] * camUp[0],
    ];
    return { eye, forward, up: camUp, right, east, north, localUp: up };
  }

  /// Moves the point under the camera by `metresAhead` along the heading and `metresRight`
  /// across it, on a sphere of the given radius (a small step: lat/lon deltas).
  move(metresAhead, metresRight, radius) {
    const h = this.heading * DEG;
    const north = metresAhead * Math.cos(h) - metresRight * Math.sin(h);
    const east = metresAhead * Math.sin(h) + metresRight * Math.cos(h);
    this.lat = Math.max(-89.9, Math.min(89.9, this.lat + north / radius / DEG));
    this.lon += east / (radius * Math.max(Math.cos(this.lat * DEG), 1e-3)) / DEG;
    this.lon = ((((this.lon + 180) % 360) + 360) % 360) - 180;
  }
}

function fixed(x, digits) {
  return String(Number(x.toFixed(digits)));
}

/// Planet mode's URL hash: #planet=ID&lat=..&lon=..&alt=..&heading=..&tilt=..[&fov=..].
/// Returns { planet, camera } (camera null unless lat, lon and alt are all given).
export function readPlanetHash(hash) {
  const params = new URLSearchParams(hash.replace(/^#/, ''));
  const planet = params.get('planet');
  if (!planet) return null;
  const num = (key) => (params.has(key) ? Number(params.get(key)) : NaN);
  const lat = num('lat'), lon = num('lon'), alt = num('alt');
  let camera = null;
  if ([lat, lon, alt].every(Number.isFinite)) {
    const heading = num('heading'), tilt = num('tilt'), fov = num('fov');
    camera = new GlobeCamera({
      lat: Math.max(-89.9, Math.min(89.9, lat)), lon, alt,
      heading: Number.isFinite(heading) ? heading : 0,
      tilt: Number.isFinite(tilt) ? Math.max(0, Math.min(89, tilt)) : 0,
      fov: fov >= 5 && fov <= 120 ? fov : 50,
    });
  }
  return { planet, camera };
}

export function writePlanetHash(planet, camera) {
  const params = new URLSearchParams();
  params.set('planet', planet);
  params.set('lat', fixed(camera.lat, 6));
  params.set('lon', fixed(camera.lon, 6));
  params.set('alt', fixed(camera.alt, 1));
  params.set('heading', fixed(camera.heading, 2));
  params.set('tilt', fixed(camera.tilt, 2));
  if (camera.fov !== 50) params.set('fov', String(camera.fov));
  return '#' + params.toString();
}

/// Mouse, touch and keyboard for the globe camera. Drag moves the globe under the pointer,
/// right-drag or shift-drag turns (heading) and tilts, wheel or pinch zooms exponentially with
/// the altitude above the ground. Keys: arrows / W A S D move, Q E turn, R F tilt, + − zoom.
/// `ground(camera)` gives the surface height (metres) under the camera as the loaded tiles know it;
/// the camera never goes below it.
export class GlobeControls extends InputControls {
  constructor(element, camera, { onChange, radius, ground }) {
    super(element, camera, onChange);
    this.radius = radius;
    this.ground = ground;
    this.listen(element, 'pointerdown', (e) => {
      element.setPointerCapture?.(e.pointerId);
      this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, button: e.button, shift: e.shiftKey });
      this.lastPinch = null;
    });
    const up = (e) => { this.pointers.delete(e.pointerId); this.lastPinch = null; };
    this.listen(element, 'pointerup', up);
    this.listen(element, 'pointercancel', up);
    this.listen(element, 'pointermove', (e) => this.pointerMove(e));
    this.listen(element, 'wheel', (e) => {
      e.preventDefault();
      const lines = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
      this.zoom(Math.exp(e.deltaY * lines * 0.0015));
      this.changed();
    }, { passive: false });
    this.listen(window, 'keydown', (e) => {
      if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
      this.keys.add(e.code);
      this.onChange('keys');
    });
    this.listenForReleases();
  }

  /// Height of the camera above the ground under it (at least a metre).
  clearance() {
    return Math.max(1, this.camera.alt - this.ground(this.camera));
  }

  /// Metres on the ground per pixel of drag straight below the camera: moving the ground by
  /// that much keeps the point under the pointer under it (exact looking down, close when
  /// tilted). From orbit it is capped so that a drag across the canvas turns the globe by
  /// about half a turn rather than flinging it round.
  metresPerPixel() {
    const c = this.camera;
    const height = Math.max(this.element.clientHeight, 1);
    const perPixel = (this.clearance() * 2 * Math.tan((c.fov * DEG) / 2)) / height;
    return Math.min(perPixel, (Math.PI * this.radius) / height);
  }

  pointerMove(e) {
    const p = this.pointers.get(e.pointerId);
    if (!p) return;
    const dx = e.clientX - p.x;
    const dy = e.clientY - p.y;
    p.x = e.clientX;
    p.y = e.clientY;
    if (this.pointers.size >= 2) {
      this.pinch();
    } else if (p.button === 2 || p.button === 1 || p.shift) {
      this.camera.heading = (((this.camera.heading + dx * 0.25) % 360) + 360) % 360;
      this.camera.tilt = Math.max(0, Math.min(89, this.camera.tilt - dy * 0.25));
    } else {
      const mpp = this.metresPerPixel();
      this.camera.move(dy * mpp, -dx * mpp, this.radius);
    }
    this.changed();
  }

  pinch() {
    const [a, b] = [...this.pointers.values()];
    const spread = Math.hypot(a.x - b.x, a.y - b.y);
    if (this.lastPinch) this.zoom(this.lastPinch / Math.max(spread, 1));
    this.lastPinch = spread;
  }

  /// Multiplies the height above the ground by `factor`: the same wheel turn halves the
  /// distance to the ground from orbit and from a hilltop alike.
  zoom(factor) {
    const ground = this.ground(this.camera);
    const clearance = Math.max(this.camera.alt - ground, 1);
    const next = Math.min(Math.max(clearance * factor, 2), 10 * this.radius);
    this.camera.alt = ground + next;
  }

  /// Keeps the camera at least two metres above the ground; returns whether it moved.
  clamp() {
    const min = this.ground(this.camera) + 2;
    if (this.camera.alt >= min) return false;
    this.camera.alt = min;
    return true;
  }

  changed() {
    this.clamp();
    this.onChange('camera');
  }

  /// Applies held keys for `dt` seconds; returns whether the camera moved.
  update(dt) {
    if (this.keys.size === 0) return false;
    const k = (code) => (this.keys.has(code) ? 1 : 0);
    const c = this.camera;
    // Half the canvas height of ground per second.
    const step = this.metresPerPixel() * Math.max(this.element.clientHeight, 1) * 0.5 * dt;
    const ahead = k('ArrowUp') + k('KeyW') - k('ArrowDown') - k('KeyS');
    const right = k('ArrowRight') + k('KeyD') - k('ArrowLeft') - k('KeyA');
    if (ahead || right) c.move(ahead * step, right * step, this.radius);
    const turn = k('KeyE') - k('KeyQ');
    if (turn) c.heading = (((c.heading + turn * 60 * dt) % 360) + 360) % 360;
    const tilt = k('KeyR') + k('PageUp') - k('KeyF') - k('PageDown');
    if (tilt) c.tilt = Math.max(0, Math.min(89, c.tilt + tilt * 40 * dt));
    const zoom = k('Minus') + k('NumpadSubtract') - k('Equal') - k('NumpadAdd');
    if (zoom) this.zoom(Math.exp(zoom * 1.5 * dt));
    this.clamp();
    return true;
  }
}
