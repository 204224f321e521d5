// The balloons' pointers and dots, shared by every app: a layer under the codes, so a
// pointer that cannot miss every code passes under them (balloons.js draws the boxes).
import {drawPointers} from "./balloons.js";
import {markMm} from "./matrix.js";

export function createLayer() {
  return {
    name: "pointers",
    draw(ctx, {state, clock, matrix, display}) {
      ctx.setTransform(...matrix);
      drawPointers(ctx, state, clock(), (px) => markMm(px, display, matrix, 1));
    },
  };
}
