// A tile's (or viewer's) live link to the wall: state in version order, applied at the
// server-scheduled instant, with NTP-style clock sync and reconnects that never reload.

const BACKOFF_BASE_MS = 500;
const BACKOFF_MAX_MS = 15000;
const GAP_WAIT_MS = 1000;
const CLOCK_SAMPLES = 8;
const CLOCK_BEST = 3;

export class WallSocket {
  /**
   * @param {string} url websocket URL
   * @param {object} hooks render(state, version) -> show(): draw the frame off screen
   *   now and return the function that shows it at the scheduled instant;
   *   onPrepare(changes, state) -> Promise: load what a heavy change (or a snapshot)
   *   needs; state is the whole state that change leads to;
   *   onOnline(bool, reason); reports: whether to send ready/applied (tiles only);
   *   notes(state) -> [text]: what the tile shows otherwise than asked, sent with applied
   */
  constructor(url, hooks) {
    this.url = url;
    this.hooks = hooks;
    this.state = null;
    this.latest = null;       // the state after the last accepted version
    this.version = null;      // last applied version
    this.queued = null;       // last version accepted into the apply chain
    this.generation = 0;      // bumps on resync: stale chain steps do nothing
    this.chain = Promise.resolve();
    this.swaps = new Map();   // version -> resolve function of a prepared change
    this.samples = [];        // clock samples {offset, rtt}
    this.offset = 0;          // server clock minus local clock, ms
    this.clockBase = Date.now() - performance.now();
    this.attempt = 0;
    this.gapTimer = null;
    this.pingTimer = null;
    this.connect();
  }

  // The local clock: the wall-clock reading at page start plus the monotonic,
  // sub-millisecond performance clock (Date.now() alone ticks in whole ms).
  localNow() {
    return this.clockBase + performance.now();
  }

  serverNow() {
    return this.localNow() + this.offset;
  }

  connect() {
    const ws = new WebSocket(this.url);
    this.ws = ws;
    ws.onopen = () => {
      this.send({type: "hello", last_version: this.version});
      this.ping();
    };
    ws.onmessage = (frame) => this.receive(JSON.parse(frame.data));
    ws.onclose = (close) => {
      clearTimeout(this.pingTimer);
      this.hooks.onOnline?.(false, close.reason || `closed (${close.code})`);
      this.resync();
      const ceiling = Math.min(BACKOFF_MAX_MS, BACKOFF_BASE_MS * 2 ** this.attempt);
      this.attempt += 1;
      setTimeout(() => this.connect(), ceiling * (0.5 + Math.random() / 2));
    };
  }

  send(message) {
    if (this.ws.readyState === WebSocket.OPEN) this.ws.send(JSON.stringify(message));
  }

  ping() {
    this.send({type: "ping", t0: this.localNow()});
    const interval = this.samples.length < CLOCK_SAMPLES ? 250 : 5000;
    this.pingTimer = setTimeout(() => this.ping(), interval);
  }

  // Keep the lowest-round-trip samples: their offset error is bounded by rtt / 2.
  recordClock({t0, t1, t2}) {
    const t3 = this.localNow();
    const rtt = (t3 - t0) - (t2 - t1);
    const offset = ((t1 - t0) + (t2 - t3)) / 2;
    this.samples.push({offset, rtt});
    if (this.samples.length > CLOCK_SAMPLES) this.samples.shift();
    const best = [...this.samples].sort((a, b) => a.rtt - b.rtt).slice(0, CLOCK_BEST);
    const offsets = best.map((s) => s.offset).sort((a, b) => a - b);
    this.offset = offsets[Math.floor(offsets.length / 2)];
  }

  receive(message) {
    switch (message.type) {
      case "pong":
        this.recordClock(message);
        this.attempt = 0;
        this.hooks.onOnline?.(true, "");
        break;
      case "snapshot": {
        this.resync();
        this.attempt = 0;
        this.hooks.onOnline?.(true, "");
        this.queued = message.version;
        this.latest = message.state;
        // Load what the state needs (renders, code layouts) before showing it; events
        // that arrive meanwhile queue behind it on the chain.
        const generation = this.generation;
        this.chain = Promise.resolve(this.hooks.onPrepare?.(message.state, message.state))
          .catch(() => undefined)
          .then(() => this.apply(message.state, message.version, generation));
        break;
      }
      case "event":
        if (this.accept(message.version)) {
          this.latest = merged(this.latest, message.changes);
          this.enqueue(message.version, message.changes, Promise.resolve(message.apply_at));
        }
        break;
      case "prepare":
        if (this.accept(message.version)) {
          this.latest = merged(this.latest, message.changes);
          const swapped = new Promise((resolve) => this.swaps.set(message.version, resolve));
          // A failed load still answers ready: the tile draws what it has rather than
          // holding the whole wall back until the swap timeout.
          const ready = Promise.resolve(this.hooks.onPrepare?.(message.changes, this.latest))
            .catch(() => undefined);
          ready.then(() => {
            if (this.hooks.reports) this.send({type: "ready", version: message.version});
          });
          this.enqueue(message.version, message.changes, ready.then(() => swapped));
        }
        break;
      case "swap":
        this.swaps.get(message.version)?.(message.apply_at);
        this.swaps.delete(message.version);
        break;
    }
  }

  // Versions must arrive one by one; a gap means something was missed: ask again.
  accept(version) {
    if (this.queued === null || version <= this.queued) return false;
    if (version === this.queued + 1) return true;
    if (!this.gapTimer) {
      this.gapTimer = setTimeout(() => {
        this.gapTimer = null;
        this.resync();
        this.send({type: "hello", last_version: this.version});
      }, GAP_WAIT_MS);
    }
    return false;
  }

  // Changes apply one after another: wait for the instant (or the swap), draw the
  // frame off screen, wait for the instant itself, show it.
  enqueue(version, changes, applyAt) {
    this.queued = version;
    const generation = this.generation;
    this.chain = this.chain
      .then(() => applyAt)
      .then((at) => {
        if (generation !== this.generation) return undefined;
        const state = merged(this.state, changes);
        const show = this.hooks.render(state, version);
        return this.waitUntil(at).then(() => this.apply(state, version, generation, show));
      });
  }

  // Sleep until server time `at`, then spin the last fraction of a millisecond: timers
  // take whole milliseconds, and re-arming a sub-millisecond timer again and again
  // would trip the browser's 4 ms clamp on nested timers.
  waitUntil(at) {
    return new Promise((resolve) => {
      const wake = () => {
        const left = at - this.serverNow();
        if (left >= 1) {
          setTimeout(wake, Math.floor(left));
          return;
        }
        while (this.serverNow() < at) { /* spin */ }
        resolve();
      };
      wake();
    });
  }

  // Report the instant the frame was shown, in server time.
  apply(state, version, generation, show = this.hooks.render(state, version)) {
    if (generation !== this.generation) return;
    const appliedAt = this.serverNow();
    show();
    this.state = state;
    this.version = version;
    if (this.hooks.reports) {
      const notes = this.hooks.notes?.(state) ?? [];
      this.send({type: "applied", version, server_time: appliedAt, notes});
    }
  }

  // Drop everything scheduled: the next snapshot or replay is the truth.
  resync() {
    this.generation += 1;
    this.chain = Promise.resolve();
    this.swaps.clear();
    this.queued = this.version;
    this.latest = this.state;
    clearTimeout(this.gapTimer);
    this.gapTimer = null;
  }
}

export function socketUrl(path) {
  const scheme = location.protocol === "https:" ? "wss:" : "ws:";
  return `${scheme}//${location.host}${path}`;
}

/**
 * The state after `changes`: the core's fields replaced, each app's slot merged key by
 * key (an event carries only the keys of a slot that changed).
 */
export function merged(state, changes) {
  const next = {...state, ...changes};
  if (changes.apps) {
    next.apps = {...state?.apps};
    for (const [app, slot] of Object.entries(changes.apps)) {
      next.apps[app] = {...next.apps[app], ...slot};
    }
  }
  return next;
}
