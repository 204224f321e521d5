// The image app's layer: the wall's image from its Deep Zoom pyramid
// (webapp/apps/image/store.py). At zoom 1 the image fills the wall's stage (as large as
// fits, centred); the core's view pans and zooms it like the brain's. Each display
// fetches only the pyramid tiles it shows, at the level of its own pixel density: the
// coarse level (the whole image in one tile) before a change is swapped in, so every
// tile changes together, then the level that matches, which replaces it as it arrives.

const KEEP_TILES = 400;  // decoded pyramid tiles kept (a 4K display shows about 160)

/** The image app's slot of the wall state: the image id, or null. */
export function imageOf(state) {
  return state?.app === "image" ? state?.apps?.image?.image ?? null : null;
}

/** A stored image's pyramid: its manifest (GET .../info.json) and the maths of levels. */
export class Pyramid {
  constructor(manifest) {
    Object.assign(this, manifest);  // id, width, height, tile_size, levels
    this.top = this.levels - 1;
    this.coarse = this.top;
    while (this.coarse > 0 && Math.max(...this.levelSize(this.coarse)) > this.tile_size) {
      this.coarse--;
    }
  }

  /** How many full-size pixels one pixel of `level` stands for. */
  shrink(level) {
    return 2 ** (this.top - level);
  }

  levelSize(level) {
    const shrink = this.shrink(level);
    return [Math.ceil(this.width / shrink), Math.ceil(this.height / shrink)];
  }

  /** The coarsest level whose pixels are no larger than the canvas's, given canvas px
   * per full-size pixel; never below the coarse level (already loaded). */
  levelFor(canvasPerPixel) {
    const level = Math.ceil(this.top + Math.log2(canvasPerPixel) - 1e-6);
    return Math.min(this.top, Math.max(this.coarse, level));
  }

  /** Full-size pixels -> scene mm, [a, e, f] (x = a u + e, y = a v + f): the image as
   * large as fits on the stage at zoom 1, centred; the view's centre (a fraction of the
   * stage) comes to the stage's middle and the view zooms about it. */
  placement(stage, view) {
    const [sx, sy, sw, sh] = stage;
    const zoom = view?.zoom ?? 1;
    const [cx, cy] = view?.center ?? [0.5, 0.5];
    const fit = Math.min(sw / this.width, sh / this.height);
    return [
      zoom * fit,
      sx + sw / 2 + zoom * ((0.5 - cx) * sw - (this.width * fit) / 2),
      sy + sh / 2 + zoom * ((0.5 - cy) * sh - (this.height * fit) / 2),
    ];
  }

  /** The tiles of `level` that fall in the scene rect [x, y, w, h], as [col, row]. */
  tilesIn(level, [a, e, f], [x, y, w, h]) {
    const span = this.tile_size * this.shrink(level);  // full-size pixels per tile
    const [width, height] = this.levelSize(level);
    const cols = Math.ceil(width / this.tile_size);
    const rows = Math.ceil(height / this.tile_size);
    const col0 = Math.max(0, Math.floor((x - e) / a / span));
    const col1 = Math.min(cols - 1, Math.floor((x + w - e) / a / span));
    const row0 = Math.max(0, Math.floor((y - f) / a / span));
    const row1 = Math.min(rows - 1, Math.floor((y + h - f) / a / span));
    const tiles = [];
    for (let row = row0; row <= row1; row++) {
      for (let col = col0; col <= col1; col++) tiles.push([col, row]);
    }
    return tiles;
  }

  url(level, col, row) {
    return `/apps/image/images/${this.id}/${level}/${col}_${row}.jpg`;
  }
}

/** The pyramids and decoded tiles a page holds (tiles by URL, the latest used last). */
class ImageCache {
  constructor() {
    this.pyramids = new Map();
    this.bitmaps = new Map();
    this.fetching = new Map();
  }

  async pyramid(id) {
    if (!this.pyramids.has(id)) {
      const response = await fetch(`/apps/image/images/${id}/info.json`);
      if (!response.ok) throw new Error(`image ${id}: ${response.status}`);
      this.pyramids.set(id, new Pyramid(await response.json()));
    }
    return this.pyramids.get(id);
  }

  bitmap(url) {
    const bitmap = this.bitmaps.get(url);
    if (bitmap) {  // used again: the newest
      this.bitmaps.delete(url);
      this.bitmaps.set(url, bitmap);
    }
    return bitmap ?? null;
  }

  fetchTile(url) {
    if (this.bitmaps.has(url)) return Promise.resolve();
    if (!this.fetching.has(url)) {
      const fetched = fetch(url)
        .then((response) => {
          if (!response.ok) throw new Error(`${url}: ${response.status}`);
          return response.blob();
        })
        .then((blob) => createImageBitmap(blob))
        .then((bitmap) => this.keep(url, bitmap))
        .finally(() => this.fetching.delete(url));
      this.fetching.set(url, fetched);
    }
    return this.fetching.get(url);
  }

  keep(url, bitmap) {
    this.bitmaps.set(url, bitmap);
    while (this.bitmaps.size > KEEP_TILES) {
      const [oldest, old] = this.bitmaps.entries().next().value;
      old.close();
      this.bitmaps.delete(oldest);
    }
  }
}

/** The image layer: each display's share of the wall's image. */
export function createLayer({wall, displays}) {
  const cache = new ImageCache();
  const wanted = new Map();  // display id -> {key, level, urls}: what its last frame needs

  function sceneKey(state) {
    return JSON.stringify([imageOf(state), state.view]);
  }

  function draw(ctx, {state, display, matrix}) {
    ctx.setTransform(...matrix);
    ctx.fillStyle = "#000";
    ctx.fillRect(...display.scene_rect);
    const id = imageOf(state);
    const pyramid = id && cache.pyramids.get(id);
    if (!pyramid) return;
    const placed = pyramid.placement(wall.stage, state.view);
    const canvasPerPixel = Math.hypot(matrix[0], matrix[1]) * placed[0];
    const level = pyramid.levelFor(canvasPerPixel);
    const [a, e, f] = placed;
    ctx.transform(a, 0, 0, a, e, f);  // full-size image pixels from here
    ctx.imageSmoothingEnabled = true;
    ctx.imageSmoothingQuality = "high";
    const urls = [];
    // the coarse level under the one that matches: it fills whatever has not arrived
    for (const shown of new Set([pyramid.coarse, level])) {
      const shrink = pyramid.shrink(shown);
      const span = pyramid.tile_size * shrink;
      for (const [col, row] of pyramid.tilesIn(shown, placed, display.scene_rect)) {
        const url = pyramid.url(shown, col, row);
        if (shown === level) urls.push(url);
        const bitmap = cache.bitmap(url);
        if (bitmap) {
          ctx.drawImage(bitmap, col * span, row * span, bitmap.width * shrink,
            bitmap.height * shrink);
        }
      }
    }
    wanted.set(display.id, {key: sceneKey(state), level, urls});
  }

  return {
    name: "image",
    async load(state) {
      const id = imageOf(state);
      if (!id) return;
      const pyramid = await cache.pyramid(id);
      const placed = pyramid.placement(wall.stage, state.view);
      await Promise.all(displays.flatMap((display) => pyramid
        .tilesIn(pyramid.coarse, placed, display.scene_rect)
        .map(([col, row]) => cache.fetchTile(pyramid.url(pyramid.coarse, col, row)))));
    },
    draw,
    shown(state, redraw) {
      const key = sceneKey(state);
      const missing = [...wanted.values()]
        .filter((want) => want.key === key)
        .flatMap((want) => want.urls.filter((url) => !cache.bitmaps.has(url)));
      if (!missing.length) return;
      // one redraw when all have come (or failed: the coarse level stays under them)
      Promise.allSettled(missing.map((url) => cache.fetchTile(url))).then(() => redraw());
    },
    marks(state) {
      // one display (a tile): "refined 13" once every tile of its level is drawn,
      // "coarse 8" before
      const want = displays.length === 1 ? wanted.get(displays[0].id) : null;
      if (!want || want.key !== sceneKey(state)) return {image: ""};
      const pyramid = cache.pyramids.get(imageOf(state));
      const done = want.urls.every((url) => cache.bitmaps.has(url));
      return {image: done ? `refined ${want.level}` : `coarse ${pyramid.coarse}`};
    },
  };
}
