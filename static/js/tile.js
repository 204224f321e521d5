// A kiosk tile: draws its viewport of the wall scene from the state the server sends.
import {drawBalloons, nextClosing} from "./balloons.js";
import {CensusViews, drawCaption, drawCensus, withToggleStates} from "./census.js";
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
const maps = new CensusViews(wall.id, body.dataset.tile);
const display = wall.displays.find((d) => d.id === body.dataset.tile);
const publicScreen = display?.roles.includes("public")
  ? new PublicScreen(document.getElementById("public")) : null;

// The server's matrix maps scene mm to the display's native pixels; fit those to the canvas.
// Volume images and map views are already in native pixels; the rest is in scene mm.
function drawer(state, clock) {
  const volume = volumes.get(state);
  const map = maps.get(state);
  return (ctx, width, height) => {
    const sx = width / viewport.pixels[0];
    const sy = height / viewport.pixels[1];
    const [a, b, c, d, e, f] = viewport.to_pixels;
    const matrix = [a * sx, b * sy, c * sx, d * sy, e * sx, f * sy];
    const layout = withToggleStates(layouts.get(state.tag_layout), map, state);
    ctx.setTransform(sx, 0, 0, sy, 0, 0);
    if (map) drawCensus(ctx, map, state, display);
    else if (volume) drawVolume(ctx, volume);
    if (map && display?.roles.includes("menu")) drawCaption(ctx, map, display);
    ctx.setTransform(...matrix);
    if (!volume && !map) drawPattern(ctx, wall, state, Math.hypot(matrix[0], matrix[1]));
    drawCodes(ctx, layout, matrix, map ? maps.hiddenCodes(state) : null);
    drawBalloons(ctx, state, clock(), Math.hypot(matrix[0], matrix[1]));
  };
}

// What the tile shows, for people (and tests) inspecting it: the volume's detail
// ("refined 0"), the census groups hidden here, the balloons open.
function mark(state, clock) {
  const volume = volumes.get(state);
  body.dataset.volume = volume ? `${volume.detail} ${volume.level}` : "";
  const map = maps.get(state);
  body.dataset.census = map ? `${map.dataset} ${map.tracts.length}` : "";
  body.dataset.hiddenGroups = Object.entries(state.layers ?? {})
    .filter(([, on]) => !on).map(([name]) => name).sort().join(" ");
  body.dataset.balloons = (state.balloons ?? [])
    .filter((b) => b.closes_at == null || b.closes_at > clock()).map((b) => b.id).join(" ");
}

let closing = null;

// Balloons close by the shared clock: redraw when the next one is due, then look again.
function closeBalloons(state, redraw, clock) {
  clearTimeout(closing);
  const due = nextClosing(state, clock());
  if (due == null) return;
  closing = setTimeout(() => {
    if (redraw()) {
      mark(state, clock);
      closeBalloons(state, redraw, clock);
    }
  }, Math.max(0, due - clock()) + 1);
}

showLive(
  `/ws/wall/${body.dataset.wall}/tile/${body.dataset.tile}?token=${body.dataset.token}`,
  drawer,
  {
    reports: true,
    prepare: (changes, state) => Promise.all([
      layouts.load(changes.tag_layout ?? state.tag_layout),
      volumes.load(state),
      maps.load(state),
    ]),
    overlay: (state) => (publicScreen ? publicScreen.prepare(state.public) : () => {}),
    shown: (state, redraw, clock) => {
      mark(state, clock);
      volumes.refine(state, () => redraw() && mark(state, clock));
      closeBalloons(state, redraw, clock);
    },
  },
);
