// The poll's layer: the question at the top of the stage, then one bar per choice in
// the choice's column (the server's: on one display, over the choice's code), its label
// above and its count on top. A bar stops short of every code, caption and designated
// screen the frame names (keepClear), so it never runs under them; text stays on one
// display, never across a bezel.
import {fitText} from "tagwall/balloons.js";

const COLOURS = ["#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948"];
const polls = new Map();  // round -> {question, choices, columns}, fetched once each

export function createLayer({wall}) {
  const [sx, sy, , sh] = wall.stage;
  const gap = sh * 0.03;  // kept between the drawing and what it keeps clear of
  const first = displayAt(wall, sx + gap, sy + gap);  // the question's display
  return {
    name: "poll",
    async load(state) {
      const round = state.apps?.poll?.round;
      if (round == null || polls.has(round)) return;
      const response = await fetch(`/api/apps/poll/walls/${wall.id}/polls/${round}`);
      if (response.ok) polls.set(round, await response.json());
    },
    draw(ctx, {state, matrix, keepClear}) {
      ctx.setTransform(...matrix);
      ctx.fillStyle = "#12203a";
      ctx.fillRect(0, 0, wall.width, wall.height);
      ctx.fillStyle = "#ffffff";
      ctx.textBaseline = "middle";
      const slot = state.apps?.poll ?? {};
      const poll = polls.get(slot.round);
      const [left, , width] = first;
      const room = width - 2 * gap;  // the question's display, less a margin
      if (!poll) {
        ctx.textAlign = "center";
        fitText(ctx, "No poll yet", left + width / 2, sy + sh / 2, room, sh / 8, "bold ");
        return;
      }
      const votes = slot.counts.reduce((sum, n) => sum + n, 0);
      const said = `${votes} vote${votes === 1 ? "" : "s"}`;
      const status = slot.closed ? `Closed: ${said} in all` : `Scan a code to vote · ${said}`;
      ctx.textAlign = "left";
      const below = writeLines(ctx, poll.question, left + gap, sy + gap, room, sh * 0.06, 2);
      ctx.fillStyle = "#b9c6e4";
      fitText(ctx, status, left + gap, below + sh * 0.03, room, sh * 0.04, "");

      const most = Math.max(1, ...slot.counts);
      const narrowest = Math.min(...poll.columns.map(([from, to]) => to - from));
      const bar = Math.min(sh * 0.45, narrowest * 0.7);
      const labels = sy + sh * 0.31;
      ctx.textAlign = "center";
      poll.columns.forEach(([from, to], i) => {
        const middle = (from + to) / 2;
        ctx.fillStyle = "#ffffff";
        fitText(ctx, poll.choices[i], middle, labels, to - from - 2 * gap, sh * 0.07, "bold ");
        const [top, bottom] = tallestFree(
          middle - bar / 2, middle + bar / 2, labels + sh * 0.05, sy + sh, keepClear, gap);
        const number = sh * 0.08;  // the count's size, over the bar
        const height = Math.max(0, bottom - top - number * 1.2) * (slot.counts[i] ?? 0) / most;
        ctx.fillStyle = COLOURS[i % COLOURS.length];
        ctx.fillRect(middle - bar / 2, bottom - height - gap / 4, bar, height + gap / 4);
        ctx.fillStyle = "#ffffff";
        fitText(ctx, String(slot.counts[i] ?? 0), middle, bottom - height - number * 0.7,
          bar, number, "bold ");
      });
    },
    marks(state) {
      const slot = state.apps?.poll;
      return {poll: slot?.round == null ? "" : `${slot.round}:${slot.counts.join(",")}`};
    },
  };
}

/** The scene rect [x, y, width, height] of the display showing the point (x, y). */
function displayAt(wall, x, y) {
  const rects = wall.displays.map((display) => display.scene_rect);
  return rects.find(([dx, dy, dw, dh]) => x >= dx && x <= dx + dw && y >= dy && y <= dy + dh)
    ?? wall.stage;
}

/** The tallest stretch [top, bottom] of the band between x0 and x1 that no box of
 * `clear`, grown by `gap`, reaches into. */
function tallestFree(x0, x1, top, bottom, clear, gap) {
  const cuts = clear
    .filter((box) => box.x - gap < x1 && box.x + box.width + gap > x0)
    .map((box) => [box.y - gap, box.y + box.height + gap])
    .sort(([a], [b]) => a - b);
  let best = [top, top];
  let from = top;
  for (const [cutTop, cutBottom] of [...cuts, [bottom, bottom]]) {
    const to = Math.min(cutTop, bottom);
    if (to - from > best[1] - best[0]) best = [from, to];
    from = Math.max(from, cutBottom);
  }
  return best;
}

/** `text` from (x, y) down, wrapped at `room` in at most `most` lines, as large as fits
 * up to `size`; where the next line would start. */
function writeLines(ctx, text, x, y, room, size, most) {
  let lines;
  for (let font = size; ; font *= 0.9) {
    ctx.font = `bold ${font}px sans-serif`;
    lines = [];
    for (const word of text.split(" ")) {
      const longer = lines.length ? `${lines.at(-1)} ${word}` : word;
      if (lines.length && ctx.measureText(longer).width <= room) lines[lines.length - 1] = longer;
      else lines.push(word);
    }
    const fits = lines.every((line) => ctx.measureText(line).width <= room);
    if ((lines.length <= most && fits) || font < size / 4) {
      lines.forEach((line, i) => ctx.fillText(line, x, y + font * (0.6 + 1.2 * i), room));
      return y + font * 1.2 * lines.length;
    }
  }
}
