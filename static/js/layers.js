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
//                                native px -> canvas px, codes(layout): the layout as
//                                the layers below adjust it}
//   codes(layout, frame)         optional: adjust the codes drawn (hide, relabel)
//   shown(state, redraw)         optional: after a frame is shown (refine an image)
//   due(state, now)              optional: server ms when the picture changes by itself
//   marks(state)                 optional: {key: text} a tile shows in its data-* marks
//   notes(state)                 optional: [text] what it shows otherwise than asked
//                                (a fallback), for the dashboard ("shows ... : why")
import {inverse, multiply} from "./matrix.js";

export class LayerStack {
  /** Load every layer module the page's apps use; `scene` as above. */
  static async load(scene) {
    const {apps, shared} = JSON.parse(document.body.dataset.layers);
    const urls = [...new Set([...Object.values(apps).flat(), ...shared])];
    const layers = new Map(await Promise.all(
      urls.map(async (url) => [url, (await import(url)).createLayer(scene)]),
    ));
    return new LayerStack(apps, shared, layers);
  }

  constructor(apps, shared, layers) {
    this.apps = apps;
    this.shared = shared;
    this.layers = layers;
  }

  /** The layers the state's app shows, bottom first. */
  of(state) {
    return [...(this.apps[state.app] ?? []), ...this.shared].map((url) => this.layers.get(url));
  }

  load(state) {
    return Promise.all(this.of(state).map((layer) => layer.load?.(state)));
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
    const frame = {
      state,
      display,
      clock,
      matrix,
      native: multiply(matrix, inverse(display.to_pixels)),
      codes: (layout) => layers.reduce(
        (adjusted, layer) => (adjusted && layer.codes ? layer.codes(adjusted, frame) : adjusted),
        layout,
      ),
    };
    for (const layer of layers) {
      ctx.save();
      layer.draw(ctx, frame);
      ctx.restore();
    }
  }
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
