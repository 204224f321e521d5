// The dashboard's codes of one's own: a link, a text, a phone number or a contact at a
// point of the wall (clicked on a drawing of its displays, or typed in mm) or at a place
// the wall shows now (a hotspot of the image: the code follows it), the list of them,
// where each stands and whether it is on the wall now, and switching one off.
import {api, onStatus, wallId} from "../api.js";

const $ = (id) => document.getElementById(id);
const wall = JSON.parse(document.body.dataset.wallInfo);
const map = $("own-map");
map.height = Math.round(map.width * wall.height / wall.width);  // the wall's own shape
const KINDS = {url: "web link", text: "text", tel: "phone number", vcard: "contact"};
let codes = [];
let places = [];

function scale() {
  return Math.min(map.width / wall.width, map.height / wall.height);
}

function draw() {
  const ctx = map.getContext("2d");
  const k = scale();
  ctx.clearRect(0, 0, map.width, map.height);
  ctx.strokeStyle = "#8b949e";
  for (const display of wall.displays) {
    const [x, y, w, h] = display.rect;
    ctx.strokeRect(x * k + 0.5, y * k + 0.5, w * k - 1, h * k - 1);
  }
  const mark = (x, y, colour) => {
    ctx.fillStyle = colour;
    ctx.beginPath();
    ctx.arc(x * k, y * k, 4, 0, 2 * Math.PI);
    ctx.fill();
  };
  for (const code of codes) if (code.on_wall && code.anchor) mark(...code.anchor, "#58a6ff");
  const x = Number($("own-x").value), y = Number($("own-y").value);
  if ($("own-x").value !== "" && $("own-y").value !== "") mark(x, y, "#e63946");
}

function showKind() {
  for (const label of document.querySelectorAll("[data-own]")) {
    label.hidden = label.dataset.own !== $("own-kind").value;
  }
}

/** Show the fields of the "Where" chosen; the other's are off (not checked, not sent). */
function showWhere() {
  const where = $("own-where").value;
  for (const part of document.querySelectorAll("[data-where]")) {
    part.hidden = part.dataset.where !== where;
    for (const field of part.querySelectorAll("input, select")) field.disabled = part.hidden;
  }
}

function showPlaces() {
  const chosen = $("own-place").value;
  $("own-place").replaceChildren(...places.map((place) => {
    const option = new Option(place.label, JSON.stringify({app: place.app, id: place.id}));
    option.selected = option.value === chosen;
    return option;
  }));
  $("own-no-places").hidden = places.length > 0;
}

async function refreshPlaces() {
  places = await api(`/api/walls/${wallId}/places`);
  showPlaces();
}

function say(error) {
  $("own-error").textContent = error ? error.message : "";
  $("own-error").hidden = !error;
}

/** Where a code stands: at its place (by the label it had when last shown) or its point. */
function standing(code) {
  if (code.params.place) return `at ${code.params.place.label}`;
  return `at (${code.anchor.map(Math.round).join(", ")}) mm`;
}

function entry(code) {
  const li = document.createElement("li");
  const what = code.action === "link" ? code.params.url : code.payload.split("\n")[0];
  li.textContent = `${code.label} · ${KINDS[code.kind]} · ${what} · ${standing(code)} `;
  if (code.active) {
    li.append(code.on_wall ? "· on the wall " : "· not on the wall now ");
    const off = document.createElement("button");
    off.textContent = "Switch off";
    off.addEventListener("click", () =>
      api(`/api/tags/${code.code}`, {method: "PATCH", body: JSON.stringify({active: false})})
        .then(refresh, say));
    li.append(off);
  } else {
    li.append("(switched off)");
    li.className = "hint";
  }
  return li;
}

async function refresh() {
  codes = await api(`/api/walls/${wallId}/own-codes`);
  $("own-codes").replaceChildren(...codes.map(entry));
  draw();
}

function chosen() {
  const kind = $("own-kind").value;
  const code = {kind, label: $("own-label").value};
  if ($("own-where").value === "place") code.place = JSON.parse($("own-place").value);
  else code.anchor = [Number($("own-x").value), Number($("own-y").value)];
  if (kind === "link") code.url = $("own-url").value;
  if (kind === "text") code.text = $("own-text").value;
  if (kind === "phone") code.number = $("own-number").value;
  if (kind === "contact") {
    code.contact = {name: $("own-name").value};
    if ($("own-phone").value) code.contact.phone = $("own-phone").value;
    if ($("own-email").value) code.contact.email = $("own-email").value;
  }
  return code;
}

map.addEventListener("click", (event) => {
  const box = map.getBoundingClientRect();
  const k = scale() * box.width / map.width;
  $("own-x").value = Math.round((event.clientX - box.left) / k);
  $("own-y").value = Math.round((event.clientY - box.top) / k);
  draw();
});
for (const id of ["own-x", "own-y"]) $(id).addEventListener("input", draw);
$("own-kind").addEventListener("change", showKind);
$("own-where").addEventListener("change", showWhere);
$("own-form").addEventListener("submit", (event) => {
  event.preventDefault();
  api(`/api/walls/${wallId}/own-codes`, {method: "POST", body: JSON.stringify(chosen())})
    .then(() => { say(null); $("own-label").value = ""; return refresh(); }, say);
});

// Placing them again (another app, another view) moves codes at places on or off the
// wall, and a status after another dashboard's change should show its codes: follow the
// layout. The places follow every change of the wall (a pan, an image, another app).
let layout = null;
let version = null;
onStatus((detail) => {
  if (layout !== detail.status.state.tag_layout) {
    layout = detail.status.state.tag_layout;
    refresh().catch(say);
  }
  if (version !== detail.status.version) {
    version = detail.status.version;
    refreshPlaces().catch(say);
  }
});
showKind();
showWhere();
draw();
