// A page that shows the wall scene live (a tile or the overview): each new state is
// drawn off screen as it arrives and shown at the instant the server scheduled.
import {Frames} from "./frames.js";
import {WallSocket, socketUrl} from "./wallsocket.js";

/**
 * @param {string} path websocket path
 * @param {function} drawer (state, clock) -> (ctx, width, height) => void; clock() is the
 *   server time now (ms), for what changes by the clock (balloons closing)
 * @param {boolean} reports whether this page reports ready/applied (tiles only)
 * @param {function} prepare (changes, state) -> Promise: load what the changed state needs
 * @param {function} overlay (state, clock) -> show(): ready page content beside the
 *   scene now, show it with the frame
 * @param {function} shown (state, redraw, clock) after a frame is shown: redraw() draws
 *   the state again in place if it is still the one shown (a refinement arrived, a
 *   balloon closed) and says whether it was
 */
export function showLive(path, drawer, {
  reports = false, prepare = () => undefined, overlay = () => () => {}, shown = () => {},
  notes = () => [],
} = {}) {
  const body = document.body;
  const frames = new Frames(document.getElementById("scene"));
  const marker = document.getElementById("offline");
  let current = null;
  const clock = () => socket.serverNow();
  const socket = new WallSocket(socketUrl(path), {
    reports,
    notes,
    render(state, version) {
      const show = frames.prepare(drawer(state, clock));
      const showOverlay = overlay(state, clock);
      return () => {
        show();
        showOverlay();
        current = state;
        body.dataset.version = String(version);
        shown(state, () => {
          if (current !== state) return false;
          frames.redraw(drawer(state, clock));
          return true;
        }, clock);
      };
    },
    onPrepare(changes, state) {
      return prepare(changes, state);
    },
    onOnline(online, reason) {
      marker.hidden = online;
      marker.title = reason;
      body.dataset.online = String(online);
    },
  });
  window.addEventListener("resize", () => current && frames.redraw(drawer(current, clock)));
}
