// The brain atlas's dashboard panel: mode, pin set, view presets, and the class's
// quiz results (refreshed with the wall's status, at most every two seconds).
import {STATUS_EVENT, api, wallId} from "../api.js";
import {bindViewControls} from "./view.js";

const $ = (id) => document.getElementById(id);
const REFRESH_MS = 2000;
let state = null;
let shown = null;
let fetchedAt = 0;

function cell(text) {
  const td = document.createElement("td");
  td.textContent = text;
  return td;
}

function show(status) {
  shown = status;
  $("brain-now").textContent = status.on_wall
    ? `· now: ${status.mode}, ${status.tag_set === "k5" ? "K-5" : "full"} pins`
    : "· the brain atlas is not on this wall";
  $("brain-presets").replaceChildren(...status.presets.map((preset) => {
    const button = document.createElement("button");
    button.textContent = preset.name;
    button.dataset.brainPreset = preset.id;
    button.addEventListener("click", () => control({preset: preset.id}));
    return button;
  }));
  const stats = status.quiz[status.tag_set];
  $("brain-round").textContent = `round ${status.round}`;
  $("brain-participants").textContent =
    `${stats.participants} taking part · ${stats.finished} finished`;
  $("brain-stats").tBodies[0].replaceChildren(...stats.regions.map((r) => {
    const tr = document.createElement("tr");
    const share = r.share_correct == null ? "–" : `${Math.round(100 * r.share_correct)} %`;
    const wrong = r.common_wrong.map(([text, count]) => `${text} (${count})`).join(", ");
    tr.append(cell(r.pin), cell(r.name), cell(r.answered), cell(share), cell(wrong || "–"));
    return tr;
  }));
}

async function refresh(force = false) {
  if (!force && Date.now() - fetchedAt < REFRESH_MS) return;
  fetchedAt = Date.now();
  show(await api(`/api/walls/${wallId}/brain`));
}

async function control(choice) {
  show(await api(`/api/walls/${wallId}/brain`, {method: "POST", body: JSON.stringify(choice)}));
}

for (const button of document.querySelectorAll("[data-brain-mode]")) {
  button.addEventListener("click", () => control({mode: button.dataset.brainMode}));
}
for (const button of document.querySelectorAll("[data-brain-set]")) {
  button.addEventListener("click", () => control({tag_set: button.dataset.brainSet}));
}
$("brain-reset").addEventListener("click", async () => {
  if (!confirm("Start a new round? Everyone's answers start again (this round stays in the export).")) return;
  show(await api(`/api/walls/${wallId}/brain/quiz/reset`, {method: "POST"}));
});
document.addEventListener(STATUS_EVENT, (event) => {
  state = event.detail.status.state;
  refresh();
});
bindViewControls($("brain-panel"), () => state);
refresh(true);
