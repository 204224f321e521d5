// The census map's dashboard panel: the data set, pan and zoom, groups, open balloons.
import {STATUS_EVENT, api, changeState} from "/static/js/api.js";
import {bindViewControls} from "/static/js/panels/view.js";

const $ = (id) => document.getElementById(id);
let state = null;
let groups = [];
let groupsOf = null;

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
  groups = datasetId ? (await api(`/api/census/datasets/${datasetId}`)).groups : [];
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

document.addEventListener(STATUS_EVENT, async (event) => {
  state = event.detail.status.state;
  // The map showing a data set the list does not have as current (its first time on
  // a wall seeds the shipped one; an import elsewhere makes another current).
  if (state.app === "census" && state.dataset !== seenDataset) {
    seenDataset = state.dataset;
    if (state.dataset !== listedCurrent) await loadDatasets();
  }
  await loadGroups(state.app === "census" ? state.dataset : null);
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
loadDatasets();
