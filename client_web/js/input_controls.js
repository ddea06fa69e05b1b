// What the scene viewer's and the globe's camera controls share: the camera they move, the
// pointers and keys held, and event listeners that are all removed together.

export class InputControls {
  constructor(element, camera, onChange) {
    this.element = element;
    this.camera = camera;
    this.onChange = onChange;
    this.keys = new Set();
    this.pointers = new Map();
    this.lastPinch = null;
    this.listeners = [];
  }

  /// Listens until dispose().
  listen(target, type, handler, options) {
    target.addEventListener(type, handler, options);
    this.listeners.push(() => target.removeEventListener(type, handler, options));
  }

  /// The context menu stays away from right-drags, and keys are released on keyup or when the
  /// window loses focus (a key held while the focus leaves never sends its keyup).
  listenForReleases() {
    this.listen(this.element, 'contextmenu', (e) => e.preventDefault());
    this.listen(window, 'keyup', (e) => this.keys.delete(e.code));
    this.listen(window, 'blur', () => this.keys.clear());
  }

  dispose() {
    for (const remove of this.listeners) remove();
    this.listeners = [];
  }

  setCamera(camera) {
    this.camera = camera;
  }
}
