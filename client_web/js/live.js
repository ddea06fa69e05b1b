// The live channel of one scene (docs/live.md): a WebSocket to /api/v1/scenes/{id}/live that
// follows the scene's head. It subscribes with the last version it knows, so after a reconnect
// the server sends what was missed (catch-up); it checks that versions arrive without gaps and
// resubscribes when one is missing; and it carries edits and their acks and rejects.
//
// Events (a LiveChannel is an EventTarget; `event.detail` is the server's message unless said):
//   status   { state: 'connecting' | 'open' | 'waiting', retryMs?, reason? }
//   welcome  the welcome message (scene, head, hash, can_edit, limits)
//   version  one per new version, in order, never twice
//   error    the server's `error` message (a malformed message of ours)
//   refused  the subscribe's token or name was refused (the `error`); the channel goes on
//            without it, read-only
//   reset    the server does not know the version we follow (its store was replaced): the
//            channel has stopped; the viewer starts again from the head
// Edits are promises instead: edit() resolves with the ack and rejects with an EditRejected.

const FIRST_RETRY_MS = 500;
const MAX_RETRY_MS = 15000;
const PING_EVERY_MS = 25000;     // our own ping, so a dead connection is noticed ...
const SILENCE_LIMIT_MS = 60000;  // ... when nothing at all came back for this long

/// A `reject` from the server, or an edit that never got an answer (status 0).
export class EditRejected extends Error {
  constructor({ status = 0, title = '', detail = '', pointer = '' } = {}) {
    super(detail ? `${title || 'Rejected'}: ${detail}` : title || 'Rejected');
    this.status = status;
    this.title = title;
    this.detail = detail;
    this.pointer = pointer;
  }
}

/// ws:// or wss:// URL of a scene's live route, on the server that served the page.
export function liveUrl(sceneId, where = location) {
  const scheme = where.protocol === 'https:' ? 'wss:' : 'ws:';
  return `${scheme}//${where.host}/api/v1/scenes/${encodeURIComponent(sceneId)}/live`;
}

export class LiveChannel extends EventTarget {
  /// `since`: the version the viewer shows (catch-up starts after it); `token` and `name` go in
  /// the subscribe message.
  constructor(sceneId, { since = null, token = '', name = '' } = {}) {
    super();
    this.sceneId = sceneId;
    this.version = since;     // the last version delivered (in order) to listeners
    this.token = token;
    this.name = name;
    this.refused = new Set();  // 'token', 'name': left out of subscribes until changed
    this.welcome = null;      // the current connection's welcome; null until it came
    this.socket = null;
    this.closed = false;
    this.attempt = 0;         // failed connections in a row: the backoff's exponent
    this.retryTimer = 0;
    this.pingTimer = 0;
    this.lastHeard = 0;
    this.gapsInARow = 0;
    this.nextRequest = 1;
    this.pending = new Map(); // request id -> { resolve, reject }
    this.connect();
  }

  get open() {
    return this.welcome !== null && this.socket?.readyState === WebSocket.OPEN;
  }

  get canEdit() {
    return this.open && this.welcome.can_edit === true;
  }

  /// New credentials take a new subscription (the token is checked at subscribe).
  /// Typing a refused token again tries it again.
  setCredentials({ token = this.token, name = this.name }) {
    const retry = (token && this.refused.has('token')) || (name && this.refused.has('name'));
    if (token === this.token && name === this.name && !retry) return;
    this.token = token;
    this.name = name;
    this.refused.clear();
    this.reconnect('new credentials', 0);
  }

  close() {
    this.closed = true;
    clearTimeout(this.retryTimer);
    clearInterval(this.pingTimer);
    this.dropSocket();
    this.failPending('The live channel was closed before the server answered.');
  }

  /// Sends an edit (a JSON Patch over the canonical scene, written against version `base`);
  /// resolves with the ack, rejects with an EditRejected.
  edit(ops, base) {
    if (!this.open) {
      return Promise.reject(new EditRejected({ title: 'Not connected',
        detail: 'the live channel is not connected; try again in a moment' }));
    }
    const request = `r${this.nextRequest++}`;
    const message = { type: 'edit', request, base, ops };
    return new Promise((resolve, reject) => {
      this.pending.set(request, { resolve, reject });
      this.socket.send(JSON.stringify(message));
    });
  }

  emit(type, detail) {
    this.dispatchEvent(new CustomEvent(type, { detail }));
  }

  connect() {
    if (this.closed) return;
    this.welcome = null;
    this.emit('status', { state: 'connecting' });
    const socket = new WebSocket(liveUrl(this.sceneId));
    this.socket = socket;
    socket.addEventListener('open', () => {
      if (socket !== this.socket) return;
      this.lastHeard = Date.now();
      const subscribe = { type: 'subscribe' };
      if (Number.isInteger(this.version)) subscribe.since = this.version;
      if (this.token && !this.refused.has('token')) subscribe.token = this.token;
      if (this.name && !this.refused.has('name')) subscribe.name = this.name;
      socket.send(JSON.stringify(subscribe));
    });
    socket.addEventListener('message', (e) => {
      if (socket !== this.socket) return;
      this.lastHeard = Date.now();
      let message;
      try {
        message = JSON.parse(e.data);
      } catch {
        return;  // not ours to understand; the protocol sends only JSON
      }
      this.receive(message);
    });
    // 'error' is always followed by 'close', which decides what happens next.
    socket.addEventListener('close', (e) => {
      if (socket !== this.socket) return;
      this.socket = null;
      const reason = e.reason || (e.code === 1006 ? 'connection lost' : `closed (${e.code})`);
      this.reconnect(reason);
    });
  }

  receive(message) {
    switch (message.type) {
      case 'welcome':
        this.welcome = message;
        this.attempt = 0;
        clearInterval(this.pingTimer);
        this.pingTimer = setInterval(() => this.keepAlive(), PING_EVERY_MS);
        this.emit('status', { state: 'open' });
        this.emit('welcome', message);
        break;
      case 'version':
        this.receiveVersion(message);
        break;
      case 'ack':
      case 'reject': {
        const waiting = this.pending.get(message.request);
        if (!waiting) return;
        this.pending.delete(message.request);
        if (message.type === 'ack') waiting.resolve(message);
        else waiting.reject(new EditRejected(message));
        break;
      }
      case 'error':
        if (this.welcome) this.emit('error', message);
        else this.subscribeFailed(message);
        break;
      default:
        break;  // pong, and whatever later versions of the protocol add
    }
  }

  receiveVersion(message) {
    if (!Number.isInteger(message.version)) return;
    const known = this.version;
    if (Number.isInteger(known) && message.version <= known) return;  // had it already
    // `previous` is the version this one follows; when it is not the last one we know, some
    // versions went by unseen: ask again from the last one we know (the server sends the rest,
    // or one head event with previous = since when the gap is long).
    if (Number.isInteger(known) && message.previous !== known) {
      // At once the first time; should the server keep skipping, back off like any failure.
      this.gapsInARow += 1;
      this.reconnect(`missed versions ${known + 1}–${message.previous}`, this.gapsInARow > 1 ? undefined : 0);
      return;
    }
    this.gapsInARow = 0;
    this.version = message.version;
    this.emit('version', message);
  }

  // An `error` instead of the welcome: the subscribe was refused (the connection stays open,
  // unsubscribed). A wrong token or name: subscribe again without it. A `since` the server does
  // not know: stop and let the viewer start over. Anything else (503: store unavailable, too
  // many viewers): try again later.
  subscribeFailed(message) {
    const field = { '/token': 'token', '/name': 'name' }[message.pointer];
    if (field) {
      this.refused.add(field);
      this.emit('refused', message);
      this.reconnect(message.detail || message.title, 0);
    } else if (message.pointer === '/since') {
      this.close();
      this.emit('reset', message);
    } else {
      this.reconnect(message.detail || message.title || 'the subscribe was refused');
    }
  }

  keepAlive() {
    if (!this.open) return;
    if (Date.now() - this.lastHeard > SILENCE_LIMIT_MS) {
      this.reconnect('the server stopped answering', 0);
      return;
    }
    this.socket.send(JSON.stringify({ type: 'ping' }));
  }

  dropSocket() {
    const socket = this.socket;
    this.socket = null;
    this.welcome = null;
    if (socket && socket.readyState <= WebSocket.OPEN) socket.close(1000, 'resubscribing');
  }

  failPending(detail) {
    for (const { reject } of this.pending.values()) {
      reject(new EditRejected({ title: 'No answer', detail }));
    }
    this.pending.clear();
  }

  /// Drops the connection (if any) and opens a new one after `delayMs` (default: exponential
  /// backoff with jitter, so a restarted server is not hit by every viewer at once).
  reconnect(reason, delayMs) {
    if (this.closed) return;
    clearTimeout(this.retryTimer);
    clearInterval(this.pingTimer);
    this.dropSocket();
    // An edit in flight may or may not have been applied; the catch-up will show which.
    this.failPending(`the connection was lost (${reason}); if the edit was applied, it arrives as a new version`);
    const wait = delayMs ?? Math.min(MAX_RETRY_MS, FIRST_RETRY_MS * 2 ** this.attempt) * (0.75 + 0.5 * Math.random());
    if (delayMs === undefined) this.attempt += 1;
    this.emit('status', { state: 'waiting', retryMs: wait, reason });
    this.retryTimer = setTimeout(() => this.connect(), wait);
  }
}
