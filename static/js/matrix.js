// Affine maps as canvases take them ([a, b, c, d, e, f], see setTransform). The server
// computes every map a page needs (wall_client/layout.py); pages only combine them.

export function apply([a, b, c, d, e, f], x, y) {
  return [a * x + c * y + e, b * x + d * y + f];
}

export function inverse([a, b, c, d, e, f]) {
  const det = a * d - b * c;
  return [d / det, -b / det, -c / det, a / det, (c * f - d * e) / det, (b * e - a * f) / det];
}

/** The map that applies `inner` first, then `outer`. */
export function multiply([a2, b2, c2, d2, e2, f2], [a1, b1, c1, d1, e1, f1]) {
  return [
    a2 * a1 + c2 * b1, b2 * a1 + d2 * b1, a2 * c1 + c2 * d1, b2 * c1 + d2 * d1,
    a2 * e1 + c2 * f1 + e2, b2 * e1 + d2 * f1 + f2,
  ];
}

/** How far the scene turns on its way to the display's native pixels: the panel's
 * rotation, by which text turns to read upright as the panel hangs. */
export function angleOf([a, b]) {
  return Math.atan2(b, a);
}

/**
 * A mark `px` of the display's own pixels wide (a pin's line, its head), in scene mm,
 * given the canvas's `matrix` (scene mm -> canvas px): as large on the overview as on
 * the wall, where it stays at least `least` canvas px so it can be seen.
 */
export function markMm(px, display, matrix, least = 2) {
  const [a, b] = display.to_pixels;
  return Math.max(px / Math.hypot(a, b), least / Math.hypot(matrix[0], matrix[1]));
}

/**
 * A display's pixels as the panel hangs (x to the right and y down on the wall):
 * `matrix` maps them to the native framebuffer pixels the tile draws in, `size` is
 * their extent ([width, height], swapped on a turned panel).
 */
export function upright(display) {
  const angle = angleOf(display.to_pixels);
  const [cos, sin] = [Math.round(Math.cos(angle)), Math.round(Math.sin(angle))];
  const [x0, y0] = apply(display.to_pixels, display.scene_rect[0], display.scene_rect[1]);
  const [width, height] = display.resolution;
  return {matrix: [cos, sin, -sin, cos, x0, y0], size: sin ? [height, width] : [width, height]};
}
