// The dashboard's volume controls: which volume, how it is drawn, the view, and the
// level-of-detail map (the finest level each tile can afford, coloured per level).
import {api, changeState, onStatus, wallId} from "../api.js";

const $ = (id) => document.getElementById(id);
const wall = JSON.parse(document.body.dataset.wallInfo);
const LEVEL_COLOURS = ["#2a9d8f", "#8ab17d", "#e9c46a", "#f4a261", "#e76f51", "#b23a48", "#6d2e46"];

let state = null;
let shownDetail = null;  // "version volume" of the map drawn

function option(value, text) {
  const element = document.createElement("option");
  element.value = value;
  element.textContent = text;
  return element;
}

async function loadVolumes() {
  const volumes = await api("/api/volumes");
  $("volume-choice").replaceChildren(
    option("", "(no volume)"),
    ...volumes.map((v) => option(v.name, `${v.name} (${v.shape.join(" × ")})`)),
  );
  if (state) $("volume-choice").value = state.volume?.volume ?? "";
}

function showVolume(current, version) {
  state = current;
  const volume = current.volume;
  for (const id of ["volume-choice", "volume-mode", "volume-transfer"]) {
    if (document.activeElement === $(id)) continue;
    if (id === "volume-choice") $(id).value = volume?.volume ?? "";
    if (id === "volume-mode") $(id).value = volume?.mode ?? "composite";
    if (id === "volume-transfer") $(id).value = volume?.transfer ?? "grey";
  }
  $("view-yaw").textContent = current.view.yaw;
  $("view-pitch").textContent = current.view.pitch;
  $("view-zoom").textContent = current.view.zoom.toFixed(2);
  const key = volume ? `${version} ${JSON.stringify(volume)}` : null;
  if (key !== shownDetail) {
    shownDetail = key;
    if (volume) refreshDetail(); else clearDetail();
  }
}

function setVolume() {
  const name = $("volume-choice").value;
  const volume = name
    ? {...(state?.volume ?? {}), volume: name, mode: $("volume-mode").value,
      transfer: $("volume-transfer").value}
    : null;
  return changeState({volume});
}

function turn(axis, by) {
  const view = {...state.view};
  if (axis === "yaw") view.yaw = ((view.yaw + by + 540) % 360) - 180;
  else view.pitch = Math.max(-90, Math.min(90, view.pitch + by));
  return changeState({view});
}

function zoom(factor) {
  const view = {...state.view, zoom: Math.max(0.1, Math.min(50, state.view.zoom * factor))};
  return changeState({view});
}

function clearDetail() {
  const canvas = $("lod-map");
  canvas.getContext("2d").clearRect(0, 0, canvas.width, canvas.height);
  $("lod-list").replaceChildren();
  $("lod-budget").textContent = "–";
}

async function refreshDetail() {
  let detail;
  try {
    detail = await api(`/api/walls/${wallId}/volume/detail`);
  } catch {
    clearDetail();
    return;
  }
  $("lod-budget").textContent = detail.budget.toLocaleString();
  const canvas = $("lod-map");
  const ctx = canvas.getContext("2d");
  const scale = Math.min(canvas.width / wall.width, canvas.height / wall.height);
  ctx.clearRect(0, 0, canvas.width, canvas.height);
  const byTile = new Map(detail.tiles.map((t) => [t.tile_id, t]));
  for (const display of wall.displays) {
    const [x, y, w, h] = display.rect.map((v) => v * scale);
    const tile = byTile.get(display.id);
    ctx.fillStyle = LEVEL_COLOURS[Math.min(tile.level, LEVEL_COLOURS.length - 1)];
    ctx.fillRect(x, y, w, h);
    ctx.fillStyle = "#000";
    ctx.font = `${Math.max(9, Math.min(w, h) / 4)}px sans-serif`;
    ctx.textAlign = "center";
    ctx.textBaseline = "middle";
    ctx.fillText(`L${tile.level}`, x + w / 2, y + h / 2);
  }
  $("lod-list").replaceChildren(...detail.tiles.map((tile) => {
    const li = document.createElement("li");
    li.dataset.tile = tile.tile_id;
    li.dataset.level = tile.level;
    li.textContent = `${tile.tile_id}: level ${tile.level}, ${tile.bricks} bricks, `
      + `${tile.voxels.toLocaleString()} voxels`;
    return li;
  }));
}

for (const id of ["volume-choice", "volume-mode", "volume-transfer"]) {
  $(id).addEventListener("change", setVolume);
}
// Its own buttons only: the apps' panels have zoom buttons of their own.
for (const button of $("volume-panel").querySelectorAll("[data-turn]")) {
  button.addEventListener("click", () => turn(button.dataset.turn, Number(button.dataset.by)));
}
for (const button of $("volume-panel").querySelectorAll("[data-zoom]")) {
  button.addEventListener("click", () => zoom(Number(button.dataset.zoom)));
}
$("view-reset").addEventListener("click", () =>
  changeState({view: {center: [0.5, 0.5], zoom: 1, yaw: 0, pitch: 0}}));
onStatus((detail) =>
  showVolume(detail.status.state, detail.status.version));
loadVolumes();
