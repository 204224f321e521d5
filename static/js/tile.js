// A kiosk tile: draws its viewport of the wall scene from the state the server sends.
import {CodeLayouts, drawCodes} from "./codes.js";
import {showLive} from "./live.js";
import {PublicScreen} from "./public.js";
import {drawPattern} from "./scene.js";

const body = document.body;
const viewport = JSON.parse(body.dataset.viewport);
const wall = JSON.parse(body.dataset.wallInfo);
const layouts = new CodeLayouts(wall.id, body.dataset.tile);
const display = wall.displays.find((d) => d.id === body.dataset.tile);
const publicScreen = display?.roles.includes("public")
  ? new PublicScreen(document.getElementById("public")) : null;

// The server's matrix maps scene mm to the display's native pixels; fit those to the canvas.
function drawer(state) {
  return (ctx, width, height) => {
    const sx = width / viewport.pixels[0];
    const sy = height / viewport.pixels[1];
    const [a, b, c, d, e, f] = viewport.to_pixels;
    const matrix = [a * sx, b * sy, c * sx, d * sy, e * sx, f * sy];
    ctx.setTransform(...matrix);
    drawPattern(ctx, wall, state, Math.hypot(matrix[0], matrix[1]));
    drawCodes(ctx, layouts.get(state.tag_layout), matrix);
  };
}

showLive(
  `/ws/wall/${body.dataset.wall}/tile/${body.dataset.tile}?token=${body.dataset.token}`,
  drawer,
  {
    reports: true,
    prepare: (changes) => layouts.load(changes.tag_layout),
    overlay: (state) => (publicScreen ? publicScreen.prepare(state.public) : () => {}),
  },
);
