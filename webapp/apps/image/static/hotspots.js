// The image panel's hotspots: the coarse picture of the image on the wall on a canvas,
// a click places a hotspot there (the form says the rest), the list with edit (the form
// takes the hotspot; a click moves it) and delete, and the quiz round's controls with
// its live statistics.
import {api, wallId} from "tagwall/api.js";
import {Pyramid} from "./image.js";

const box = document.getElementById("image-hotspots");
const canvas = document.getElementById("hotspot-canvas");
const form = document.getElementById("hotspot-form");
const said = document.getElementById("hotspot-status");
const quizSaid = document.getElementById("image-quiz-status");
const csv = document.getElementById("image-quiz-csv");
const submit = form.querySelector("button[type=submit]");
const cancel = document.getElementById("hotspot-cancel");
const GROUPS = ["k5", "undergraduate", "medical", "research"];
let pyramid = null;
let picture = null;
let spots = [];
let editing = null;  // the hotspot the form changes (null: it adds one)

/** A field of the form by its name (``form.title`` would be the form's own title). */
function field(name) {
  return form.elements.namedItem(name);
}

function draw() {
  const ctx = canvas.getContext("2d");
  ctx.fillStyle = "#000";
  ctx.fillRect(0, 0, canvas.width, canvas.height);
  if (!pyramid) return;
  if (picture) ctx.drawImage(picture, 0, 0, canvas.width, canvas.height);
  const scale = canvas.width / pyramid.width;
  const chosen = [field("x").value, field("y").value].map(Number);
  const marks = spots.filter((s) => s.id !== editing?.id).map((s) => [s.x, s.y, "#ff0"]);
  if (field("x").value) marks.push([...chosen, "#f0f"]);
  for (const [x, y, colour] of marks) {
    ctx.beginPath();
    ctx.arc(x * scale, y * scale, 5, 0, 2 * Math.PI);
    ctx.fillStyle = colour;
    ctx.fill();
    ctx.strokeStyle = "#000";
    ctx.stroke();
  }
}

function choosePlace(x, y) {
  field("x").value = x;
  field("y").value = y;
  document.getElementById("hotspot-place").textContent = `At (${Math.round(x)}, ${Math.round(y)}) px`;
}

/** An empty form adding a hotspot, no place chosen (hidden inputs keep their value
 * through reset()). */
function clearForm() {
  form.reset();
  editing = null;
  submit.textContent = "Add hotspot";
  cancel.hidden = true;
  field("x").value = "";
  field("y").value = "";
  document.getElementById("hotspot-place").textContent = "No place chosen yet.";
}

/** The form takes ``spot`` to change it: its place (a click moves it), title, texts,
 * question and accepted answers. */
function edit(spot) {
  clearForm();
  editing = spot;
  choosePlace(spot.x, spot.y);
  field("title").value = spot.title;
  for (const group of GROUPS) field(`text-${group}`).value = spot.texts[group] ?? "";
  field("question").value = spot.question ?? "";
  field("accepted").value = spot.accepted.join("\n");
  submit.textContent = "Save hotspot";
  cancel.hidden = false;
  said.textContent = `editing ${spot.title}`;
  draw();
  field("title").focus();
}

function listSpots() {
  document.getElementById("hotspot-list").replaceChildren(...spots.map((spot) => {
    const li = document.createElement("li");
    const change = document.createElement("button");
    change.textContent = "edit";
    change.addEventListener("click", () => edit(spot));
    const remove = document.createElement("button");
    remove.textContent = "delete";
    remove.addEventListener("click", async () => {
      spots = await api(`/api/apps/image/images/${pyramid.id}/hotspots/${spot.id}`, {method: "DELETE"});
      if (editing?.id === spot.id) clearForm();
      listSpots();
      draw();
    });
    const question = spot.question ? ` · asks: ${spot.question}` : "";
    li.append(`${spot.title} (${Math.round(spot.x)}, ${Math.round(spot.y)})${question} `, change, remove);
    return li;
  }));
}

/** The image on the wall changed (or came): its picture and hotspots. */
export async function showHotspots(imageId) {
  box.hidden = !imageId;
  if (!imageId || pyramid?.id === imageId) return;
  pyramid = new Pyramid(await (await fetch(`/apps/image/images/${imageId}/info.json`)).json());
  canvas.height = Math.max(1, Math.round((canvas.width * pyramid.height) / pyramid.width));
  clearForm();
  picture = null;
  const tile = await fetch(pyramid.url(pyramid.coarse, 0, 0));
  if (tile.ok) picture = await createImageBitmap(await tile.blob());
  spots = await api(`/api/apps/image/images/${imageId}/hotspots`);
  listSpots();
  draw();
}

canvas.addEventListener("click", (event) => {
  if (!pyramid) return;
  const rect = canvas.getBoundingClientRect();
  const x = ((event.clientX - rect.left) / rect.width) * pyramid.width;
  const y = ((event.clientY - rect.top) / rect.height) * pyramid.height;
  choosePlace(x.toFixed(1), y.toFixed(1));
  draw();
});

cancel.addEventListener("click", () => {
  clearForm();
  said.textContent = "";
  draw();
});

form.addEventListener("submit", async (event) => {
  event.preventDefault();
  if (!field("x").value) {
    said.textContent = "Click the picture where the hotspot goes first.";
    return;
  }
  const texts = Object.fromEntries(GROUPS.map((g) => [g, field(`text-${g}`).value])
    .filter(([, text]) => text.trim()));
  const body = {
    x: Number(field("x").value),
    y: Number(field("y").value),
    title: field("title").value,
    texts,
    question: field("question").value || null,
    accepted: field("accepted").value.split("\n").map((a) => a.trim()).filter(Boolean),
  };
  try {
    const url = `/api/apps/image/images/${pyramid.id}/hotspots`;
    if (editing) {
      const saved = await api(`${url}/${editing.id}`, {method: "PUT", body: JSON.stringify(body)});
      spots = spots.map((spot) => (spot.id === saved.id ? saved : spot));
      said.textContent = `saved ${saved.title}`;
    } else {
      const added = await api(url, {method: "POST", body: JSON.stringify(body)});
      spots.push(added);
      said.textContent = `added ${added.title}`;
    }
    clearForm();
    listSpots();
    draw();
  } catch (error) {
    said.textContent = error.message;
  }
});

function showQuiz(status) {
  const round = status.round;
  csv.hidden = !round;
  if (round) csv.href = `/api/apps/image/walls/${wallId}/answers.csv?round=${round.number}`;
  const items = status.items.map((item) => {
    const share = item.share_correct === null ? "–" : `${Math.round(item.share_correct * 100)} %`;
    return `Q${item.number} ${item.title}: ${item.answered} answered, ${share} right`;
  });
  const waiting = status.questions && !round?.open;
  quizSaid.textContent = !round ? `${status.questions} questions, no round yet`
    : `Round ${round.number} ${round.open ? "running" : "closed"}: ${status.participants} `
      + `taking part. ${items.join("; ")}`;
  if (waiting) quizSaid.textContent += ": press Start round to ask them (a new class asks them itself).";
}

for (const button of box.querySelectorAll("[data-quiz]")) {
  button.addEventListener("click", async () => {
    try {
      showQuiz(await api(`/api/apps/image/walls/${wallId}/quiz/${button.dataset.quiz}`,
        {method: "POST", body: "{}"}));
    } catch (error) {
      quizSaid.textContent = error.message;
    }
  });
}

/** The round's statistics, polled while the panel is open (answers come in live). */
export async function refreshQuiz() {
  if (box.hidden) return;
  showQuiz(await api(`/api/apps/image/walls/${wallId}`));
}
