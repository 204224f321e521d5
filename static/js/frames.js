// Double buffering: the next frame is drawn off screen ahead of its instant, and shown
// at that instant by swapping two stacked canvases, which costs next to nothing. Drawing
// time differs per tile; the swap does not, so tiles change together.

export class Frames {
  /** @param {HTMLElement} element the box the frames fill */
  constructor(element) {
    this.element = element;
    this.canvases = [0, 1].map(() => {
      const canvas = document.createElement("canvas");
      canvas.className = "frame";
      canvas.hidden = true;
      element.append(canvas);
      return canvas;
    });
    this.front = 0;
    this.canvases[0].hidden = false;
  }

  get visible() {
    return this.canvases[this.front];
  }

  /** Draw into the hidden canvas now; returns the function that shows it. */
  prepare(draw) {
    const back = this.canvases[1 - this.front];
    this.paint(back, draw);
    return () => {
      back.hidden = false;
      this.visible.hidden = true;
      this.front = 1 - this.front;
    };
  }

  /** Draw the visible frame again in place (the window was resized). */
  redraw(draw) {
    this.paint(this.visible, draw);
  }

  paint(canvas, draw) {
    const ratio = window.devicePixelRatio || 1;
    const box = this.element.getBoundingClientRect();
    canvas.width = Math.round(box.width * ratio);
    canvas.height = Math.round(box.height * ratio);
    const ctx = canvas.getContext("2d");
    ctx.setTransform(1, 0, 0, 1, 0, 0);
    draw(ctx, canvas.width, canvas.height);
  }
}
