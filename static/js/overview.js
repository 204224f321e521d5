// The whole wall in one window, at scale, bezels drawn: what each tile shows, live.
import {CodeLayouts, drawCodes} from "./codes.js";
import {showLive} from "./live.js";
import {drawPattern} from "./scene.js";

const wall = JSON.parse(document.body.dataset.wallInfo);
const layouts = new CodeLayouts(wall.id);

function drawer(state) {
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
      drawPattern(ctx, wall, state, scale * Math.hypot(a, b));
      const matrix = [a * scale, b * scale, c * scale, d * scale, e * scale, f * scale];
      drawCodes(ctx, layouts.get(state.tag_layout), matrix);
      ctx.restore();
    }
  };
}

showLive(`/ws/wall/${wall.id}/view`, drawer, {
  prepare: (changes) => layouts.load(changes.tag_layout),
});
