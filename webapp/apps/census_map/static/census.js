// The census map on a tile: the server sends each tile its share of the map in the
// tile's own pixels (outlines clipped and simplified, labels, groups, codes); the
// tile draws it, hiding the groups whose layer is off, so a toggle is instant.

import {angleOf, upright} from "/static/js/matrix.js";

const KEEP = 4;

export function groupShown(state, groupId) {
  return state.layers?.[groupId] ?? true;
}

export class CensusViews {
  constructor(wallId, tileId) {
    this.base = `/api/walls/${wallId}/tiles/${tileId}/census`;
    this.views = new Map();
  }

  static keyOf(state) {
    if (state?.app !== "census" || !state.dataset) return null;
    const [cx, cy] = state.view?.center ?? [0.5, 0.5];
    const query = new URLSearchParams({
      dataset: state.dataset, layout: state.tag_layout ?? 0, cx, cy, zoom: state.view?.zoom ?? 1,
    });
    return query.toString();
  }

  get(state) {
    return this.views.get(CensusViews.keyOf(state));
  }

  async load(state) {
    const key = CensusViews.keyOf(state);
    if (!key || this.views.has(key)) return;
    const response = await fetch(`${this.base}?${key}`);
    if (!response.ok) throw new Error(`census map: ${response.status}`);
    this.views.set(key, await response.json());
    while (this.views.size > KEEP) this.views.delete(this.views.keys().next().value);
  }

  /** Codes of tracts in hidden groups, and cluster codes all of whose tracts are
   * hidden: the tile leaves them out with their tracts. */
  hiddenCodes(state) {
    const view = this.get(state);
    const hidden = new Set();
    if (!view) return hidden;
    for (const tract of view.tracts) {
      if (tract.code && !groupShown(state, tract.group)) hidden.add(tract.code);
    }
    for (const [code, groups] of Object.entries(view.clusters ?? {})) {
      if (groups.every((group) => !groupShown(state, group))) hidden.add(code);
    }
    return hidden;
  }
}

/** The tracts, in the display's native pixels (the caller's transform maps those to
 * its canvas). Colours and the outline's width come with the view
 * (webapp/apps/census_map/mapview.py keeps the outline in contrast with the fills it
 * separates, as wide as read from the seats). */
export function drawCensus(ctx, view, state, display) {
  const colours = view.colours;
  ctx.fillStyle = colours.background;
  ctx.fillRect(0, 0, ...display.resolution);
  const shown = view.tracts.filter((tract) => groupShown(state, tract.group));
  ctx.fillStyle = colours.fill;
  ctx.strokeStyle = colours.outline;
  ctx.lineWidth = view.outline_px;
  ctx.lineJoin = "round";
  for (const tract of shown) {
    ctx.beginPath();
    for (const ring of tract.rings) {
      ctx.moveTo(ring[0], ring[1]);
      for (let i = 2; i < ring.length; i += 2) ctx.lineTo(ring[i], ring[i + 1]);
      ctx.closePath();
    }
    ctx.fill("evenodd");
    ctx.stroke();
  }
  drawLabels(ctx, shown, view.label_px, colours.label, angleOf(display.to_pixels));
}

// Tract numbers where they fit inside their tract and stay clear of every code and
// caption (the server says which: label_clear); a tract with its own code is named by
// the code's caption. Each is turned by `angle`, upright as the panel hangs.
function drawLabels(ctx, tracts, size, colour, angle) {
  ctx.font = `bold ${Math.round(size)}px sans-serif`;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  ctx.fillStyle = colour;
  for (const tract of tracts) {
    if (tract.code || !tract.label_clear) continue;  // codes' captions name their tracts
    const width = ctx.measureText(tract.label).width;
    if (width > 2 * tract.room) continue;
    ctx.save();
    ctx.translate(tract.at[0], tract.at[1]);
    ctx.rotate(angle);
    ctx.fillText(tract.label, 0, 0);
    ctx.restore();
  }
}

/** The layout without the codes of hidden groups (with what they stand on), each
 * group toggle's label saying whether its group is shown now. */
export function codesShown(layout, views, state) {
  const view = views.get(state);
  if (!view) return layout;
  const hidden = views.hiddenCodes(state);
  const placed = layout.placed.filter((code) => !hidden.has(code.code)).map((code) => {
    const group = view.toggles[code.code];
    if (!group) return code;
    return {...code, label: `${code.label} · ${groupShown(state, group) ? "shown" : "hidden"}`};
  });
  return {...layout, placed};
}

/** On the menu screen, along its bottom edge as the panel hangs: how many tracts
 * carry codes. */
export function drawCaption(ctx, view, display) {
  if (!view.caption) return;
  const hanging = upright(display);
  const [width, height] = hanging.size;
  ctx.save();
  ctx.transform(...hanging.matrix);
  const size = Math.round(view.label_px);
  ctx.font = `${size}px sans-serif`;
  const fit = Math.min(1, (width - 2 * size) / ctx.measureText(view.caption).width);
  ctx.font = `${Math.floor(size * fit)}px sans-serif`;
  ctx.fillStyle = "#e8ecf4";
  ctx.textAlign = "right";
  ctx.textBaseline = "bottom";
  ctx.fillText(view.caption, width - size / 2, height - size / 2);
  ctx.restore();
}

/** The census app's layer: each display's share of the map (and on the menu screen,
 * the caption), its codes as the groups shown say. */
export function createLayer({wall, displays}) {
  const views = new Map(displays.map((d) => [d.id, new CensusViews(wall.id, d.id)]));
  return {
    name: "census",
    load: (state) => Promise.all([...views.values()].map((view) => view.load(state))),
    draw(ctx, {state, display, native}) {
      const view = views.get(display.id).get(state);
      if (!view) return;
      ctx.setTransform(...native);
      drawCensus(ctx, view, state, display);
      if (display.roles.includes("menu")) drawCaption(ctx, view, display);
    },
    codes: (layout, {state, display}) => codesShown(layout, views.get(display.id), state),
    marks(state) {
      const view = displays.length === 1 ? views.get(displays[0].id).get(state) : null;
      return {census: view ? `${view.dataset} ${view.tracts.length}` : ""};
    },
  };
}
