// Description balloons: a box the server placed clear of codes, with a pointer to what
// it describes. Drawn in scene mm (the caller's transform); each closes at its time on
// the wall's shared clock, so every tile drops it at the same instant. The server keeps
// box, pointer and dot clear of every code and caption by CLEAR_PX in
// webapp/apps/census_map/actions.py: keep the sizes below within it.
//
// Two layers: the pointers and dots go under the codes (where codes crowd the map and
// no straight line from the box to the tract misses them all, the line passes under a
// code rather than over it), the boxes over everything else.

import {markMm} from "./matrix.js";

const PAD = 0.5;          // of the font size
const LINE_HEIGHT = 1.35; // of the font size

export function openBalloons(state, serverNow) {
  // A balloon never placed is not drawn: anywhere else, it could cover a code.
  return (state.balloons ?? [])
    .filter((b) => b.rect && (b.closes_at == null || b.closes_at > serverNow));
}

/** When the next open balloon closes (server ms), or null. */
export function nextClosing(state, serverNow) {
  const times = openBalloons(state, serverNow).map((b) => b.closes_at).filter((t) => t != null);
  return times.length ? Math.min(...times) : null;
}

/** `mm(px)`: a line `px` of the display's pixels wide, in scene mm. */
export function drawPointers(ctx, state, serverNow, mm) {
  ctx.strokeStyle = "#1b1b1b";
  ctx.fillStyle = "#1b1b1b";
  ctx.lineWidth = mm(2);
  for (const balloon of openBalloons(state, serverNow)) {
    const [ax, ay] = balloon.anchor;
    const [x, y, w, h] = balloon.rect;
    ctx.beginPath();
    ctx.moveTo(Math.min(Math.max(ax, x), x + w), Math.min(Math.max(ay, y), y + h));
    ctx.lineTo(ax, ay);
    ctx.stroke();
    ctx.beginPath();
    ctx.arc(ax, ay, mm(4), 0, 2 * Math.PI);
    ctx.fill();
  }
}

/** `mm(px)`: a line `px` of the display's pixels wide, in scene mm. */
export function drawBalloons(ctx, state, serverNow, mm) {
  for (const balloon of openBalloons(state, serverNow)) {
    const [x, y, w, h] = balloon.rect;
    const font = h / (LINE_HEIGHT * (1 + balloon.lines.length) + 2 * PAD);
    ctx.strokeStyle = "#1b1b1b";
    ctx.fillStyle = "#fffdf5";
    ctx.lineWidth = mm(2);
    ctx.fillRect(x, y, w, h);
    ctx.strokeRect(x, y, w, h);
    ctx.fillStyle = "#1b1b1b";
    ctx.textAlign = "left";
    ctx.textBaseline = "top";
    const left = x + PAD * font;
    const room = w - 2 * PAD * font;
    balloon.lines.forEach((line, i) => {
      fitText(ctx, line, left, y + PAD * font + LINE_HEIGHT * font * (i + 1), room, font, "");
    });
    fitText(ctx, balloon.title, left, y + PAD * font, room, font, "bold ");
  }
}

export function fitText(ctx, text, x, y, room, font, weight) {
  ctx.font = `${weight}${font}px sans-serif`;
  const width = ctx.measureText(text).width;
  const size = width > room ? font * room / width : font;
  ctx.font = `${weight}${size}px sans-serif`;
  ctx.fillText(text, x, y);
}

/** The balloons' boxes, shared by every app, over everything else. */
export function createLayer() {
  return {
    name: "balloons",
    draw(ctx, {state, clock, matrix, display}) {
      ctx.setTransform(...matrix);
      drawBalloons(ctx, state, clock(), (px) => markMm(px, display, matrix, 1));
    },
    due: nextClosing,
  };
}
