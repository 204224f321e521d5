// The one rule for a display's part of the wall's camera: the wall is a window, the eye
// stands `eye.distance_mm` in front of the scene point (eye.x, eye.y), and a display sees
// through its own rectangle of that window. Its frustum is off centre: left, right, top,
// bottom are tangents (the near plane's edges at distance 1), in the display's own pixel
// axes (a panel turned a quarter sees the window turned with it), and `up` says which way
// the top of its picture faces in the wall's own right and up (the camera's right and up:
// straight down, north up, those are east and north; globe.js turns them with the camera). Every display has the same
// eye, so a straight line on the ground runs on straight across the bezels (overlay mode:
// the scene is the wall's mm, bezels included; offset mode: the bezels squeezed out).

/**
 * @param {{to_pixels: number[], resolution: number[], rotation: number}} display
 *   to_pixels maps scene mm to the display's native pixels (x' = a x + c y + e,
 *   y' = b x + d y + f); resolution is the native [width, height]
 * @param {{x: number, y: number, distance_mm: number}} eye
 * @returns {{left: number, right: number, top: number, bottom: number, up: number[]}}
 */
export function displayFrustum(display, eye) {
  const [a, b, c, d, e, f] = display.to_pixels;
  const det = a * d - b * c;
  // native pixels -> scene mm: the inverse of to_pixels
  const toScene = (px, py) => [
    (d * (px - e) - c * (py - f)) / det,
    (-b * (px - e) + a * (py - f)) / det,
  ];
  const [width, height] = display.resolution;
  const origin = toScene(0, 0);
  const along = toScene(width, 0);
  const down = toScene(0, height);
  const unit = (p) => {
    const v = [p[0] - origin[0], p[1] - origin[1]];
    const length = Math.hypot(v[0], v[1]);
    return [v[0] / length, v[1] / length];
  };
  const ex = unit(along);  // the picture's x axis, in scene mm
  const ey = unit(down);  // the picture's y axis (downwards), in scene mm
  const at = (p, axis) => ((p[0] - eye.x) * axis[0] + (p[1] - eye.y) * axis[1]) / eye.distance_mm;
  const corner = toScene(width, height);
  const xs = [origin, along, down, corner].map((p) => at(p, ex));
  const ys = [origin, along, down, corner].map((p) => at(p, ey));
  return {
    left: Math.min(...xs),
    right: Math.max(...xs),
    top: -Math.min(...ys),
    bottom: -Math.max(...ys),
    // scene y runs down the wall: the picture's up (-ey) is -ey.x right and ey.y up
    up: [-ey[0], ey[1]],
  };
}
