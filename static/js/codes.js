// The codes layer: placed QR codes, drawn so every module covers whole device pixels,
// and the red pins from displaced codes to their anchors.

import {angleOf, apply, markMm} from "./matrix.js";

const KEEP_LAYOUTS = 4;
const PIN = "#e63946";
const CAPTION_BACKING = "#10161f";

// Layouts (placements of a tag set) by id. They never change once made, so each is
// fetched once; a tile asks only for its own display's codes.
export class CodeLayouts {
  constructor(wallId, displayId = null) {
    this.wallId = wallId;
    this.displayId = displayId;
    this.layouts = new Map();
  }

  get(id) {
    return this.layouts.get(id);
  }

  async load(id) {
    if (!id || this.layouts.has(id)) return;
    const query = this.displayId ? `?display=${encodeURIComponent(this.displayId)}` : "";
    const response = await fetch(`/api/walls/${this.wallId}/layouts/${id}${query}`);
    if (!response.ok) throw new Error(`layout ${id}: ${response.status}`);
    this.layouts.set(id, await response.json());
    while (this.layouts.size > KEEP_LAYOUTS) this.layouts.delete(this.layouts.keys().next().value);
  }
}


// A scene-mm rectangle as whole device pixels under `matrix` (rotation included).
export function pixelBox(matrix, x, y, w, h) {
  const [x0, y0] = apply(matrix, x, y);
  const [x1, y1] = apply(matrix, x + w, y + h);
  const left = Math.round(Math.min(x0, x1));
  const top = Math.round(Math.min(y0, y1));
  return [left, top, Math.round(Math.max(x0, x1)) - left, Math.round(Math.max(y0, y1)) - top];
}

function drawCode(ctx, code, matrix) {
  const [x, y, w] = code.rect;
  const size = w / code.modules;
  const quiet = (code.modules - code.matrix.length) / 2;
  ctx.fillStyle = "#fff";
  ctx.fillRect(...pixelBox(matrix, x, y, w, w));
  ctx.fillStyle = "#000";
  code.matrix.forEach((row, j) => {
    for (let i = 0; i < row.length; i++) {
      if (row[i] === "1") {
        ctx.fillRect(...pixelBox(matrix, x + (quiet + i) * size, y + (quiet + j) * size, size, size));
      }
    }
  });
}

// Pins are drawn in scene mm (the caller's transform), under the codes; `mm(px)` sizes
// their marks in the display's pixels.
function drawPins(ctx, codes, mm) {
  ctx.strokeStyle = PIN;
  ctx.fillStyle = PIN;
  ctx.lineWidth = mm(3);
  for (const code of codes) {
    if (!code.leader) continue;
    const [[x0, y0], [x1, y1]] = code.leader;
    ctx.beginPath();
    ctx.moveTo(x0, y0);
    ctx.lineTo(x1, y1);
    ctx.stroke();
    ctx.beginPath();
    ctx.arc(x1, y1, mm(6), 0, 2 * Math.PI);
    ctx.fill();
  }
}

// A caption in its box (device pixels) on a dark backing, so nothing drawn before shows
// through; the text turned by `angle` (upright as the panel hangs), as large as fits,
// and clipped to the box: a label never reaches the code beside or under it.
export function drawCaption(ctx, text, [left, top, boxW, boxH], angle = 0) {
  const turned = Math.abs(Math.sin(angle)) > 0.5;
  ctx.save();
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  ctx.fillStyle = CAPTION_BACKING;
  ctx.fillRect(left, top, boxW, boxH);
  ctx.beginPath();
  ctx.rect(left, top, boxW, boxH);
  ctx.clip();
  const [width, height] = turned ? [boxH, boxW] : [boxW, boxH];
  ctx.setTransform(Math.cos(angle), Math.sin(angle), -Math.sin(angle), Math.cos(angle),
    left + boxW / 2, top + boxH / 2);
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  let size = Math.floor(height * 0.8);
  ctx.font = `bold ${size}px sans-serif`;
  const measured = ctx.measureText(text).width;
  if (measured > width * 0.96) {
    size = Math.floor(size * (width * 0.96) / measured);
    ctx.font = `bold ${size}px sans-serif`;
  }
  ctx.fillStyle = "#fff";
  ctx.fillText(text, 0, 0);
  ctx.restore();
}

// Every labelled code carries its caption in the strip placement reserved under it (same
// display, clear of other codes and captions).
function drawCaptions(ctx, codes, matrix) {
  const angle = angleOf(matrix);  // the panel's rotation: text turns with the scene
  for (const code of codes) {
    if (code.label && code.caption) {
      drawCaption(ctx, code.label, pixelBox(matrix, ...code.caption), angle);
    }
  }
}

/**
 * Draw a layout's codes on `display`: pins under codes, then the codes, then their
 * captions. `matrix` maps scene mm to the canvas's device pixels.
 */
export function drawCodes(ctx, layout, matrix, display) {
  if (!layout) return;
  const codes = layout.placed;
  ctx.setTransform(...matrix);
  drawPins(ctx, codes, (px) => markMm(px, display, matrix));
  ctx.setTransform(1, 0, 0, 1, 0, 0);
  for (const code of codes) drawCode(ctx, code, matrix);
  drawCaptions(ctx, codes, matrix);
}

/** The codes layer, shared by every app: the layout the wall state names as the layers
 * adjust it (the layer stack loads it: a tile gets what its display draws of it, the
 * overview all of it). */
export function createLayer() {
  return {
    name: "codes",
    draw: (ctx, frame) => drawCodes(ctx, frame.layout, frame.matrix, frame.display),
  };
}
