// The hello app's layer: a green band with the greeting across the whole wall.
export function createLayer({wall}) {
  return {
    name: "hello",
    draw(ctx, {state, matrix}) {
      const greeting = state.apps?.hello?.greeting ?? "Hello, wall";
      ctx.save();
      ctx.setTransform(...matrix);
      ctx.fillStyle = "#1f7a3a";
      ctx.fillRect(0, 0, wall.width, wall.height);
      ctx.fillStyle = "#ffffff";
      ctx.font = `bold ${wall.height / 12}px sans-serif`;
      ctx.textAlign = "center";
      ctx.fillText(greeting, wall.width / 2, wall.height / 4);
      ctx.restore();
    },
    marks(state) {
      return {hello: state.apps?.hello?.greeting ?? "Hello, wall"};
    },
  };
}
