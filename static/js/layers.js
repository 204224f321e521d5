// The scene's layer registry: tiles and the overview draw the wall scene through the
// same ordered layers, so what the overview shows is what the tiles show.
//
// The server lists, per app, the modules that draw its scene (bottom first) and the
// shared ones drawn over every app's (codes, balloons): data-layers on the page. Each
// module exports createLayer(scene), scene = {wall, displays, token}: the displays the
// page draws (a tile: its own; the overview: all) and the tile token (or null). A layer:
//   name
//   load(state) -> Promise       fetch what the state needs, before it is shown
//   draw(ctx, frame)             draw one display's part; frame = {state, display, clock,
//                                matrix: scene mm -> canvas px, native: the display's
//                                native px -> canvas px, layout: the placed codes as
//                                the layers adjust them, keepClear: the scene-mm boxes
//                                {x, y, width, height, what: "code"|"screen", role}
//                                of the codes (with captions) and of the designated
//                                screens, which an app's drawing keeps clear of}
//   codes(layout, frame)         optional: adjust the codes drawn (hide, relabel)
//   shown(state, redraw)         optional: after a frame is shown (refine an image)
//   due(state, now)              optional: server ms when the picture changes by itself
//   marks(state)                 optional: {key: text} a tile shows in its data-* marks
//   notes(state)                 optional: [text] what it shows otherwise than asked
//                                (a fallback), for the dashboard ("shows ... : why")
import {CodeLayouts} from "./codes.js";
import {inverse, multiply} from "./matrix.js";

export class LayerStack {
  /** Load every layer module the page's apps use; `scene` as above. */
  static async load(scene) {
    const {apps, shared} = JSON.parse(document.body.dataset.layers);
    const urls = [...new Set([...Object.values(apps).flat(), ...shared])];
    const layers = new Map(await Promise.all(
      urls.map(async (url) => [url, (await import(url)).createLayer(scene)]),
    ));
    const one = scene.displays.length === 1 ? scene.displays[0].id : null;
    return new LayerStack(apps, shared, layers, new CodeLayouts(scene.wall.id, one),
      screenBoxes(scene.wall));
  }

  constructor(apps, shared, layers, layouts, screens) {
    this.apps = apps;
    this.shared = shared;
    this.layers = layers;
    this.layouts = layouts;
    this.screens = screens;
  }

  /** The layers the state's app shows, bottom first. */
  of(state) {
    return [...(this.apps[state.app] ?? []), ...this.shared].map((url) => this.layers.get(url));
  }

  load(state) {
    return Promise.all([
      this.layouts.load(state.tag_layout),
      ...this.of(state).map((layer) => layer.load?.(state)),
    ]);
  }

  shown(state, redraw) {
    for (const layer of this.of(state)) layer.shown?.(state, redraw);
  }

  /** When the picture next changes by itself (server ms), or null. */
  due(state, now) {
    const times = this.of(state).map((layer) => layer.due?.(state, now)).filter((t) => t != null);
    return times.length ? Math.min(...times) : null;
  }

  /** What the layers shown draw otherwise than the state asks, in words. */
  notes(state) {
    return this.of(state).flatMap((layer) => layer.notes?.(state) ?? []);
  }

  /** Every layer's marks; a layer the state's app does not show marks nothing. */
  marks(state) {
    const shown = new Set(this.of(state));
    const marks = {};
    for (const layer of this.layers.values()) {
      for (const [key, text] of Object.entries(layer.marks?.(state) ?? {})) {
        marks[key] = shown.has(layer) ? text : "";
      }
    }
    return marks;
  }

  /**
   * Draw one display's part of the scene. `matrix` maps scene mm to the canvas's
   * device pixels (a tile: its viewport fitted to the canvas; the overview: the
   * display placed on the wall by to_wall); the caller clips to the display.
   */
  draw(ctx, state, display, matrix, clock) {
    const layers = this.of(state);
    const placed = this.layouts.get(state.tag_layout);
    const screens = this.screens;
    let adjusted;
    const frame = {
      state,
      display,
      clock,
      matrix,
      native: multiply(matrix, inverse(display.to_pixels)),
      get layout() {
        if (adjusted === undefined) {
          adjusted = layers.reduce(
            (codes, layer) => (codes && layer.codes ? layer.codes(codes, frame) : codes), placed,
          ) ?? null;
        }
        return adjusted;
      },
      get keepClear() {
        return [...screens, ...codeBoxes(this.layout)];
      },
    };
    for (const layer of layers) {
      ctx.save();
      layer.draw(ctx, frame);
      ctx.restore();
    }
  }
}

/** The designated screens' boxes in scene mm: whole displays (their roles). */
function screenBoxes(wall) {
  return wall.displays.flatMap((d) => d.roles.map((role) => {
    const [x, y, width, height] = d.scene_rect;
    return {x, y, width, height, what: "screen", role};
  }));
}

/** Each placed code's box in scene mm, its caption's strip included. */
function codeBoxes(layout) {
  return (layout?.placed ?? []).map((code) => {
    const [x, y, side] = code.rect;
    const [cx, cy, cw, ch] = code.caption ?? [x, y, side, side];
    const left = Math.min(x, cx);
    const top = Math.min(y, cy);
    const width = Math.max(x + side, cx + cw) - left;
    const height = Math.max(y + side, cy + ch) - top;
    return {x: left, y: top, width, height, what: "code", role: null};
  });
}

/** Redraw when the picture changes by itself (a balloon closing), then look again. */
export function followClock(stack, state, redraw, clock, onRedraw = () => {}) {
  clearTimeout(followClock.timer);
  const due = stack.due(state, clock());
  if (due == null) return;
  followClock.timer = setTimeout(() => {
    if (redraw()) {
      onRedraw();
      followClock(stack, state, redraw, clock, onRedraw);
    }
  }, Math.max(0, due - clock()) + 1);
}
