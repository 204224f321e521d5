// The setup test pattern, drawn in scene millimetres. Callers set the transform
// (scene mm -> their pixels) before calling; this module knows no geometry of tiles.

const MINOR_MM = 100;
const MAJOR_MM = 500;

function visible(state, layer) {
  return state.layers?.[layer] ?? true;
}

// The view (centre as wall fraction, zoom) pans and zooms the pattern about the wall centre.
function applyView(ctx, wall, view) {
  const zoom = view?.zoom ?? 1;
  const [cx, cy] = view?.center ?? [0.5, 0.5];
  ctx.translate(wall.width / 2, wall.height / 2);
  ctx.scale(zoom, zoom);
  ctx.translate(-cx * wall.width, -cy * wall.height);
}

export function drawPattern(ctx, wall, state, pxPerMm) {
  const lw = 1 / pxPerMm;  // one device pixel, in mm
  ctx.fillStyle = "#10131a";
  ctx.fillRect(0, 0, wall.width, wall.height);
  for (const display of wall.displays) {
    const [x, y, w, h] = display.scene_rect;
    ctx.fillStyle = "#182030";
    ctx.fillRect(x, y, w, h);
  }

  ctx.save();
  applyView(ctx, wall, state.view);
  if (visible(state, "grid")) {
    for (let mm = 0; mm <= Math.max(wall.width, wall.height); mm += MINOR_MM) {
      const major = mm % MAJOR_MM === 0;
      ctx.strokeStyle = major ? "#5f7fbf" : "#34466b";
      ctx.lineWidth = (major ? 3 : 1) * lw;
      ctx.beginPath();
      if (mm <= wall.width) { ctx.moveTo(mm, 0); ctx.lineTo(mm, wall.height); }
      if (mm <= wall.height) { ctx.moveTo(0, mm); ctx.lineTo(wall.width, mm); }
      ctx.stroke();
    }
  }
  if (visible(state, "diagonals")) {
    ctx.strokeStyle = "#f2c14e";
    ctx.lineWidth = 4 * lw;
    ctx.beginPath();
    ctx.moveTo(0, 0); ctx.lineTo(wall.width, wall.height);
    ctx.moveTo(wall.width, 0); ctx.lineTo(0, wall.height);
    ctx.stroke();
    ctx.strokeStyle = "#e76f51";
    ctx.beginPath();
    const r = Math.min(wall.width, wall.height) * 0.45;
    ctx.arc(wall.width / 2, wall.height / 2, r, 0, 2 * Math.PI);
    ctx.stroke();
  }
  ctx.restore();

  if (visible(state, "labels")) {
    for (const display of wall.displays) {
      const [x, y, w, h] = display.scene_rect;
      const size = Math.min(w, h) / 6;
      ctx.fillStyle = "#ffffff";
      ctx.textAlign = "center";
      ctx.textBaseline = "middle";
      ctx.font = `bold ${size}px sans-serif`;
      ctx.fillText(display.id, x + w / 2, y + h / 2);
      ctx.font = `${size / 3}px sans-serif`;
      ctx.fillStyle = "#9fb3d9";
      const roles = display.roles.length ? ` · ${display.roles.join(", ")}` : "";
      ctx.fillText(`${wall.id} · ${display.node}:${display.index}${roles}`,
        x + w / 2, y + h / 2 + size);
    }
  }
}

/** The pattern app's layer; it steps aside for a volume the dashboard puts up. */
export function createLayer({wall}) {
  return {
    name: "pattern",
    draw(ctx, {state, matrix}) {
      if (state.volume) return;
      ctx.setTransform(...matrix);
      drawPattern(ctx, wall, state, Math.hypot(matrix[0], matrix[1]));
    },
  };
}
