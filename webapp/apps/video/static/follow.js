// One tile's video kept on the wall clock. The server states where the video is as one
// clock statement, {playing, media_s, wall_ms}: "playing from media time media_s at
// wall time wall_ms" (or paused there); every tile computes from it where its video
// should be at each instant of the estimated server clock and steers its <video>
// element there: small playbackRate changes for small errors, a seek only when far
// off. The thresholds are below; docs/video.md says why each is what it is.
//
// A statement takes effect at its wall_ms, on every tile at once; until then the one
// before it holds (the server makes them continuous there, unless it is a seek).

/** Steer by rate while the error is under this; seek past it (seconds)... */
export const SEEK_S = 0.2;
/** ...when it stays past it this many frames in a row: a tile that stalled (a busy
 * machine) shows the frame due when it comes back, and needs no seek. */
const FAR_FRAMES = 3;
/** The largest change of rate: 10 % faster or slower. */
export const MAX_RATE_STEP = 0.1;
/** Rate change per second of error: 50 ms behind plays 10 % faster. */
export const GAIN_PER_S = 2;
/** The error is smoothed over about this many frames (each frame's is quantised). */
const SMOOTHING_FRAMES = 5;
/** Within this fraction of a frame the rate stays exactly 1. */
const DEADBAND_FRAMES = 0.15;
/** A seek first aims this far ahead (s), then as far as seeks took here lately. */
const FIRST_SEEK_LEAD_S = 0.3;
const MAX_SEEK_LEAD_S = 3;
/** Frames measured after a start to learn how late this tile's starts show (s). */
const START_FRAMES = 4;
const MAX_START_LAG_S = 0.5;
/** How often a tile looks when no frame tells it to (paused, seeking), ms. */
const TICK_MS = 200;

/**
 * Where a statement puts the video at server time `at` (ms): {position, playing}. A
 * playing video stands still before its wall_ms; looping, it wraps at `duration` as
 * it plays; not looping, it stops on its last frame (paused, it stands where put).
 */
export function positionAt(clock, at, duration, loop) {
  const running = clock.playing && at > clock.wall_ms;
  let position = clock.media_s + (running ? (at - clock.wall_ms) / 1000 : 0);
  if (!(duration > 0)) return {position: Math.max(0, position), playing: running};
  if (loop && running) {
    position = ((position % duration) + duration) % duration;
    return {position, playing: running};
  }
  if (position >= duration) return {position: duration, playing: false};
  return {position: Math.max(0, position), playing: running};
}

/** `error` (s) brought into (-duration/2, duration/2]: a looping video is as near to
 * a position just after its start as to one just before its end. */
function wrapped(error, duration, loop) {
  if (!loop || !(duration > 0)) return error;
  return error - duration * Math.round(error / duration);
}

function sameClock(a, b) {
  return a && b && a.playing === b.playing && a.media_s === b.media_s && a.wall_ms === b.wall_ms;
}

export class Follower {
  /**
   * @param {HTMLVideoElement} video the element it steers
   * @param {number} fps the video's frame rate (the error is measured per frame)
   * @param {function} redraw () => void: draw the element's frame now
   */
  constructor(video, fps, redraw) {
    this.video = video;
    this.fps = fps;
    this.redraw = redraw;
    this.clock = null;           // () => server ms, the tile's estimate
    this.before = null;          // the statement in effect until `current` takes over
    this.current = null;
    this.loop = false;
    this.smoothed = null;        // the error (s), smoothed
    this.seekLead = FIRST_SEEK_LEAD_S;
    this.startLag = 0;           // how late frames come after play() here (s), learned
    this.starting = null;        // the errors of the first frames after a start
    this.holding = false;        // a seek under way: the canvas keeps its frame
    this.heldSince = 0;
    this.holdUntil = 0;          // server ms: a start prepared, its frame kept unseen till then
    this.placed = null;          // the media time a paused element was last put at
    this.timer = null;
    this.seeks = 0;
    this.lastError = null;       // the last frame's error (s), for the tile's marks
    this.far = 0;                // frames in a row past SEEK_S
    this.muted = false;          // the browser refused its sound: it plays muted
    this.stopped = false;
    this.interval = setInterval(() => this.tick(), TICK_MS);
    this.watchFrames();
  }

  get duration() {
    return Number.isFinite(this.video.duration) ? this.video.duration : 0;
  }

  /** Follow the slot's statement from now on (the same one again changes nothing). */
  follow(statement, loop, clock) {
    this.clock = clock;
    if (sameClock(statement, this.current) && loop === this.loop) return;
    this.loop = loop;
    this.video.loop = loop;  // the element wraps by itself, without a seek of ours
    if (!sameClock(statement, this.current)) {
      this.before = this.current ?? statement;
      this.current = statement;
      this.smoothed = null;
      this.at(statement.wall_ms);
    }
    this.tick();
  }

  /** Stop following until told a statement again (another app is on the wall). */
  park() {
    this.current = null;
    this.before = null;
    clearTimeout(this.timer);
    this.video.pause();
  }

  /** The statement in effect at server time `now`. */
  effective(now) {
    return now >= this.current.wall_ms ? this.current : this.before;
  }

  /** Where the video should be at server time `now`. */
  wanted(now) {
    return positionAt(this.effective(now), now, this.duration, this.loop);
  }

  /** Where to put a paused element so that, played at server time `at`, its frames
   * come on time: this tile's starts show late by `startLag`. */
  startingPoint(at) {
    return this.wanted(at + this.startLag * 1000).position;
  }

  /** Look again at exactly server time `when` (a statement's instant). */
  at(when) {
    clearTimeout(this.timer);
    const left = when - this.clock();
    if (left <= 0) return;
    this.timer = setTimeout(() => {
      while (this.clock() < when) { /* spin the last millisecond */ }
      this.tick();
    }, Math.max(0, Math.floor(left) - 1));
  }

  watchFrames() {
    this.video.requestVideoFrameCallback((now, meta) => {
      if (this.stopped) return;
      this.watchFrames();
      this.frame(now, meta);
    });
  }

  /** A new frame was presented: draw it (unless holding the last one), measure, steer. */
  frame(now, meta) {
    if (!this.current || !this.clock || this.holding) return;
    if (this.clock() < this.holdUntil) return;
    this.redraw();
    if (this.video.paused || this.video.seeking) return;
    const shownAt = this.clock() + (meta.expectedDisplayTime - performance.now());
    const {position, playing} = this.wanted(shownAt);
    if (!playing) return this.tick();
    // the frame shown covers [mediaTime, mediaTime + 1 / fps): its middle is where it is
    const error = wrapped(meta.mediaTime + 0.5 / this.fps - position, this.duration, this.loop);
    this.lastError = error;
    if (Math.abs(error) > SEEK_S) {
      this.far += 1;
      if (this.far >= FAR_FRAMES) this.seekAhead();
      return;
    }
    this.far = 0;
    if (this.starting) {
      this.learnStart(error);
      return;
    }
    const keep = 2 / (SMOOTHING_FRAMES + 1);
    this.smoothed = this.smoothed === null ? error : this.smoothed + keep * (error - this.smoothed);
    const deadband = DEADBAND_FRAMES / this.fps;
    const step = Math.max(-MAX_RATE_STEP, Math.min(MAX_RATE_STEP, GAIN_PER_S * this.smoothed));
    const rate = Math.abs(this.smoothed) < deadband ? 1 : 1 - step;
    if (this.video.playbackRate !== rate) this.video.playbackRate = rate;
  }

  /** The first frames after a start say how late this tile's starts show: the next
   * start aims that much further on (the rest the rate steers away). */
  learnStart(error) {
    this.starting.push(error);
    if (this.starting.length < START_FRAMES) return;
    const mean = this.starting.reduce((sum, e) => sum + e, 0) / this.starting.length;
    this.startLag = Math.max(0, Math.min(MAX_START_LAG_S, this.startLag - mean));
    this.starting = null;
    this.smoothed = mean;
  }

  /** What no frame prompts: a pause, a paused seek, a start, a stall. */
  tick() {
    if (!this.current || !this.clock || this.video.readyState < 1) return;
    const now = this.clock();
    if (this.holding) {
      // a seek that never ended (the element was reloaded, another seek took over)
      if (now - this.heldSince > (MAX_SEEK_LEAD_S + 1) * 1000) this.holding = false;
      return;
    }
    const {position, playing} = this.wanted(now);
    const video = this.video;
    if (!playing) {
      this.stand(now, position);
      return;
    }
    if (video.paused && !video.seeking) {
      const ahead = wrapped(video.currentTime - this.startingPoint(now), this.duration, this.loop);
      if (Math.abs(ahead) < 1 / this.fps) {
        // the start prepared: its frame is decoded, this is its instant
        this.holdUntil = 0;
        this.play();
        this.redraw();
        return;
      }
    }
    const off = wrapped(video.currentTime - position, this.duration, this.loop);
    if (video.paused || Math.abs(off) > SEEK_S + 0.1) this.seekAhead();
  }

  /** Paused at `position`, exactly: every tile then shows the one frame that holds
   * that instant. A start ahead (the current statement plays from its instant on) is
   * prepared instead: its first frame decoded, unseen until then. */
  stand(now, position) {
    const video = this.video;
    const stopping = !video.paused;
    if (stopping) video.pause();
    video.playbackRate = 1;
    const start = this.current.wall_ms > now && this.current.playing ? this.current : null;
    const target = start ? this.startingPoint(start.wall_ms) : position;
    this.holdUntil = start ? start.wall_ms : 0;
    if (!video.seeking && video.currentTime !== target && this.placed !== target) {
      this.placed = target;  // once: an element that rounds the time is not asked again
      video.currentTime = target;
      if (!start) video.addEventListener("seeked", () => this.redraw(), {once: true});
    } else if (stopping && !start) {
      this.redraw();
    }
  }

  /**
   * Far off, or starting: pause, seek to where the video will be a little ahead, and
   * play from there at exactly that instant, the canvas holding its last frame
   * meanwhile. The lead is what seeks took here lately (seeking on a loaded tile takes
   * longer), so the frame comes in time.
   */
  seekAhead() {
    const video = this.video;
    this.holding = true;
    this.heldSince = this.clock();
    this.seeks += 1;
    this.far = 0;
    this.smoothed = null;
    video.pause();
    video.playbackRate = 1;
    const asked = this.clock();
    const when = asked + this.seekLead * 1000;
    const playing = this.wanted(when).playing;
    const position = playing ? this.startingPoint(when) : this.wanted(when).position;
    const done = () => {
      const took = (this.clock() - asked) / 1000;
      const late = this.clock() >= when;
      this.seekLead = Math.min(MAX_SEEK_LEAD_S,
        late ? this.seekLead * 2 : Math.max(0.1, 0.7 * this.seekLead + 0.3 * 1.5 * took));
      if (late || !playing) {
        this.holding = false;
        this.tick();
        return;
      }
      const wait = () => {
        const left = when - this.clock();
        if (left >= 2) {
          setTimeout(wait, Math.floor(left) - 1);
          return;
        }
        while (this.clock() < when) { /* spin */ }
        this.holding = false;
        this.play();
        this.redraw();
      };
      wait();
    };
    if (Math.abs(video.currentTime - position) < 0.25 / this.fps) {
      done();
    } else {
      video.addEventListener("seeked", done, {once: true});
      video.currentTime = position;
    }
  }

  /** Play, and learn from the first frames how late they come; where the browser
   * refuses sound without a click (no kiosk flag), muted. */
  play() {
    this.placed = null;
    this.starting = [];
    this.video.play().catch((error) => {
      if (error.name !== "NotAllowedError" || this.video.muted) return;
      this.muted = true;
      this.video.muted = true;
      this.video.play().catch(() => {});
    });
  }

  stop() {
    this.stopped = true;
    clearInterval(this.interval);
    clearTimeout(this.timer);
    this.video.pause();
  }
}
