// Orbit and fly controls for a Camera: mouse, touch and keyboard. The controls only change the
// camera; the viewer redraws when `onChange` says so.
import { add, normalise, scale } from './vector.js';
import { InputControls } from './input_controls.js';

const ROTATE_PER_PIXEL = 0.005;
const LOOK_PER_PIXEL = 0.003;

export class Controls extends InputControls {
  /// `scaleHint()` gives a length in metres that sets pan and fly speeds (the scene's size).
  constructor(element, camera, { onChange, scaleHint }) {
    super(element, camera, onChange);
    this.mode = 'orbit';
    this.scaleHint = scaleHint;
    this.listen(element, 'pointerdown', (e) => this.pointerDown(e));
    this.listen(element, 'pointermove', (e) => this.pointerMove(e));
    this.listen(element, 'pointerup', (e) => this.pointerUp(e));
    this.listen(element, 'pointercancel', (e) => this.pointerUp(e));
    this.listen(element, 'wheel', (e) => this.wheel(e), { passive: false });
    this.listen(window, 'keydown', (e) => this.keyDown(e));
    this.listenForReleases();
  }

  setMode(mode) {
    this.mode = mode === 'fly' ? 'fly' : 'orbit';
    this.onChange('mode');
  }

  pointerDown(e) {
    this.element.setPointerCapture?.(e.pointerId);
    this.pointers.set(e.pointerId, { x: e.clientX, y: e.clientY, button: e.button, shift: e.shiftKey });
    this.lastPinch = null;
  }

  pointerUp(e) {
    this.pointers.delete(e.pointerId);
    this.lastPinch = null;
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
      return;
    }
    if (p.button === 2 || p.button === 1 || p.shift) {
      this.pan(dx, dy);
    } else if (this.mode === 'fly') {
      const { yaw, pitch } = this.camera.angles();
      this.camera.lookTo(yaw - dx * LOOK_PER_PIXEL, pitch - dy * LOOK_PER_PIXEL);
    } else {
      const { yaw, pitch } = this.camera.angles();
      this.camera.orbitTo(yaw - dx * ROTATE_PER_PIXEL, pitch + dy * ROTATE_PER_PIXEL, this.camera.distance());
    }
    this.onChange('camera');
  }

  // Two fingers: their distance zooms, their midpoint pans.
  pinch() {
    const [a, b] = [...this.pointers.values()];
    const mid = { x: (a.x + b.x) / 2, y: (a.y + b.y) / 2 };
    const spread = Math.hypot(a.x - b.x, a.y - b.y);
    if (this.lastPinch) {
      this.zoom(this.lastPinch.spread / Math.max(spread, 1));
      this.pan(mid.x - this.lastPinch.mid.x, mid.y - this.lastPinch.mid.y);
    }
    this.lastPinch = { mid, spread };
    this.onChange('camera');
  }

  wheel(e) {
    e.preventDefault();
    const lines = e.deltaMode === 1 ? 16 : e.deltaMode === 2 ? 400 : 1;
    this.zoom(Math.exp(e.deltaY * lines * 0.0015));
    this.onChange('camera');
  }

  // Orbit: the eye moves towards or away from the target. Fly: the eye moves along the view.
  zoom(factor) {
    if (this.mode === 'fly') {
      const { forward } = this.camera.basis();
      this.camera.translate(scale(forward, (1 - factor) * this.speed()));
      return;
    }
    const { yaw, pitch } = this.camera.angles();
    const distance = Math.min(Math.max(this.camera.distance() * factor, 1), this.scaleHint() * 20);
    this.camera.orbitTo(yaw, pitch, distance);
  }

  // Drags the ground under the pointer: a move in the horizontal plane, scaled by distance.
  pan(dx, dy) {
    const { forward, right } = this.camera.basis();
    const ahead = normalise([forward[0], forward[1], 0]);
    const metresPerPixel = (this.camera.distance() * 2 * Math.tan((this.camera.fov * Math.PI) / 360)) /
      Math.max(this.element.clientHeight, 1);
    const move = add(scale(right, -dx * metresPerPixel), scale(ahead, dy * metresPerPixel));
    this.camera.translate([move[0], move[1], 0]);
  }

  speed() {
    // Faster high up, slower near the ground: a tenth of the height above the target per second
    // at least, and a fiftieth of the scene.
    return Math.max(this.scaleHint() / 50, Math.abs(this.camera.eye[2] - this.camera.target[2]) / 2);
  }

  keyDown(e) {
    if (e.target instanceof HTMLInputElement || e.target instanceof HTMLSelectElement) return;
    if (e.code === 'KeyF') {
      this.setMode(this.mode === 'fly' ? 'orbit' : 'fly');
      return;
    }
    this.keys.add(e.code);
    this.onChange('keys');
  }

  /// Applies held keys for `dt` seconds; returns whether the camera moved.
  update(dt) {
    if (this.keys.size === 0) return false;
    const k = (code) => (this.keys.has(code) ? 1 : 0);
    const { forward, right } = this.camera.basis();
    if (this.mode === 'fly') {
      const step = this.speed() * dt;
      let move = add(scale(forward, (k('KeyW') - k('KeyS')) * step), scale(right, (k('KeyD') - k('KeyA')) * step));
      move = add(move, [0, 0, (k('KeyE') - k('KeyQ')) * step]);
      this.camera.translate(move);
      const { yaw, pitch } = this.camera.angles();
      const turn = 1.2 * dt;
      this.camera.lookTo(yaw + (k('ArrowLeft') - k('ArrowRight')) * turn, pitch + (k('ArrowUp') - k('ArrowDown')) * turn);
    } else {
      const { yaw, pitch } = this.camera.angles();
      const turn = 1.2 * dt;
      this.camera.orbitTo(yaw + (k('ArrowLeft') - k('ArrowRight') + k('KeyA') - k('KeyD')) * turn,
        pitch + (k('ArrowUp') - k('ArrowDown')) * turn, this.camera.distance());
      const zoom = k('Minus') + k('NumpadSubtract') + k('KeyS') - k('Equal') - k('NumpadAdd') - k('KeyW');
      if (zoom !== 0) this.zoom(Math.exp(zoom * 1.5 * dt));
    }
    return true;
  }
}

