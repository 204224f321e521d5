// The census map's dashboard panel: the data set, pan and zoom, flat or on a globe, the
// globe's camera (turn, tilt, fly to a place), the tour, the colouring, groups, open
// balloons.
import {api, changeState, onStatus, wallId} from "tagwall/api.js";
import {bindViewControls} from "tagwall/panels/view.js";
import {censusOf} from "./census.js";

const $ = (id) => document.getElementById(id);
let state = null;
let groups = [];
let attributes = [];
let groupsOf = null;
const METHODS = {quantiles: "quantiles", equal: "equal intervals", natural: "natural breaks"};

let listedCurrent;  // the current data set when the list was last loaded (null: none)
let seenDataset = null;  // the data set the wall showed at the last status

function option(value, text) {
  const element = document.createElement("option");
  element.value = value;
  element.textContent = text;
  return element;
}

async function loadDatasets() {
  const datasets = await api("/api/apps/census/datasets");
  listedCurrent = datasets.find((d) => d.current)?.id ?? null;
  $("census-dataset").replaceChildren(...datasets.map((d) => {
    const entry = option(d.id, `${d.title} (${d.tracts} tracts, #${d.id})${d.current ? " · current" : ""}`);
    entry.selected = d.current;
    return entry;
  }));
  if (!datasets.length) {
    // The shipped tracts are loaded when the map first goes on a wall.
    $("census-dataset").append(option("", "none yet: put the census map on the wall"));
  }
  $("census-use").disabled = !datasets.length;
}

async function loadGroups(datasetId) {
  if (groupsOf === datasetId) return;
  groupsOf = datasetId;
  const detail = datasetId ? await api(`/api/apps/census/datasets/${datasetId}`) : null;
  groups = detail?.groups ?? [];
  attributes = detail?.attributes ?? [];
  $("census-attribute").replaceChildren(option("", "nothing (one plain colour)"),
    ...attributes.map((a) => option(a.key, a.label)));
  $("census-places").replaceChildren(...groups.map((g) => option(g.name, `${g.tracts} tracts`)));
}

async function loadSchemes() {
  const schemes = await api("/api/apps/census/schemes");
  $("census-scheme").replaceChildren(...schemes.map((s) => option(s.name, `${s.name} (${s.kind})`)));
}

// The wall's colouring as the status says: the controls follow it (another instructor,
// or a phone, may have changed it).
function showTheme() {
  const theme = state.app === "census" ? censusOf(state).theme : null;
  const label = attributes.find((a) => a.key === theme?.attribute)?.label ?? theme?.attribute;
  $("census-theme-shown").textContent = theme
    ? `Coloured by ${label}: ${theme.classes} classes by ${METHODS[theme.method]}, ${theme.scheme}.`
    : "One plain colour.";
  if (document.activeElement?.closest("#census-theme")) return;  // the instructor is choosing
  $("census-attribute").value = theme?.attribute ?? "";
  if (theme) {
    $("census-scheme").value = theme.scheme;
    $("census-method").value = theme.method;
    $("census-classes").value = String(theme.classes);
  }
}

// Flat or on a globe, as the status says; tiles that cannot show the globe say so in
// the Tiles table.
const SURFACES = {
  flat: "Flat, on the wall's plane.",
  globe: "On a globe: each display its part of one camera (tiles without WebGL: flat).",
};
function showSurface() {
  const {surface} = censusOf(state);
  for (const button of $("census-surface").querySelectorAll("[data-surface]")) {
    button.setAttribute("aria-pressed", String(button.dataset.surface === surface));
  }
  $("census-surface-shown").textContent = SURFACES[surface] ?? surface;
}

// The globe's camera as the status says. Codes and balloons stand where the globe shows
// their tracts, however it is turned (the server places them through the camera).
const MAX_TILT = 60;  // webapp/apps/census_map/state.py refuses more
function showCamera() {
  const {surface, heading, tilt} = censusOf(state);
  const look = heading === 0 && tilt === 0 ? "Straight down, north up."
    : `Turned to ${heading}° from north, tilted ${tilt}° from straight down.`;
  const codes = surface !== "globe" ? " The flat map stays north up, straight down: the globe shows the turn."
    : (heading || tilt ? " Codes and balloons stand where the globe shows their tracts." : "");
  $("census-camera-shown").textContent = look + codes;
}

function showTour() {
  const {tour} = censusOf(state);
  $("census-tour-steps").replaceChildren(...tour.steps.map((step, i) => {
    const li = document.createElement("li");
    const [cx, cy] = step.center;
    li.textContent = `centre ${cx.toFixed(2)}, ${cy.toFixed(2)} · zoom ${+step.zoom.toFixed(2)}`
      + ` · turned ${step.heading}° · tilted ${step.tilt}° · ${step.dwell_s} s`
      + (tour.playing && tour.step === i ? " · on the wall" : "");
    return li;
  }));
  $("census-tour-shown").textContent = tour.playing
    ? `Playing: step ${tour.step + 1} of ${tour.steps.length}.`
    : (tour.note ? `Not playing: ${tour.note}.` : (tour.steps.length ? "Not playing." : "No tour yet: add views to it."));
  $("census-tour-play").disabled = !tour.steps.length;
  $("census-tour-stop").disabled = !tour.playing;
  $("census-tour-clear").disabled = !tour.steps.length;
}

function say(element, promise) {
  element.textContent = "";
  return promise.catch((error) => { element.textContent = error.message; });
}

function aim(heading, tilt) {
  return say($("census-camera-shown"), api(`/api/apps/census/walls/${wallId}/camera`, {
    method: "POST", body: JSON.stringify({heading, tilt}),
  }));
}

// What the instructor typed: "lon, lat", a group (its name or id), else a tract.
function placeOf(text) {
  const numbers = text.match(/^\s*(-?\d+(?:\.\d*)?)\s*,\s*(-?\d+(?:\.\d*)?)\s*$/);
  if (numbers) return {longitude: Number(numbers[1]), latitude: Number(numbers[2])};
  const wanted = text.trim().toLowerCase();
  const group = groups.find((g) => g.id.toLowerCase() === wanted || g.name.toLowerCase() === wanted);
  return group ? {group: group.id} : {tract: text.trim()};
}

function tourCall(path, options = {method: "POST"}) {
  return say($("census-tour-shown"), api(`/api/apps/census/walls/${wallId}/tour${path}`, options));
}

function putTour(steps) {
  return tourCall("", {method: "PUT", body: JSON.stringify({steps})});
}

function item(text, buttonText, onClick) {
  const li = document.createElement("li");
  li.textContent = `${text} `;
  const button = document.createElement("button");
  button.textContent = buttonText;
  button.addEventListener("click", onClick);
  li.append(button);
  return li;
}

function showGroups() {
  $("census-groups").replaceChildren(...groups.map((g) => {
    const on = state.layers[g.id] ?? true;
    const li = item(`${g.name} · ${g.tracts} tracts · ${on ? "shown" : "hidden"}`,
      on ? "hide" : "show", () => changeState({layers: {[g.id]: !on}}));
    li.dataset.group = g.id;
    return li;
  }));
}

function showBalloons() {
  const now = Date.now();
  const open = state.balloons.filter((b) => b.closes_at == null || b.closes_at > now);
  $("census-balloons").replaceChildren(...open.map((b) => item(b.title, "close", () =>
    changeState({balloons: state.balloons.filter((other) => other.id !== b.id)}))));
}

onStatus(async (detail) => {
  state = detail.status.state;
  // The map showing a data set the list does not have as current (its first time on
  // a wall seeds the shipped one; an import elsewhere makes another current).
  const {dataset} = censusOf(state);
  if (state.app === "census" && dataset !== seenDataset) {
    seenDataset = dataset;
    if (dataset !== listedCurrent) await loadDatasets();
  }
  await loadGroups(state.app === "census" ? dataset : null);
  showSurface();
  showCamera();
  showTour();
  showTheme();
  showGroups();
  showBalloons();
});

bindViewControls($("census-panel"), () => state);
$("census-use").addEventListener("click", async () => {
  await api("/api/apps/census/current", {
    method: "POST", body: JSON.stringify({dataset: Number($("census-dataset").value)}),
  });
  await loadDatasets();
});
for (const button of $("census-surface").querySelectorAll("[data-surface]")) {
  button.addEventListener("click", () => api(`/api/apps/census/walls/${wallId}/surface`, {
    method: "POST", body: JSON.stringify({surface: button.dataset.surface}),
  }));
}
for (const button of $("census-camera").querySelectorAll("[data-turn]")) {
  button.addEventListener("click", () => {
    const {heading, tilt} = censusOf(state);
    aim((((heading + Number(button.dataset.turn)) % 360) + 360) % 360, tilt);
  });
}
for (const button of $("census-camera").querySelectorAll("[data-tilt]")) {
  button.addEventListener("click", () => {
    const {heading, tilt} = censusOf(state);
    aim(heading, Math.max(0, Math.min(MAX_TILT, tilt + Number(button.dataset.tilt))));
  });
}
$("census-camera").querySelector("[data-camera-reset]").addEventListener("click", () => aim(0, 0));
$("census-fly").addEventListener("submit", (event) => {
  event.preventDefault();
  const text = $("census-place").value;
  say($("census-fly-said"), api(`/api/apps/census/walls/${wallId}/fly`, {
    method: "POST", body: JSON.stringify(placeOf(text)),
  }).then(() => { $("census-fly-said").textContent = `Flying to ${text}.`; }));
});
$("census-tour-add").addEventListener("click", () => {
  const {tour, heading, tilt} = censusOf(state);
  const dwell = Number($("census-dwell").value);
  const {center, zoom} = state.view;
  putTour([...tour.steps, {center, zoom, heading, tilt, dwell_s: dwell}]);
});
$("census-tour-clear").addEventListener("click", () => putTour([]));
$("census-tour-play").addEventListener("click", () => tourCall("/play"));
$("census-tour-stop").addEventListener("click", () => tourCall("/stop"));
$("census-colour").addEventListener("click", async () => {
  const attribute = $("census-attribute").value;
  const theme = attribute ? {
    attribute, scheme: $("census-scheme").value, method: $("census-method").value,
    classes: Number($("census-classes").value),
  } : null;
  await api(`/api/apps/census/walls/${wallId}/theme`, {method: "POST", body: JSON.stringify({theme})});
});
loadDatasets();
loadSchemes();
