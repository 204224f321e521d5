// The whole wall in one window, at scale, bezels drawn: what each tile shows, live.
import {WallSocket, socketUrl} from "./wallsocket.js";
import {drawPattern} from "./scene.js";

const body = document.body;
const wall = JSON.parse(body.dataset.wallInfo);
const canvas = document.getElementById("scene");
const marker = document.getElementById("offline");
let current = null;

function draw() {
  if (!current) return;
  const ratio = window.devicePixelRatio || 1;
  const box = canvas.getBoundingClientRect();
  canvas.width = Math.round(box.width * ratio);
  canvas.height = Math.round(box.height * ratio);
  const scale = Math.min(canvas.width / wall.width, canvas.height / wall.height);
  const ctx = canvas.getContext("2d");
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = "#000";  // bezels and gaps
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  for (const display of wall.displays) {
    const [x, y, w, h] = display.rect;
    ctx.save();
    ctx.setTransform(scale, 0, 0, scale, 0, 0);
    ctx.beginPath();
    ctx.rect(x, y, w, h);
    ctx.clip();
    // to_wall places this display's part of the scene at its physical position.
    const [a, b, c, d, e, f] = display.to_wall;
    ctx.transform(a, b, c, d, e, f);
    drawPattern(ctx, wall, current.state, scale * Math.hypot(a, b));
    ctx.restore();
  }
  body.dataset.version = String(current.version);
}

new WallSocket(socketUrl(`/ws/wall/${wall.id}/view`), {
  reports: false,
  onState(state, version) {
    current = {state, version};
    draw();
  },
  onOnline(online, reason) {
    marker.hidden = online;
    marker.title = reason;
  },
});
window.addEventListener("resize", draw);
