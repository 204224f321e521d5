// The whole wall in one window, at scale, bezels drawn: what each tile shows, live,
// drawn through the same layers as the tiles (layers.js).
import {LayerStack, followClock} from "../layers.js";
import {showLive} from "../live.js";

const wall = JSON.parse(document.body.dataset.wallInfo);
// Without a tile token the overview gets each display's quick fallback image.
const stack = await LayerStack.load({wall, displays: wall.displays, token: null});

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
      const matrix = display.to_wall.map((v) => v * scale);
      stack.draw(ctx, state, display, matrix, clock);
      ctx.restore();
    }
  };
}

showLive(`/ws/wall/${wall.id}/view`, drawer, {
  prepare: (changes, state) => stack.load(state),
  shown: (state, redraw, clock) => {
    stack.shown(state, redraw);  // layers refine at the overview's own density (an image)
    followClock(stack, state, redraw, clock);
  },
});
