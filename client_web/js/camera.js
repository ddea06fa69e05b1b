// The viewer's camera: an eye and a target in scene metres (z up), driven by orbit or fly
// controls, and written to / read from the URL so that a view can be shared.

import { add, cross, length, normalise, scale, sub } from './vector.js';

const UP = [0, 0, 1];


export class Camera {
  constructor({ eye, target, fov = 50 }) {
    this.eye = [...eye];
    this.target = [...target];
    this.fov = fov;
  }

  clone() {
    return new Camera({ eye: this.eye, target: this.target, fov: this.fov });
  }

  /// Forward, right and up unit vectors and tan(fov / 2), in float32 arithmetic operation for
  /// operation as terrain::Camera::basis computes them, so both trace the same rays.
  basis() {
    const f = Math.fround;
    const normaliseF = (v) => {
      const l = f(Math.sqrt(f(f(f(v[0] * v[0]) + f(v[1] * v[1])) + f(v[2] * v[2]))));
      return [f(v[0] / l), f(v[1] / l), f(v[2] / l)];
    };
    const eye = this.eye.map(f);
    const target = this.target.map(f);
    const forward = normaliseF([f(target[0] - eye[0]), f(target[1] - eye[1]), f(target[2] - eye[2])]);
    let right = normaliseF([forward[1], -forward[0], 0]);
    if (!Number.isFinite(right[0])) right = [1, 0, 0];  // looking straight down or up
    const up = [
      f(f(right[1] * forward[2]) - f(right[2] * forward[1])),
      f(f(right[2] * forward[0]) - f(right[0] * forward[2])),
      f(f(right[0] * forward[1]) - f(right[1] * forward[0])),
    ];
    const tanHalf = f(Math.tan(f(f(f(this.fov) * f(Math.PI)) / 360)));
    return { forward, right, up, tanHalf };
  }

  distance() {
    return length(sub(this.target, this.eye));
  }

  /// Yaw (radians from +x, counter-clockwise) and pitch (radians, negative looking down) of the
  /// view direction.
  angles() {
    const d = sub(this.target, this.eye);
    return { yaw: Math.atan2(d[1], d[0]), pitch: Math.atan2(d[2], Math.hypot(d[0], d[1])) };
  }

  /// Puts the eye at `distance` from the target, looking along (yaw, pitch).
  orbitTo(yaw, pitch, distance) {
    const p = Math.max(-1.5533, Math.min(1.5533, pitch));  // ±89°: the basis needs a horizon
    const dir = [Math.cos(p) * Math.cos(yaw), Math.cos(p) * Math.sin(yaw), Math.sin(p)];
    this.eye = sub(this.target, scale(dir, distance));
  }

  /// Turns the view in place (fly mode): the target moves, the eye stays.
  lookTo(yaw, pitch) {
    const p = Math.max(-1.5533, Math.min(1.5533, pitch));
    const d = Math.max(this.distance(), 1);
    const dir = [Math.cos(p) * Math.cos(yaw), Math.cos(p) * Math.sin(yaw), Math.sin(p)];
    this.target = add(this.eye, scale(dir, d));
  }

  translate(offset) {
    this.eye = add(this.eye, offset);
    this.target = add(this.target, offset);
  }

  equals(other) {
    return (
      other &&
      this.fov === other.fov &&
      this.eye.every((v, i) => v === other.eye[i]) &&
      this.target.every((v, i) => v === other.target[i])
    );
  }
}

function formatVector(v) {
  return v.map((x) => String(Math.round(x * 100) / 100)).join(',');
}

function parseVector(text) {
  if (typeof text !== 'string') return null;
  const parts = text.split(',').map(Number);
  if (parts.length !== 3 || !parts.every(Number.isFinite)) return null;
  return parts;
}

/// The view state in a URL hash: #scene=ID&eye=x,y,z&target=x,y,z&fov=F&mode=orbit|fly.
export function readViewFromHash(hash) {
  const params = new URLSearchParams(hash.replace(/^#/, ''));
  const view = { scene: params.get('scene') || null, mode: params.get('mode') === 'fly' ? 'fly' : 'orbit' };
  const eye = parseVector(params.get('eye'));
  const target = parseVector(params.get('target'));
  const fov = Number(params.get('fov'));
  if (eye && target && length(sub(target, eye)) > 0) {
    view.camera = new Camera({ eye, target, fov: fov >= 5 && fov <= 120 ? fov : 50 });
  }
  return view;
}

export function writeViewToHash({ scene, camera, mode }) {
  const params = new URLSearchParams();
  if (scene) params.set('scene', scene);
  if (camera) {
    params.set('eye', formatVector(camera.eye));
    params.set('target', formatVector(camera.target));
    params.set('fov', String(camera.fov));
  }
  if (mode === 'fly') params.set('mode', 'fly');
  return '#' + params.toString().replaceAll('%2C', ',');
}

/// The ray through canvas point (x, y) (pixels, y from the top, of a width × height picture) as
/// the tracer casts it (trace_ray_direction): { origin, direction (unit) }.
export function rayThrough(camera, x, y, width, height) {
  const { forward, right, up, tanHalf } = camera.basis();
  const sx = (2 * (x / width) - 1) * tanHalf * (width / height);
  const sy = (1 - 2 * (y / height)) * tanHalf;
  return { origin: camera.eye, direction: normalise(add(forward, add(scale(right, sx), scale(up, sy)))) };
}

/// Where a point (scene metres) appears on a width × height picture: { x, y } in pixels (y from
/// the top), or null when it is behind the eye.
export function projectPoint(camera, point, width, height) {
  const { forward, right, up, tanHalf } = camera.basis();
  const v = sub(point, camera.eye);
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const depth = dot(v, forward);
  if (!(depth > 0)) return null;
  const sx = dot(v, right) / depth / (tanHalf * (width / height));
  const sy = dot(v, up) / depth / tanHalf;
  return { x: ((sx + 1) / 2) * width, y: ((1 - sy) / 2) * height };
}
