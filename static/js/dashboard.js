// Setup dashboard: tile status and test-pattern controls, through the walls API.
const token = document.body.dataset.token;
const select = document.getElementById("wall");
let state = null;

async function api(path, options = {}) {
  const response = await fetch(path, {
    ...options,
    headers: {"Authorization": `Bearer ${token}`, "Content-Type": "application/json"},
  });
  if (!response.ok) throw new Error(`${path}: ${response.status}`);
  return response.json();
}

function change(patch) {
  return api(`/api/walls/${select.value}/state`, {method: "POST", body: JSON.stringify(patch)})
    .then(refresh);
}

function cell(text, className) {
  const td = document.createElement("td");
  td.textContent = text;
  if (className) td.className = className;
  return td;
}

const tagSetSelect = document.getElementById("tag-set");

function option(value, text, selected) {
  const element = document.createElement("option");
  element.value = value;
  element.textContent = text;
  element.selected = selected;
  return element;
}

// The wall's tag sets, the active one selected, and every code placement could not place.
async function refreshCodes() {
  const info = await api(`/api/walls/${select.value}/tag-sets`);
  if (document.activeElement !== tagSetSelect) {
    tagSetSelect.replaceChildren(
      option("", "(permanent codes only)", info.active === null),
      ...info.sets.map((name) => option(name, name, name === info.active)),
    );
  }
  document.getElementById("codes-placed").textContent = info.placed;
  document.getElementById("codes-layout").textContent = info.layout;
  document.getElementById("codes-unplaced").replaceChildren(...info.unplaced.map((code) => {
    const li = document.createElement("li");
    li.className = "down";
    li.textContent = `not placed: ${code.label || code.code} (${code.code}): ${code.reason}`;
    return li;
  }));
}

tagSetSelect.addEventListener("change", () => {
  const name = tagSetSelect.value || null;
  api(`/api/walls/${select.value}/tag-set`, {method: "PUT", body: JSON.stringify({name})})
    .then(refresh);
});

async function refresh() {
  refreshCodes();
  const status = await api(`/api/walls/${select.value}/status`);
  state = status.state;
  document.getElementById("version").textContent = status.version;
  document.getElementById("app").textContent = state.app;
  document.getElementById("mode").textContent = state.mode;
  document.getElementById("overview-link").href = `/wall/${select.value}/overview`;
  for (const box of document.querySelectorAll("[data-layer]")) {
    box.checked = state.layers[box.dataset.layer] ?? true;
  }
  // Apply times relative to the earliest tile at the wall's version: how in step they are.
  const current = status.tiles.filter((t) => t.version === status.version && t.applied_at);
  const first = Math.min(...current.map((t) => t.applied_at));
  const rows = status.tiles.map((tile) => {
    const tr = document.createElement("tr");
    const seen = tile.last_seen ? new Date(tile.last_seen).toLocaleTimeString() : "never";
    tr.append(
      cell(tile.tile_id),
      cell(tile.connected ? "yes" : "no", tile.connected ? "up" : "down"),
      cell(tile.version ?? "–"),
      cell(current.includes(tile) ? `+${(tile.applied_at - first).toFixed(1)} ms` : "–"),
      cell(seen),
      cell(tile.address ?? ""),
    );
    return tr;
  });
  document.getElementById("tiles").replaceChildren(...rows);
}

for (const box of document.querySelectorAll("[data-layer]")) {
  box.addEventListener("change", () => change({layers: {[box.dataset.layer]: box.checked}}));
}
for (const button of document.querySelectorAll("[data-pan]")) {
  button.addEventListener("click", () => {
    const [dx, dy] = button.dataset.pan.split(",").map(Number);
    const view = state.view;
    const step = 1 / view.zoom;
    change({view: {...view, center: [view.center[0] + dx * step, view.center[1] + dy * step]}});
  });
}
for (const button of document.querySelectorAll("[data-zoom]")) {
  button.addEventListener("click", () => {
    change({view: {...state.view, zoom: state.view.zoom * Number(button.dataset.zoom)}});
  });
}
document.getElementById("reset-view").addEventListener("click", () => {
  change({view: {center: [0.5, 0.5], zoom: 1, yaw: 0, pitch: 0}});
});
select.addEventListener("change", refresh);
refresh();
setInterval(refresh, 2000);
