// A kiosk tile: draws its viewport of the wall scene from the state the server sends.
import {CodeLayouts, drawCodes} from "./codes.js";
import {showLive} from "./live.js";
import {PublicScreen} from "./public.js";
import {drawPattern} from "./scene.js";
import {VolumeImages, drawVolume} from "./volume.js";

const body = document.body;
const viewport = JSON.parse(body.dataset.viewport);
const wall = JSON.parse(body.dataset.wallInfo);
const layouts = new CodeLayouts(wall.id, body.dataset.tile);
const volumes = new VolumeImages(wall.id, body.dataset.tile, body.dataset.token);
const display = wall.displays.find((d) => d.id === body.dataset.tile);
const publicScreen = display?.roles.includes("public")
  ? new PublicScreen(document.getElementById("public")) : null;

// The server's matrix maps scene mm to the display's native pixels; fit those to the canvas.
// A volume image is already in native pixels; the pattern and codes are in scene mm.
function drawer(state) {
  const volume = volumes.get(state);
  return (ctx, width, height) => {
    const sx = width / viewport.pixels[0];
    const sy = height / viewport.pixels[1];
    const [a, b, c, d, e, f] = viewport.to_pixels;
    const matrix = [a * sx, b * sy, c * sx, d * sy, e * sx, f * sy];
    if (volume) {
      ctx.setTransform(sx, 0, 0, sy, 0, 0);
      drawVolume(ctx, volume);
    }
    ctx.setTransform(...matrix);
    if (!volume) drawPattern(ctx, wall, state, Math.hypot(matrix[0], matrix[1]));
    drawCodes(ctx, layouts.get(state.tag_layout), matrix);
  };
}

// What the tile shows of a volume, for people (and tests) inspecting it: "refined 0".
function markVolume(state) {
  const volume = volumes.get(state);
  body.dataset.volume = volume ? `${volume.detail} ${volume.level}` : "";
}

showLive(
  `/ws/wall/${body.dataset.wall}/tile/${body.dataset.tile}?token=${body.dataset.token}`,
  drawer,
  {
    reports: true,
    prepare: (changes, state) => Promise.all([
      layouts.load(changes.tag_layout),
      volumes.load(state),
    ]),
    overlay: (state) => (publicScreen ? publicScreen.prepare(state.public) : () => {}),
    shown: (state, redraw) => {
      markVolume(state);
      volumes.refine(state, () => redraw() && markVolume(state));
    },
  },
);
