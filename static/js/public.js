// The public screen on a tile: what visitors published, shown full-screen over the
// scene. The HTML comes from the wall state, where only the server puts it, rendered
// with autoescaping from plain text (webapp/publishing.py); the page's CSP forbids
// inline script besides.

export class PublicScreen {
  /** @param {HTMLElement} element the box over the scene */
  constructor(element) {
    this.element = element;
    this.shownKey = "";
  }

  /** Build the item's view off screen now; returns the function that shows it. */
  prepare(item) {
    const key = item ? `${item.id}:${item.published_at}` : "";
    if (key === this.shownKey) return () => {};
    const next = document.createElement("div");
    next.className = "public-view";
    next.hidden = true;
    if (item) next.innerHTML = item.html;
    this.element.append(next);
    return () => {
      for (const child of [...this.element.children]) if (child !== next) child.remove();
      next.hidden = !item;
      this.element.hidden = !item;
      this.element.dataset.publication = item ? String(item.id) : "";
      this.shownKey = key;
    };
  }
}
