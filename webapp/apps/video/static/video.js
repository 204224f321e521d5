// The video app's layer: the wall's video framed on the stage (as large as fits at zoom
// 1, centred; the core's view pans and zooms it), each display drawing its part of the
// frame from one <video> element of its own, kept on the wall clock by follow.js. A new
// video is loaded to its first frame before the change is swapped in, so it appears on
// every tile at once. Only the display the slot names plays the sound.
import {Follower} from "./follow.js";

const LOAD_TIMEOUT_MS = 20000;

/** The video app's slot of the wall state, or null when another app is up. */
export function videoOf(state) {
  return state?.app === "video" ? state?.apps?.video ?? null : null;
}

/** Video pixels -> scene mm, [a, e, f] (x = a u + e, y = a v + f): as large as fits
 * on the stage at zoom 1, centred; the view's centre (a fraction of the stage) comes to
 * the stage's middle and the view zooms about it. */
export function placement([width, height], stage, view) {
  const [sx, sy, sw, sh] = stage;
  const zoom = view?.zoom ?? 1;
  const [cx, cy] = view?.center ?? [0.5, 0.5];
  const fit = Math.min(sw / width, sh / height);
  return [
    zoom * fit,
    sx + sw / 2 + zoom * ((0.5 - cx) * sw - (width * fit) / 2),
    sy + sh / 2 + zoom * ((0.5 - cy) * sh - (height * fit) / 2),
  ];
}

/** The page's one <video>: in the document (a detached or hidden element may not be
 * decoded), one pixel, unseen; the canvas shows its frames. */
function videoElement() {
  const video = document.createElement("video");
  video.playsInline = true;
  video.preload = "auto";
  video.muted = true;
  video.setAttribute("aria-hidden", "true");
  Object.assign(video.style, {
    position: "fixed", left: "0", top: "0", width: "1px", height: "1px", opacity: "0.01",
    pointerEvents: "none",
  });
  document.body.append(video);
  return video;
}

/** Resolve once `video` has its first frame, or reject with why not. */
function firstFrame(video) {
  if (video.readyState >= 2) return Promise.resolve();
  return new Promise((resolve, reject) => {
    const timer = setTimeout(() => done(new Error("did not load in time")), LOAD_TIMEOUT_MS);
    const done = (error) => {
      clearTimeout(timer);
      video.removeEventListener("loadeddata", loaded);
      video.removeEventListener("error", failed);
      if (error) reject(error); else resolve();
    };
    const loaded = () => done();
    const failed = () => done(new Error(video.error?.message || "cannot be played here"));
    video.addEventListener("loadeddata", loaded);
    video.addEventListener("error", failed);
  });
}

/** The video layer: each display's share of the wall's video. */
export function createLayer({wall, displays}) {
  const own = displays.length === 1 ? displays[0].id : null;  // a tile: its display
  let video = null;
  let follower = null;
  let manifest = null;       // the video loaded: its info.json
  let problem = null;        // why it does not play here, in words
  let redrawShown = () => {};

  let loading = {id: null, done: Promise.resolve()};

  /** Load the slot's video to its first frame (once per video, however often asked). */
  function load(state) {
    const id = videoOf(state)?.video;
    if (!id || id === loading.id) return loading.done;
    follower?.stop();
    follower = null;
    manifest = null;
    problem = null;
    loading = {id, done: start(id)};
    return loading.done;
  }

  async function start(id) {
    try {
      const response = await fetch(`/apps/video/videos/${id}/info.json`);
      if (!response.ok) throw new Error(`its manifest answered ${response.status}`);
      const info = await response.json();
      video ??= videoElement();
      video.src = `/apps/video/videos/${info.id}/video.${info.container}`;
      await firstFrame(video);
      manifest = info;
      follower = new Follower(video, info.fps, () => redrawShown());
    } catch (error) {
      problem = `shows no video: ${error.message}`;
      loading = {id: null, done: Promise.resolve()};  // asked again, it tries again
    }
  }

  function draw(ctx, {state, display, matrix, clock}) {
    ctx.setTransform(...matrix);
    ctx.fillStyle = "#000";
    ctx.fillRect(...display.scene_rect);
    const slot = videoOf(state);
    if (!slot || !follower || slot.video !== manifest?.id) return;
    video.muted = own === null || slot.sound !== own || follower.muted;
    // a rate change keeps the pitch only where it is heard: time-stretching costs CPU
    video.preservesPitch = !video.muted;
    follower.follow(slot.clock, slot.loop, clock);
    const size = [video.videoWidth || manifest.width, video.videoHeight || manifest.height];
    const [a, e, f] = placement(size, wall.stage, state.view);
    ctx.imageSmoothingEnabled = true;
    ctx.drawImage(video, e, f, size[0] * a, size[1] * a);
  }

  return {
    name: "video",
    load,
    draw,
    shown(state, redraw) {
      redrawShown = redraw;
      // the frame swapped in was drawn as the change arrived: draw the one due now
      if (videoOf(state) && follower) redraw();
    },
    marks(state) {
      const slot = videoOf(state);
      if (!slot) {
        follower?.park();  // another app came: nothing plays, or sounds, behind it
        return {video: ""};
      }
      if (!follower || own === null) return {video: problem ?? ""};
      const error = follower.lastError;
      return {
        video: [
          video.paused ? "paused" : "playing",
          `${video.currentTime.toFixed(3)} s`,
          error === null ? "" : `error ${(error * 1000).toFixed(1)} ms`,
          `rate ${video.playbackRate.toFixed(3)}`,
          `seeks ${follower.seeks}`,
          video.muted ? "muted" : "sound",
        ].filter(Boolean).join(", "),
      };
    },
    notes(state) {
      const slot = videoOf(state);
      if (problem) return [problem];
      if (slot?.sound === own && own !== null && follower?.muted) {
        return ["plays muted: the browser refused sound without a click"];
      }
      return [];
    },
  };
}
