// A kiosk tile: draws its viewport of the wall scene from the state the server sends.
import {WallSocket, socketUrl} from "./wallsocket.js";
import {drawPattern} from "./scene.js";

const body = document.body;
const viewport = JSON.parse(body.dataset.viewport);
const wall = JSON.parse(body.dataset.wallInfo);
const canvas = document.getElementById("scene");
const marker = document.getElementById("offline");
let current = null;

function draw() {
  if (!current) return;
  const ratio = window.devicePixelRatio || 1;
  const width = window.innerWidth;
  const height = window.innerHeight;
  if (canvas.width !== Math.round(width * ratio)) canvas.width = Math.round(width * ratio);
  if (canvas.height !== Math.round(height * ratio)) canvas.height = Math.round(height * ratio);
  const ctx = canvas.getContext("2d");
  // The server's matrix maps scene mm to the display's native pixels; fit those to the window.
  const sx = (width * ratio) / viewport.pixels[0];
  const sy = (height * ratio) / viewport.pixels[1];
  const [a, b, c, d, e, f] = viewport.to_pixels;
  ctx.setTransform(a * sx, b * sy, c * sx, d * sy, e * sx, f * sy);
  const pxPerMm = Math.hypot(a * sx, b * sy);
  drawPattern(ctx, wall, current.state, pxPerMm);
  body.dataset.version = String(current.version);
}

new WallSocket(
  socketUrl(`/ws/wall/${body.dataset.wall}/tile/${body.dataset.tile}?token=${body.dataset.token}`),
  {
    reports: true,
    onState(state, version) {
      current = {state, version};
      draw();
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
window.addEventListener("resize", draw);
