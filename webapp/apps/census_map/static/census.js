// The census map on a tile: the server sends each tile its share of the map in the
// tile's own pixels (outlines clipped and simplified, labels, groups, codes); the
// tile draws it, hiding the groups whose layer is off, so a toggle is instant. When the
// wall's state names a theme, the tracts take their class's colour and the legend
// stands where the server placed it (webapp/apps/census_map/legend.py).

import {fitText} from "tagwall/balloons.js";
import {angleOf, upright} from "tagwall/matrix.js";
import {Globe, globeMissing} from "./globe.js";

/** The census map's slot of the wall state: {dataset, theme} (both null: not set up),
 * surface "flat" or "globe", the globe camera's heading and tilt, the tour. */
export function censusOf(state) {
  return {
    dataset: null, theme: null, surface: "flat", heading: 0, tilt: 0,
    tour: {steps: [], playing: false, step: 0, run: 0, note: ""},
    ...state?.apps?.census,
  };
}

const KEEP = 4;
// The legend's box as the codes' captions have theirs (static/js/codes.js), its text a
// little under white: codes' modules stay the lightest things on the wall.
const LEGEND = {backing: "#10161f", text: "#e6e6e6"};

export function groupShown(state, groupId) {
  return state.layers?.[groupId] ?? true;
}

export class CensusViews {
  constructor(wallId, tileId) {
    this.base = `/api/apps/census/walls/${wallId}/tiles/${tileId}`;
    this.views = new Map();  // the map's share per view, the latest few
    this.themes = new Map();  // the colouring per theme, apart: a pan never drops it
  }

  /** The query of the wall's theme (null: the plain map); the same for every tile.
   * The view, surface and globe's camera go with it: the legend keeps off the map, where
   * the wall shows it, where it can. */
  static themeKeyOf(state) {
    const {dataset, theme, surface, heading, tilt} = censusOf(state);
    if (state?.app !== "census" || !dataset || !theme) return null;
    const [cx, cy] = state.view?.center ?? [0.5, 0.5];
    const camera = surface === "globe" ? {surface, heading, tilt} : {};
    return new URLSearchParams({
      dataset, layout: state.tag_layout ?? 0, cx, cy, zoom: state.view?.zoom ?? 1,
      attribute: theme.attribute, scheme: theme.scheme, method: theme.method,
      classes: theme.classes, ...camera,
    }).toString();
  }

  /** The query of the map on the globe: the same for every tile (null: flat). */
  static globeKeyOf(state) {
    const {dataset, surface, heading, tilt} = censusOf(state);
    if (state?.app !== "census" || !dataset || surface !== "globe") return null;
    const [cx, cy] = state.view?.center ?? [0.5, 0.5];
    return new URLSearchParams({
      dataset, cx, cy, zoom: state.view?.zoom ?? 1, heading, tilt,
    }).toString();
  }

  static keyOf(state) {
    const {dataset} = censusOf(state);
    if (state?.app !== "census" || !dataset) return null;
    const [cx, cy] = state.view?.center ?? [0.5, 0.5];
    const query = new URLSearchParams({
      dataset, layout: state.tag_layout ?? 0, cx, cy, zoom: state.view?.zoom ?? 1,
    });
    return query.toString();
  }

  get(state) {
    return this.views.get(CensusViews.keyOf(state));
  }

  /** The wall's theme as loaded (null: the plain map). */
  theme(state) {
    return this.themes.get(CensusViews.themeKeyOf(state)) ?? null;
  }

  async load(state) {
    await Promise.all([
      this.fetchInto(this.views, CensusViews.keyOf(state), ""),
      this.fetchInto(this.themes, CensusViews.themeKeyOf(state), "/theme"),
    ]);
  }

  async fetchInto(kept, key, path) {
    if (!key || kept.has(key)) return;
    const response = await fetch(`${this.base}${path}?${key}`);
    if (!response.ok) throw new Error(`census map${path}: ${response.status}`);
    kept.set(key, await response.json());
    while (kept.size > KEEP) kept.delete(kept.keys().next().value);
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
 * separates, as wide as read from the seats). With a `theme`, each tract takes its
 * class's fill (stripes: no value) and an outline inside its own edge in the colour
 * that stands out from that fill, so every border reads whatever meets there. */
export function drawCensus(ctx, view, state, display, theme = null) {
  const colours = view.colours;
  ctx.fillStyle = colours.background;
  ctx.fillRect(0, 0, ...display.resolution);
  const shown = view.tracts.filter((tract) => groupShown(state, tract.group));
  const stripes = theme ? stripePattern(ctx, theme.missing) : null;
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
    if (!theme) {
      ctx.fill("evenodd");
      ctx.stroke();
      continue;
    }
    const style = styleOf(theme, tract.id);
    ctx.fillStyle = style.stripe ? stripes : style.fill;
    ctx.fill("evenodd");
    ctx.save();
    ctx.clip("evenodd");
    ctx.strokeStyle = style.line;
    ctx.lineWidth = 2 * view.outline_px;  // half of it lies inside the tract
    ctx.stroke();
    ctx.restore();
  }
  drawLabels(ctx, shown, view.label_px, angleOf(display.to_pixels),
    (tract) => (theme ? styleOf(theme, tract.id).line : colours.label));
}

/** How a tract is drawn under `theme`: its class's row of the legend. */
export function styleOf(theme, tractId) {
  const index = theme.tracts[tractId] ?? -1;
  return index >= 0 ? theme.classes[index] : theme.missing;
}

function stripePattern(ctx, missing) {
  const tile = document.createElement("canvas");
  tile.width = tile.height = 16;
  const g = tile.getContext("2d");
  g.fillStyle = missing.fill;
  g.fillRect(0, 0, 16, 16);
  g.strokeStyle = missing.stripe;
  g.lineWidth = 4;
  for (const offset of [-16, 0, 16]) {
    g.beginPath();
    g.moveTo(offset, 16);
    g.lineTo(offset + 16, 0);
    g.stroke();
  }
  return ctx.createPattern(tile, "repeat");
}

/** The legend, in scene mm (the caller's transform), where the server placed it clear of
 * every code: the value's name, how it was cut, and a swatch per class with its range
 * and how many tracts it holds. */
export function drawLegend(ctx, legend, stripes) {
  if (!legend.rect) return;
  const [x, y, w, h] = legend.rect;
  const font = legend.font_mm;
  const pad = font / 2;
  const line = 1.35 * font;
  const room = w - 2 * pad;
  ctx.fillStyle = LEGEND.backing;
  ctx.strokeStyle = LEGEND.text;
  ctx.lineWidth = font / 10;
  ctx.fillRect(x, y, w, h);
  ctx.strokeRect(x, y, w, h);
  ctx.textAlign = "left";
  ctx.textBaseline = "top";
  ctx.fillStyle = LEGEND.text;
  fitText(ctx, legend.title, x + pad, y + pad, room, font, "bold ");
  fitText(ctx, legend.note, x + pad, y + pad + line, room, font * 0.8, "");
  legend.rows.forEach((row, i) => {
    const top = y + pad + line * (i + 2);
    ctx.fillStyle = row.stripe ? stripes : row.fill;
    ctx.fillRect(x + pad, top, 2 * font, font);
    ctx.strokeRect(x + pad, top, 2 * font, font);
    ctx.fillStyle = LEGEND.text;
    fitText(ctx, row.text, x + pad + 3 * font, top, room - 3 * font, font, "");
  });
}

// Tract numbers where they fit inside their tract and stay clear of every code and
// caption (the server says which: label_clear); a tract with its own code is named by
// the code's caption. Each is turned by `angle`, upright as the panel hangs, in
// `colourOf(tract)`.
function drawLabels(ctx, tracts, size, angle, colourOf) {
  ctx.font = `bold ${Math.round(size)}px sans-serif`;
  ctx.textAlign = "center";
  ctx.textBaseline = "middle";
  for (const tract of tracts) {
    if (tract.code || !tract.label_clear) continue;  // codes' captions name their tracts
    const width = ctx.measureText(tract.label).width;
    if (width > 2 * tract.room) continue;
    ctx.fillStyle = colourOf(tract);
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

/** How a tract looks on the globe: the flat map's colours, `shown` as its group is. */
function globeStyle(view, theme, state) {
  return (tract) => {
    const shown = groupShown(state, tract.group);
    if (!theme) return {fill: view.colours.fill, line: view.colours.outline, shown};
    const style = styleOf(theme, tract.id);
    return {fill: style.fill, line: style.line, shown};
  };
}

/** The globe's part of a tile: the wall's map on CesiumJS, its last pictures kept, so a
 * prepared change costs the frame only a copy. Where the browser has no WebGL, or
 * Cesium fails, `missing` says why and the tile draws the flat map. */
class GlobeLayer {
  constructor(wallId, display) {
    this.base = `/api/apps/census/walls/${wallId}/globe`;
    this.display = display;
    this.maps = new Map();
    this.globe = null;
    this.missing = "";
    // The last few pictures by look, ready to copy: changes prepared one after another
    // (a turn, then a tilt) each find their own picture at their swap, rather than
    // rendering it again in the frame (hundreds of ms under software GL: tiles apart).
    this.pictures = new Map();
    this.loading = Promise.resolve();
  }

  /** Prepare the picture of `state`. One at a time: a tile prepares a snapshot and the
   * changes that arrive meanwhile at once, and each aims the one globe (two at once
   * each rendered the other's camera, and one kept it as its own picture). */
  load(state, views) {
    this.loading = this.loading.then(() => this.loadNow(state, views));
    return this.loading;
  }

  async loadNow(state, views) {
    const key = CensusViews.globeKeyOf(state);
    if (!key || this.missing) return;
    try {
      if (!this.globe) {
        this.missing = globeMissing();
        if (this.missing) return;
      }
      if (!this.maps.has(key)) {
        const response = await fetch(`${this.base}?${key}`);
        if (!response.ok) throw new Error(`census globe: ${response.status}`);
        this.maps.set(key, await response.json());
        while (this.maps.size > KEEP) this.maps.delete(this.maps.keys().next().value);
      }
      // on the site's imagery and terrain, where it has them (the same for every map)
      this.globe ??= await Globe.create(this.display, this.maps.get(key).ground ?? {});
      const look = this.look(state, views);
      if (!look) return;
      this.globe.show(look.map, look.style);
      this.globe.restyle(look.styleKey, look.style);
      await this.globe.settle();
      if (this.globe.map !== look.map || this.globe.styleKey !== look.styleKey) {
        // a frame drawn meanwhile (pictureOf: a light change) aimed it at its own look
        this.globe.show(look.map, look.style);
        this.globe.restyle(look.styleKey, look.style);
        this.globe.render();
      }
      this.keep(look.key);
    } catch (error) {
      this.missing = `globe failed: ${error.message ?? error}`;
      console.error(error, error?.stack);
    }
  }

  /** What the state shows on the globe, or null (flat, or not loaded). */
  look(state, views) {
    const key = CensusViews.globeKeyOf(state);
    const map = key && this.maps.get(key);
    const view = views.get(state);
    if (!map || !view || !this.globe || this.missing) return null;
    const theme = views.theme(state);
    const styleKey = JSON.stringify([
      CensusViews.themeKeyOf(state), state.layers ?? {}, map.dataset,
    ]);
    return {map, key: `${key}|${styleKey}`, styleKey, style: globeStyle(view, theme, state)};
  }

  keep(key) {
    const source = this.globe.canvas;
    let canvas = this.pictures.get(key);
    this.pictures.delete(key);
    if (!canvas && this.pictures.size >= KEEP) {
      canvas = this.pictures.values().next().value;  // the oldest's canvas, reused
      this.pictures.delete(this.pictures.keys().next().value);
    }
    canvas ??= document.createElement("canvas");
    canvas.width = source.width;
    canvas.height = source.height;
    canvas.getContext("2d").drawImage(source, 0, 0);
    this.pictures.set(key, canvas);
  }

  /** The picture for `state` (rendered now unless prepared), or null: draw flat. */
  pictureOf(state, views) {
    const look = this.look(state, views);
    if (!look) return null;
    if (!this.pictures.has(look.key)) {
      this.globe.show(look.map, look.style);
      this.globe.restyle(look.styleKey, look.style);
      this.globe.render();
      this.keep(look.key);
    }
    return this.pictures.get(look.key);
  }
}

/** The census app's layer: each display's share of the map (and on the menu screen,
 * the caption), its codes as the groups shown say. On the globe (the state's
 * `surface`), a tile shows its part of the wall's one camera instead of its share of
 * the flat map; the caption, legend and codes stay where they are. */
export function createLayer({wall, displays}) {
  const views = new Map(displays.map((d) => [d.id, new CensusViews(wall.id, d.id)]));
  // The overview draws the flat map; a tile (one display) draws the globe when asked.
  const globe = displays.length === 1 ? new GlobeLayer(wall.id, displays[0]) : null;
  return {
    name: "census",
    async load(state) {
      await Promise.all([...views.values()].map((view) => view.load(state)));
      if (globe) await globe.load(state, views.get(displays[0].id));
    },
    draw(ctx, {state, display, native, matrix}) {
      const loaded = views.get(display.id);
      const view = loaded.get(state);
      if (!view) return;
      const theme = loaded.theme(state);
      ctx.setTransform(...native);
      const picture = globe?.pictureOf(state, loaded);
      if (picture) {
        ctx.drawImage(picture, 0, 0, ...display.resolution);
      } else {
        drawCensus(ctx, view, state, display, theme);
      }
      if (display.roles.includes("menu")) drawCaption(ctx, view, display);
      if (theme) {
        ctx.setTransform(...matrix);
        drawLegend(ctx, theme.legend, stripePattern(ctx, theme.missing));
      }
    },
    codes: (layout, {state, display}) => codesShown(layout, views.get(display.id), state),
    notes(state) {
      if (CensusViews.globeKeyOf(state) == null || !globe) return [];
      if (globe.missing) return [`shows the flat map: ${globe.missing}`];
      return globe.globe?.notes() ?? [];
    },
    marks(state) {
      const loaded = displays.length === 1 ? views.get(displays[0].id) : null;
      const view = loaded?.get(state);
      const theme = loaded?.theme(state);
      const onGlobe = CensusViews.globeKeyOf(state) != null;
      return {
        census: view ? `${view.dataset} ${view.tracts.length}` : "",
        censusTheme: theme ? `${censusOf(state).theme.attribute} ${theme.classes.length}` : "",
        // "globe" when it shows, "flat: <why>" when a tile asked for it cannot (its note)
        censusSurface: !onGlobe ? "flat"
          : (globe?.missing ? `flat: ${globe.missing}` : (globe?.look(state, loaded) ? "globe" : "")),
      };
    },
  };
}
