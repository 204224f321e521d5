// A kiosk tile: draws its viewport of the wall scene from the state the server sends,
// through the layers the apps register (layers.js).
import {LayerStack, followClock} from "../layers.js";
import {showLive} from "../live.js";
import {PublicScreen} from "../public.js";

const body = document.body;
const viewport = JSON.parse(body.dataset.viewport);
const wall = JSON.parse(body.dataset.wallInfo);
const display = wall.displays.find((d) => d.id === body.dataset.tile);
const stack = await LayerStack.load({wall, displays: [display], token: body.dataset.token});
const publicScreen = body.dataset.publicScreen
  ? new PublicScreen(document.getElementById("public"), JSON.parse(body.dataset.publicScreen))
  : null;

// The server's matrix maps scene mm to the display's native pixels; fit those to the canvas.
function drawer(state, clock) {
  return (ctx, width, height) => {
    const sx = width / viewport.pixels[0];
    const sy = height / viewport.pixels[1];
    const [a, b, c, d, e, f] = viewport.to_pixels;
    stack.draw(ctx, state, display, [a * sx, b * sy, c * sx, d * sy, e * sx, f * sy], clock);
  };
}

// What the tile shows, for people (and tests) inspecting it: the layers' marks (a
// volume's detail, an app's data), the layers switched off, the balloons open.
function mark(state, clock) {
  Object.assign(body.dataset, stack.marks(state));
  body.dataset.hiddenGroups = Object.entries(state.layers ?? {})
    .filter(([, on]) => !on).map(([name]) => name).sort().join(" ");
  body.dataset.balloons = (state.balloons ?? [])
    .filter((b) => b.closes_at == null || b.closes_at > clock()).map((b) => b.id).join(" ");
}

showLive(
  `/ws/wall/${body.dataset.wall}/tile/${body.dataset.tile}?token=${body.dataset.token}`,
  drawer,
  {
    reports: true,
    prepare: (changes, state) => stack.load(state),
    notes: (state) => stack.notes(state),
    overlay: (state, clock) => (publicScreen ? publicScreen.prepare(state.public, clock) : () => {}),
    shown: (state, redraw, clock) => {
      mark(state, clock);
      stack.shown(state, () => redraw() && mark(state, clock));
      followClock(stack, state, redraw, clock, () => mark(state, clock));
    },
  },
);
