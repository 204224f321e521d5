// The census map's dashboard panel: the data set, pan and zoom, groups, open balloons.
import {STATUS_EVENT, api, changeState} from "../api.js";
import {bindViewControls} from "./view.js";

const $ = (id) => document.getElementById(id);
let state = null;
let groups = [];
let groupsOf = null;

async function loadDatasets() {
  const datasets = await api("/api/census/datasets");
  $("census-dataset").replaceChildren(...datasets.map((d) => {
    const option = document.createElement("option");
    option.value = d.id;
    option.textContent = `${d.title} (${d.tracts} tracts, #${d.id})${d.current ? " · current" : ""}`;
    option.selected = d.current;
    return option;
  }));
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
