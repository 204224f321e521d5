// The poll's dashboard panel: ask the room a question (the app's API, with the session's
// CSRF token), then follow the poll on the wall: its votes as they come in, Close, and
// its votes as CSV.
import {api, onStatus, wallId} from "tagwall/api.js";

const form = document.getElementById("poll-ask");
const said = document.getElementById("poll-ask-status");
const close = document.getElementById("poll-close");
const csv = document.getElementById("poll-csv");
const polls = `/api/apps/poll/walls/${wallId}/polls`;
let shown = null;  // the poll on the wall: {round, question, choices}

form.addEventListener("submit", async (event) => {
  event.preventDefault();
  const choices = [...form.elements.namedItem("choice")].map((input) => input.value.trim());
  const question = form.elements.namedItem("question").value;
  try {
    const asked = await api(polls, {
      method: "POST", body: JSON.stringify({question, choices: choices.filter(Boolean)}),
    });
    said.textContent = `poll ${asked.round} is on the wall`;
    form.reset();
  } catch (error) {
    said.textContent = error.message;
  }
});

close.addEventListener("click", async () => {
  try {
    await api(`${polls}/${shown.round}/close`, {method: "POST"});
  } catch (error) {
    said.textContent = error.message;
  }
});

function row(choice, count) {
  const tr = document.createElement("tr");
  const th = document.createElement("th");
  th.scope = "row";
  th.textContent = choice;
  const td = document.createElement("td");
  td.textContent = count;
  tr.append(th, td);
  return tr;
}

let latest = null;

async function follow(slot) {
  latest = slot;
  if (slot.round != null && shown?.round !== slot.round) {
    shown = await api(`${polls}/${slot.round}`);
    if (latest !== slot) return;  // a later status came meanwhile: it shows
  }
  const asked = slot.round != null;
  document.getElementById("poll-round").textContent = !asked ? ""
    : `poll ${slot.round}${slot.closed ? " · closed" : ""}`;
  document.getElementById("poll-question").textContent = asked ? shown.question : "No poll yet.";
  document.querySelector("#poll-counts tbody").replaceChildren(
    ...(asked ? shown.choices : []).map((choice, i) => row(choice, slot.counts[i] ?? 0)));
  close.disabled = !asked || slot.closed;
  csv.hidden = !asked;
  if (asked) csv.href = `${polls}/${slot.round}/answers.csv`;
}

onStatus(({status}) => follow(status.state.apps?.poll ?? {}).catch(() => {}));
