// Play, pause, seek, loop and the sound's display of the wall's video: one module for
// the dashboard's panel and the instructor's phone remote, each a page of controls
// marked by data-video-* attributes inside its `root`. They ask the server to change the
// wall (it states the one clock every tile follows) and follow the wall's video by
// asking it every second, moving the time shown on by the same rule the tiles play by.
import {api} from "tagwall/api.js";
import {positionAt} from "./follow.js";

const POLL_MS = 1000;

/** A media time as a video player shows it: 4:05, 1:02:03. */
export function clockText(seconds) {
  const whole = Math.max(0, Math.floor(seconds));
  const [h, m, s] = [Math.floor(whole / 3600), Math.floor(whole / 60) % 60, whole % 60];
  const two = (n) => String(n).padStart(2, "0");
  return h ? `${h}:${two(m)}:${two(s)}` : `${m}:${two(s)}`;
}

export class VideoControls {
  /**
   * @param {HTMLElement} root the element holding the controls
   * @param {string} wallId the wall
   * @param {function} onChange (wallVideo) => void after every answer (the panel's list)
   */
  constructor(root, wallId, onChange = () => {}) {
    this.root = root;
    this.base = `/api/apps/video/walls/${wallId}`;
    this.onChange = onChange;
    this.now = null;        // the last answer: GET /api/apps/video/walls/{wall}
    this.offset = 0;        // the server's clock minus this page's (ms), roughly
    this.dragging = false;
    this.bind();
  }

  $(selector) {
    return this.root.querySelector(selector);
  }

  bind() {
    this.$("[data-video-toggle]")?.addEventListener("click", () => {
      this.act(this.playing() ? "pause" : "play");
    });
    for (const button of this.root.querySelectorAll("[data-video-by]")) {
      button.addEventListener("click", () => this.act("seek", {by_s: Number(button.dataset.videoBy)}));
    }
    for (const button of this.root.querySelectorAll("[data-video-to]")) {
      button.addEventListener("click", () => this.act("seek", {to_s: Number(button.dataset.videoTo)}));
    }
    const slider = this.$("[data-video-position]");
    slider?.addEventListener("input", () => {
      this.dragging = true;
      this.showTime(Number(slider.value));
    });
    slider?.addEventListener("change", () => {
      this.dragging = false;
      this.act("seek", {to_s: Number(slider.value)});
    });
    this.$("[data-video-loop]")?.addEventListener("change", (event) => {
      this.act("loop", {loop: event.target.checked}, "PUT");
    });
    this.$("[data-video-sound]")?.addEventListener("change", (event) => {
      this.act("sound", {display: event.target.value || null}, "PUT");
    });
  }

  /** Ask the server for a change; show what the wall does now, or why not. */
  async act(path, body = null, method = "POST") {
    const said = this.$("[data-video-said]");
    try {
      const options = {method, ...(body ? {body: JSON.stringify(body)} : {})};
      this.show(await api(`${this.base}/${path}`, options));
      if (said) said.textContent = "";
    } catch (error) {
      if (said) said.textContent = error.message;
    }
  }

  async refresh() {
    try {
      this.show(await api(this.base));
    } catch (error) {
      const said = this.$("[data-video-said]");
      if (said) said.textContent = error.message;
    }
  }

  /** Follow the wall: ask every second, move the time shown on between answers. */
  follow() {
    this.refresh();
    setInterval(() => {
      if (!document.hidden && this.root.offsetParent !== null) this.refresh();
    }, POLL_MS);
    const tick = () => {
      if (this.now && !this.dragging) this.showTime(this.position().position);
      requestAnimationFrame(tick);
    };
    requestAnimationFrame(tick);
  }

  /** Where the wall's video is now, by the rule the tiles play by. */
  position() {
    const {clock, loop, video} = this.now;
    return positionAt(clock, Date.now() + this.offset, video?.duration_s ?? 0, loop);
  }

  playing() {
    return Boolean(this.now?.on_wall && this.now.video && this.position().playing);
  }

  show(now) {
    this.now = now;
    this.offset = now.server_ms - Date.now();
    const up = Boolean(now.on_wall && now.video);
    for (const control of this.root.querySelectorAll("button, input, select")) {
      if (control.closest("[data-video-controls]")) control.disabled = !up;
    }
    const title = this.$("[data-video-title]");
    if (title) {
      title.textContent = now.video
        ? now.video.title + (now.on_wall ? "" : " (the wall shows another app)")
        : "No video on the wall";
    }
    const slider = this.$("[data-video-position]");
    if (slider && now.video) slider.max = String(now.video.duration_s);
    const loop = this.$("[data-video-loop]");
    if (loop) loop.checked = now.loop;
    const sound = this.$("[data-video-sound]");
    if (sound && sound.options.length !== now.displays.length + 1) {
      const none = new Option("no sound", "");
      sound.replaceChildren(none, ...now.displays.map((id) => new Option(id, id)));
    }
    if (sound) sound.value = now.sound ?? "";
    this.showTime(this.position().position);
    this.onChange(now);
  }

  showTime(seconds) {
    const toggle = this.$("[data-video-toggle]");
    if (toggle) {
      const playing = this.playing();
      toggle.textContent = playing ? "Pause" : "Play";
    }
    const time = this.$("[data-video-time]");
    const duration = this.now?.video?.duration_s ?? 0;
    if (time) time.textContent = `${clockText(seconds)} / ${clockText(duration)}`;
    const slider = this.$("[data-video-position]");
    if (slider && !this.dragging) slider.value = String(seconds);
  }
}
