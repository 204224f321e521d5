// The census map's dashboard panel: the data set, pan and zoom, flat or on a globe, the
// colouring, groups, open balloons.
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
  const datasets = await api("/api/census/datasets");
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
  const detail = datasetId ? await api(`/api/census/datasets/${datasetId}`) : null;
  groups = detail?.groups ?? [];
  attributes = detail?.attributes ?? [];
  $("census-attribute").replaceChildren(option("", "nothing (one plain colour)"),
    ...attributes.map((a) => option(a.key, a.label)));
}

async function loadSchemes() {
  const schemes = await api("/api/census/schemes");
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
  showTheme();
  showGroups();
  showBalloons();
});

bindViewControls($("census-panel"), () => state);
$("census-use").addEventListener("click", async () => {
  await api("/api/census/current", {
    method: "POST", body: JSON.stringify({dataset: Number($("census-dataset").value)}),
  });
  await loadDatasets();
});
for (const button of $("census-surface").querySelectorAll("[data-surface]")) {
  button.addEventListener("click", () => api(`/api/census/walls/${wallId}/surface`, {
    method: "POST", body: JSON.stringify({surface: button.dataset.surface}),
  }));
}
$("census-colour").addEventListener("click", async () => {
  const attribute = $("census-attribute").value;
  const theme = attribute ? {
    attribute, scheme: $("census-scheme").value, method: $("census-method").value,
    classes: Number($("census-classes").value),
  } : null;
  await api(`/api/census/walls/${wallId}/theme`, {method: "POST", body: JSON.stringify({theme})});
});
loadDatasets();
loadSchemes();
