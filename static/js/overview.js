// The whole wall in one window, at scale, bezels drawn: what each tile shows, live.
import {drawBalloons} from "./balloons.js";
import {CensusViews, drawCensus} from "./census.js";
import {CodeLayouts, drawCodes} from "./codes.js";
import {showLive} from "./live.js";
import {drawPattern} from "./scene.js";
import {VolumeImages, drawVolume} from "./volume.js";

const wall = JSON.parse(document.body.dataset.wallInfo);
const layouts = new CodeLayouts(wall.id);
// Without a tile token the overview gets each display's quick fallback image.
const volumes = new Map(wall.displays.map((d) => [d.id, new VolumeImages(wall.id, d.id)]));
const maps = new Map(wall.displays.map((d) => [d.id, new CensusViews(wall.id, d.id)]));

function inverse([a, b, c, d, e, f]) {
  const det = a * d - b * c;
  return [d / det, -b / det, -c / det, a / det, (c * f - d * e) / det, (b * e - a * f) / det];
}

function drawer(state, clock) {
  return (ctx, width, height) => {
    const scale = Math.min(width / wall.width, height / wall.height);
    ctx.fillStyle = "#000";  // bezels and gaps
    ctx.fillRect(0, 0, width, height);
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
      const volume = volumes.get(display.id).get(state);
      const map = maps.get(display.id).get(state);
      if (map) {
        ctx.save();
        ctx.transform(...inverse(display.to_pixels));
        drawCensus(ctx, map, state, display);
        ctx.restore();
      } else if (volume) {
        ctx.save();
        ctx.transform(...inverse(display.to_pixels));
        drawVolume(ctx, volume);
        ctx.restore();
      } else {
        drawPattern(ctx, wall, state, scale * Math.hypot(a, b));
      }
      const matrix = [a * scale, b * scale, c * scale, d * scale, e * scale, f * scale];
      const hidden = map ? maps.get(display.id).hiddenCodes(state) : null;
      drawCodes(ctx, layouts.get(state.tag_layout), matrix, hidden);
      drawBalloons(ctx, state, clock(), scale * Math.hypot(a, b));
      ctx.restore();
    }
  };
}

showLive(`/ws/wall/${wall.id}/view`, drawer, {
  prepare: (changes, state) => Promise.all([
    layouts.load(changes.tag_layout),
    ...[...volumes.values()].map((images) => images.load(state)),
    ...[...maps.values()].map((views) => views.load(state)),
  ]),
});
