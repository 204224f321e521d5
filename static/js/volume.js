// A volume across the wall: each tile shows the server's render of its own part.
// The quick fallback image is loaded before a view change is swapped in, so every
// tile changes together; the refined image follows and replaces it when it arrives.

const KEEP = 4;  // scenes whose images are kept (the one shown and those coming)

export class VolumeImages {
  /**
   * @param {string} wallId
   * @param {string} tileId
   * @param {string|null} token the tile token (refined images need it, or a staff session)
   */
  constructor(wallId, tileId, token = null) {
    this.base = `/api/walls/${wallId}/tiles/${tileId}/volume`;
    this.token = token;
    this.images = new Map();   // scene key -> {bitmap, scale, level, detail}
    this.refining = new Set();
  }

  static sceneOf(state) {
    return state?.volume ? JSON.stringify({view: state.view, volume: state.volume}) : null;
  }

  url(scene, detail) {
    const query = new URLSearchParams({scene, detail});
    if (this.token) query.set("token", this.token);
    return `${this.base}?${query}`;
  }

  async fetch(scene, detail) {
    const response = await fetch(this.url(scene, detail));
    if (!response.ok) throw new Error(`volume image: ${response.status}`);
    const bitmap = await createImageBitmap(await response.blob());
    return {
      bitmap,
      detail,
      scale: Number(response.headers.get("X-Pixel-Scale")) || 1,
      level: Number(response.headers.get("X-Volume-Level")),
    };
  }

  /** Before the swap: the state's fallback image (nothing to do if one is loaded). */
  async load(state) {
    const scene = VolumeImages.sceneOf(state);
    if (!scene || this.images.has(scene)) return;
    this.remember(scene, await this.fetch(scene, "fallback"));
  }

  /** After the swap: fetch the refined image, then call redraw(). */
  refine(state, redraw) {
    const scene = VolumeImages.sceneOf(state);
    const entry = scene && this.images.get(scene);
    if (!entry || entry.detail === "refined" || this.refining.has(scene)) return;
    this.refining.add(scene);
    this.fetch(scene, "refined")
      .then((image) => { this.remember(scene, image); redraw(); })
      .catch(() => undefined)  // the fallback stays up; the next view tries again
      .finally(() => this.refining.delete(scene));
  }

  remember(scene, image) {
    this.images.get(scene)?.bitmap.close();
    this.images.delete(scene);
    this.images.set(scene, image);
    while (this.images.size > KEEP) {
      const [oldest, old] = this.images.entries().next().value;
      old.bitmap.close();
      this.images.delete(oldest);
    }
  }

  /** The best image loaded for the state, or null. */
  get(state) {
    const scene = VolumeImages.sceneOf(state);
    return (scene && this.images.get(scene)) || null;
  }
}

/**
 * Draw the image in the tile's native pixels: it covers (width x scale, height x scale).
 * @param {CanvasRenderingContext2D} ctx with its transform at native tile pixels
 */
export function drawVolume(ctx, image) {
  ctx.fillStyle = "#000";
  ctx.fillRect(0, 0, image.bitmap.width * image.scale, image.bitmap.height * image.scale);
  ctx.imageSmoothingEnabled = true;
  ctx.imageSmoothingQuality = "high";
  ctx.drawImage(image.bitmap, 0, 0, image.bitmap.width * image.scale,
    image.bitmap.height * image.scale);
}

/** The volume layer (apps that show a volume): each display's image of the wall
 * state's volume, refined after the swap on tiles (they hold the tile token). */
export function createLayer({wall, displays, token}) {
  const images = new Map(displays.map((d) => [d.id, new VolumeImages(wall.id, d.id, token)]));
  return {
    name: "volume",
    load: (state) => Promise.all([...images.values()].map((image) => image.load(state))),
    draw(ctx, {state, display, native}) {
      const image = images.get(display.id).get(state);
      if (!image) return;
      ctx.setTransform(...native);
      drawVolume(ctx, image);
    },
    shown(state, redraw) {
      if (token) for (const image of images.values()) image.refine(state, redraw);
    },
    marks(state) {
      const image = displays.length === 1 ? images.get(displays[0].id).get(state) : null;
      return {volume: image ? `${image.detail} ${image.level}` : ""};
    },
  };
}
