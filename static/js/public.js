// The public screen on a tile: what visitors published, shown full-screen over the
// scene. The HTML comes from the wall state, where only the server puts it, rendered
// with autoescaping from plain text (webapp/publishing/publication.py); the page's CSP forbids
// inline script besides.
//
// Any publication shows whole: its title on top and its byline at the bottom always,
// the content between at the largest type size that fits (never below the wall's
// readable minimum), in columns on a wide screen; what still does not fit is cut into
// pages between blocks (paragraphs, list items, table rows, charts), never inside one.
// Pages turn by themselves on the wall's shared clock, counted from the publication's
// `published_at`, and every public display lays out in the same box (the server's
// layout, scaled to each screen), so all of them show the same page at the same time.

const CHAR_EM = 0.5;        // an average glyph of system-ui is about half an em wide
const MIN_MEASURE = 45;     // a column is never narrower than this many characters
const MAX_COLUMNS = 3;
const TITLE_EM = 1.6;       // the title's size against the body's ...
const TITLE_MAX_LINES = 3;  // ... shrunk (not below the minimum) to keep it this short
const BYLINE_EM = 0.8;      // the byline's, never below the minimum
const FIT_ROUNDS = 6;       // a block too tall for any page is zoomed down in a few steps

/**
 * The pieces of an article that may go to different columns or pages, in reading
 * order: each piece is a node and the containers it sits in (a list, a table of facts),
 * which are rebuilt around it wherever it lands. A heading is glued to what follows.
 */
function pieces(article) {
  const atoms = [];
  const walk = (node, path) => {
    for (const child of node.children) {
      const tag = child.tagName;
      if (tag === "DIV" && child.classList.contains("markdown")) walk(child, [...path, child]);
      else if (tag === "UL" || tag === "OL") {
        const start = tag === "OL" ? Number(child.getAttribute("start") ?? 1) : 1;
        [...child.children].forEach((item, index) => {
          if (tag === "OL") item.setAttribute("value", String(start + index));
          atoms.push({nodes: [item], path: [...path, child]});
        });
      } else if (tag === "DL") {
        let row = null;
        for (const item of child.children) {
          if (item.tagName === "DT" || !row) {
            row = {nodes: [], path: [...path, child]};
            atoms.push(row);
          }
          row.nodes.push(item);
        }
      } else if (tag === "TABLE" && child.tBodies.length) {
        for (const body of child.tBodies) {
          for (const row of body.rows) atoms.push({nodes: [row], path: [...path, child, body]});
        }
      } else atoms.push({nodes: [child], path});
    }
  };
  walk(article, []);
  // A heading (or a paragraph that is only bold words, as "**Sources**") stays with
  // the piece after it.
  const groups = [];
  let glued = [];
  for (const atom of atoms) {
    glued.push(atom);
    if (!isHeading(atom.nodes[0])) {
      groups.push(glued);
      glued = [];
    }
  }
  if (glued.length) groups.push(glued);
  return groups;
}

function isHeading(node) {
  if (/^H[2-6]$/.test(node.tagName)) return true;
  const only = node.tagName === "P" && node.children.length === 1 ? node.children[0] : null;
  return Boolean(only && only.tagName === "STRONG" && only.textContent === node.textContent);
}

/** A container as it continues in another column: empty, a table keeps its head. */
function shallow(container) {
  const copy = container.cloneNode(false);
  if (container.tagName === "TABLE" && container.tHead) copy.append(container.tHead.cloneNode(true));
  return copy;
}

/** One column being filled: places pieces with their containers, and takes them back. */
class Column {
  constructor(element) {
    this.element = element;
    this.open = [];  // [original container, its copy here], outermost first
    this.count = 0;
  }

  overflows() {
    const e = this.element;
    return e.scrollHeight > e.clientHeight + 0.5 || e.scrollWidth > e.clientWidth + 0.5;
  }

  /** Place a group; returns what undoes it. */
  place(group, into = this.element) {
    const saved = [...this.open];
    const added = [];
    for (const atom of group) {
      let depth = 0;
      while (depth < this.open.length && depth < atom.path.length
             && this.open[depth][0] === atom.path[depth]) depth += 1;
      this.open.length = depth;
      let parent = depth ? this.open[depth - 1][1] : into;
      let fresh = false;  // whether the atom went into containers made for it
      for (const container of atom.path.slice(depth)) {
        const copy = shallow(container);
        parent.append(copy);
        if (!fresh) added.push(copy);
        fresh = true;
        this.open.push([container, copy]);
        parent = copy;
      }
      for (const node of atom.nodes) {
        const copy = node.cloneNode(true);
        parent.append(copy);
        if (!fresh) added.push(copy);
      }
    }
    this.count += 1;
    return () => {
      for (const node of added) node.remove();
      this.open = saved;
      this.count -= 1;
    };
  }

  /** A group taller (or wider) than a whole column, alone in it: zoomed to fit. */
  placeScaled(group) {
    const box = document.createElement("div");
    box.className = "public-fit";
    this.element.append(box);
    this.place(group, box);
    this.open = [];
    let zoom = 1;
    for (let round = 0; round < FIT_ROUNDS && this.overflows(); round += 1) {
      const e = this.element;
      zoom *= Math.min(e.clientHeight / e.scrollHeight, e.clientWidth / e.scrollWidth) * 0.98;
      box.style.zoom = String(zoom);
    }
  }
}

export class PublicScreen {
  /**
   * @param {HTMLElement} element the box over the scene
   * @param {object} layout the server's ScreenLayout: box [w, h] px, min_font_px,
   *   max_font_px, words_per_minute, page_min_ms (webapp/publishing/publication.py)
   */
  constructor(element, layout) {
    this.element = element;
    this.layout = layout;
    this.shownKey = "";
    this.timer = null;
    this.stage = document.createElement("div");  // where views are laid out unseen
    this.stage.className = "public-stage";
    this.stage.setAttribute("aria-hidden", "true");
    document.body.append(this.stage);
    window.addEventListener("resize", () => this.fitWindow());
  }

  /**
   * Lay the item out off screen now; returns the function that shows it.
   * @param {object|null} item the wall state's `public`
   * @param {function} clock the server time now, ms
   */
  prepare(item, clock) {
    const key = item ? `${item.id}:${item.published_at}` : "";
    if (key === this.shownKey) return () => {};
    const view = item ? this.build(item) : null;
    return () => {
      clearTimeout(this.timer);
      this.element.replaceChildren(...(view ? [view.element] : []));
      this.element.hidden = !item;
      this.element.dataset.publication = item ? String(item.id) : "";
      for (const name of ["page", "pages", "pageSince", "pageUntil"]) delete this.element.dataset[name];
      this.shownKey = key;
      this.view = view;
      if (view) {
        this.fitWindow();
        this.turn(view, item.published_at, clock);
      }
    };
  }

  /** The view scaled (and centred) to the window: the box is the same on every display. */
  fitWindow() {
    const element = this.view?.element;
    if (!element) return;
    const [width, height] = this.layout.box;
    const scale = Math.min(innerWidth / width, innerHeight / height);
    const x = (innerWidth - width * scale) / 2;
    const y = (innerHeight - height * scale) / 2;
    element.style.transform = `translate(${x}px, ${y}px) scale(${scale})`;
  }

  /** Show the page the clock says, and come back when the next one is due. */
  turn(view, publishedAt, clock) {
    const now = clock();
    const cycle = view.durations.reduce((a, b) => a + b, 0);
    let into = ((now - publishedAt) % cycle + cycle) % cycle;
    let page = 0;
    while (into >= view.durations[page]) into -= view.durations[page++];
    view.show(page, now - into, now - into + view.durations[page]);
    // Look again at the turn, and every second meanwhile: the clock's offset may still
    // settle right after (re)connecting.
    if (view.pages.length > 1) {
      const due = Math.min(view.durations[page] - into + 1, 1000);
      this.timer = setTimeout(() => this.turn(view, publishedAt, clock), due);
    }
  }

  /** The item's view: pages laid out in the layout's box, and how long each stays. */
  build(item) {
    const [width, height] = this.layout.box;
    const element = document.createElement("div");
    element.className = "public-view";
    element.style.width = `${width}px`;
    element.style.height = `${height}px`;
    element.style.padding = `${Math.round(0.04 * Math.min(width, height))}px`;
    const source = document.createElement("template");
    source.innerHTML = item.html;
    const original = source.content.querySelector("article") ?? source.content;
    const title = original.querySelector(":scope > h1");
    const byline = original.querySelector(":scope > footer");
    title?.remove();
    byline?.remove();
    const groups = pieces(original);

    const article = document.createElement("article");
    article.className = "public-item";
    const heading = title ?? document.createElement("h1");
    const footer = document.createElement("footer");
    const by = document.createElement("span");
    by.className = "byline";
    by.append(...(byline ? byline.childNodes : []));
    const number = document.createElement("span");
    number.className = "page-number";
    footer.append(by, number);
    const body = document.createElement("div");
    body.className = "public-pages";
    article.append(heading, body, footer);
    element.append(article);
    this.stage.replaceChildren(element);

    const {min_font_px: min, max_font_px: max} = this.layout;
    const fill = (size, limit) => this.fill(groups, element, body, heading, footer, size, limit);
    // The largest size that keeps everything on one page; else the fewest pages the
    // minimum size gives, at the largest size that still gives no more.
    let best = null;
    let low = min;
    let high = max;
    let limit = 1;
    if (!fill(min, 1)) {
      limit = fill(min, Infinity).length;
    }
    while (low <= high) {
      const size = Math.floor((low + high) / 2);
      const pages = fill(size, limit);
      if (pages) {
        best = size;
        low = size + 1;
      } else high = size - 1;
    }
    const pages = fill(best ?? min, best ? limit : Infinity);
    const {words_per_minute: wpm, page_min_ms: least} = this.layout;
    const durations = pages.map((page) => {
      const words = page.textContent.split(/\s+/).filter(Boolean).length;
      return Math.max(least, Math.round(words / wpm * 60000));
    });
    element.classList.toggle("public-single", pages.length === 1);
    element.dataset.fontPx = String(best ?? min);
    element.dataset.pages = String(pages.length);
    const screen = this.element;
    return {
      element,
      pages,
      durations,
      show(index, since, until) {
        pages.forEach((page, i) => { page.hidden = i !== index; });
        number.textContent = pages.length > 1 ? `${index + 1} / ${pages.length}` : "";
        screen.dataset.page = String(index + 1);
        screen.dataset.pages = String(pages.length);
        screen.dataset.pageSince = String(Math.round(since));
        screen.dataset.pageUntil = pages.length > 1 ? String(Math.round(until)) : "";
      },
    };
  }

  /**
   * The groups laid out at body size `size` px into pages of columns; null when that
   * takes more than `limit` pages.
   */
  fill(groups, element, body, heading, footer, size, limit) {
    const {min_font_px: min} = this.layout;
    element.style.fontSize = `${size}px`;
    footer.style.fontSize = `${Math.max(min, Math.round(size * BYLINE_EM))}px`;
    let title = Math.max(min, Math.round(size * TITLE_EM));
    heading.style.fontSize = `${title}px`;
    while (title > min && heading.offsetHeight > TITLE_MAX_LINES * 1.25 * title) {
      title = Math.max(min, Math.round(title * 0.9));
      heading.style.fontSize = `${title}px`;
    }
    body.replaceChildren();
    const columns = Math.max(1, Math.min(MAX_COLUMNS,
      Math.floor(body.clientWidth / (size * CHAR_EM * MIN_MEASURE))));
    element.style.setProperty("--column-height", `${body.clientHeight}px`);
    // Fewer columns when they do (a short item reads best across the screen).
    for (let count = 1; count <= columns; count += 1) {
      const pages = this.flow(groups, body, count, limit);
      if (pages) return pages;
    }
    return null;
  }

  flow(groups, body, count, limit) {
    body.replaceChildren();
    const pages = [];
    const columns = [];
    const newPage = () => {
      const page = document.createElement("div");
      page.className = "public-page";
      for (let i = 0; i < count; i += 1) {
        const column = document.createElement("div");
        column.className = "public-column";
        page.append(column);
        columns.push(new Column(column));
      }
      body.append(page);
      pages.push(page);
      // earlier pages step aside so this one takes the space
      for (const earlier of pages) earlier.hidden = earlier !== page;
    };
    newPage();
    let at = 0;
    for (const group of groups) {
      let undo = columns[at].place(group);
      while (columns[at].overflows()) {
        if (columns[at].count === 1) {
          undo();
          columns[at].placeScaled(group);
          break;
        }
        undo();
        at += 1;
        if (at === columns.length) {
          if (pages.length === limit) return null;
          newPage();
        }
        undo = columns[at].place(group);
      }
    }
    return pages;
  }
}
