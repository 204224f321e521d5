// A kiosk tile: draws its viewport of the wall scene from the state the server sends.
import {Frames} from "./frames.js";
import {WallSocket, socketUrl} from "./wallsocket.js";
import {drawPattern} from "./scene.js";

const body = document.body;
const viewport = JSON.parse(body.dataset.viewport);
const wall = JSON.parse(body.dataset.wallInfo);
const frames = new Frames(document.getElementById("scene"));
const marker = document.getElementById("offline");
let current = null;

// The server's matrix maps scene mm to the display's native pixels; fit those to the canvas.
function drawer(state) {
  return (ctx, width, height) => {
    const sx = width / viewport.pixels[0];
    const sy = height / viewport.pixels[1];
    const [a, b, c, d, e, f] = viewport.to_pixels;
    ctx.setTransform(a * sx, b * sy, c * sx, d * sy, e * sx, f * sy);
    drawPattern(ctx, wall, state, Math.hypot(a * sx, b * sy));
  };
}

new WallSocket(
  socketUrl(`/ws/wall/${body.dataset.wall}/tile/${body.dataset.tile}?token=${body.dataset.token}`),
  {
    reports: true,
    render(state, version) {
      const show = frames.prepare(drawer(state));
      return () => {
        show();
        current = state;
        body.dataset.version = String(version);
      };
    },
    onPrepare() {
      return Promise.resolve();  // the test pattern has nothing to load
    },
    onOnline(online, reason) {
      marker.hidden = online;
      marker.title = reason;
      body.dataset.online = String(online);
    },
  },
);
window.addEventListener("resize", () => current && frames.redraw(drawer(current)));
