// The brain atlas's dashboard panel: mode, pin set, view presets, who may switch the
// wall's pins, the quiz round (open or closed, when names are shown) and the class's
// results (refreshed with the wall's status, at most every two seconds).
import {api, localTime, onStatus, wallId} from "tagwall/api.js";
import {bindViewControls} from "tagwall/panels/view.js";

const $ = (id) => document.getElementById(id);
const REFRESH_MS = 2000;
const REVEAL_HINTS = {
  close: "Finishing shows a student nothing; everyone sees the names when you close the round.",
  finish: "For practice: whoever finishes sees the names at once, and may pass them on (a second browser counts as another student).",
};
let state = null;
let fetchedAt = 0;

function cell(text, label) {
  const td = document.createElement("td");
  td.textContent = text;
  td.dataset.label = label;  // a phone shows it before the value (table.stacked)
  return td;
}

function clock(iso) {
  return iso ? localTime(iso) : "–";
}

function showRound(status) {
  const round = status.round;
  $("brain-round").textContent = round ? `round ${round.number}` : "no round yet";
  $("brain-close").disabled = !round || !round.open;
  if (!round) {
    $("brain-round-state").textContent = "";
    return;
  }
  const stats = status.quiz[status.tag_set];
  const when = round.open
    ? `open since ${clock(round.started_at)} · last answer ${clock(round.last_answer_at)}`
    : `closed at ${clock(round.closed_at)}: students see the names and their results`;
  $("brain-round-state").textContent = `Round ${round.number} is ${when}.`;
  if (round.open) $("brain-reveal").value = round.reveal;  // closed: the next round's choice
  $("brain-reveal-hint").textContent = REVEAL_HINTS[$("brain-reveal").value];
  $("brain-participants").textContent =
    `${stats.participants} taking part · ${stats.answers} answers so far · ${stats.finished} finished`;
  $("brain-stats").tBodies[0].replaceChildren(...stats.regions.map((r) => {
    const tr = document.createElement("tr");
    const share = r.share_correct == null ? "–" : `${Math.round(100 * r.share_correct)} %`;
    const wrong = r.common_wrong.map(([text, count]) => `${text} (${count})`).join(", ");
    tr.append(
      cell(r.pin, "Pin"), cell(r.name, "Region"), cell(r.answered, "Answered"),
      cell(share, "Correct"), cell(wrong || "–", "Common wrong answers"),
    );
    return tr;
  }));
}

// Which pins no view can show is asked once per round and pin set while the brain is
// on the wall: it places the round's pins in every view, too much for every status.
let unshownFor = null;

async function showUnshown(status) {
  const key = status.on_wall && status.round ? `${status.round.number}:${status.tag_set}` : null;
  if (key === unshownFor) return;
  unshownFor = key;
  const line = $("brain-unshown");
  if (!key) {
    line.hidden = true;
    return;
  }
  const found = await api(`/api/apps/brain/walls/${wallId}/unshown?tag_set=${status.tag_set}`);
  if (unshownFor !== key) return;  // the round or the set changed meanwhile
  line.hidden = found.regions.length === 0;
  line.textContent = `${found.regions.length} of ${found.pins} pins have a code in no view,`
    + ` so no student can scan them this round: ${found.regions.join(", ")}`;
}

function show(status) {
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
  $("brain-audience").checked = status.audience_switches;
  showRound(status);
  showUnshown(status);
}

async function refresh(force = false) {
  if (!force && Date.now() - fetchedAt < REFRESH_MS) return;
  fetchedAt = Date.now();
  show(await api(`/api/apps/brain/walls/${wallId}`));
}

async function control(choice) {
  show(await api(`/api/apps/brain/walls/${wallId}`, {method: "POST", body: JSON.stringify(choice)}));
}

for (const button of document.querySelectorAll("[data-brain-mode]")) {
  button.addEventListener("click", () => {
    const tutor = button.dataset.brainMode === "tutor";
    if (tutor && !$("brain-close").disabled &&
        !confirm("Tutor pages name every pin: switching closes the running round and shows students the names. Switch?")) return;
    control({mode: button.dataset.brainMode});
  });
}
for (const button of document.querySelectorAll("[data-brain-set]")) {
  button.addEventListener("click", () => control({tag_set: button.dataset.brainSet}));
}
$("brain-audience").addEventListener("change", (event) => control({audience_switches: event.target.checked}));
$("brain-reveal").addEventListener("change", (event) => {
  $("brain-reveal-hint").textContent = REVEAL_HINTS[event.target.value];
  if (!$("brain-close").disabled) control({reveal: event.target.value});
});
$("brain-close").addEventListener("click", async () => {
  if (!confirm("Close the round? Answers stop counting and every student sees the correct names.")) return;
  show(await api(`/api/apps/brain/walls/${wallId}/quiz/close`, {method: "POST"}));
});
$("brain-reset").addEventListener("click", async () => {
  if (!confirm("Start a new round? The pins get new numbers and codes; this round closes and stays in the export.")) return;
  const body = JSON.stringify({reveal: $("brain-reveal").value});
  show(await api(`/api/apps/brain/walls/${wallId}/quiz/reset`, {method: "POST", body}));
});
onStatus((detail) => {
  state = detail.status.state;
  refresh();
});
bindViewControls($("brain-panel"), () => state);
refresh(true);
