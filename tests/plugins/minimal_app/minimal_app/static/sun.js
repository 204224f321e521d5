// The minimal app's layer: a yellow sky over the wall, a sun in the middle, and a dark
// margin around every code and designated screen (frame.keepClear), so the drawing never
// runs under them.
export function createLayer({wall}) {
  return {
    name: "minimal",
    draw(ctx, {matrix, keepClear}) {
      ctx.setTransform(...matrix);
      ctx.fillStyle = "#f4d35e";
      ctx.fillRect(0, 0, wall.width, wall.height);
      ctx.fillStyle = "#ee964b";
      ctx.beginPath();
      ctx.arc(wall.width / 2, wall.height / 2, wall.height / 6, 0, 2 * Math.PI);
      ctx.fill();
      ctx.fillStyle = "#0d3b66";
      for (const {x, y, width, height} of keepClear) {
        ctx.fillRect(x - 20, y - 20, width + 40, height + 40);
      }
      document.body.dataset.minimalClear = String(keepClear.length);
    },
  };
}
