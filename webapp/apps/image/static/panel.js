// The image app's dashboard panel: upload an image or import a lesson (multipart, with
// the session's CSRF token), list the stored ones (show one on the wall, export its
// lesson, retitle it, delete it), pan and zoom it, and mark the hotspots of the one
// shown (hotspots.js).
import {api, onStatus, sendForm, wallId} from "tagwall/api.js";
import {bindViewControls} from "tagwall/panels/view.js";
import {refreshQuiz, showHotspots} from "./hotspots.js";

const panel = document.getElementById("image-panel");
const upload = document.getElementById("image-upload");
const uploadSaid = document.getElementById("image-upload-status");
const lessonForm = document.getElementById("lesson-import");
const lessonSaid = document.getElementById("lesson-import-status");
const listSaid = document.getElementById("image-list-status");
let state = null;

function cell(text, label) {
  const td = document.createElement("td");
  td.textContent = text;
  td.dataset.label = label;  // a phone shows it before the value (table.stacked)
  return td;
}

function button(text, action) {
  const made = document.createElement("button");
  made.type = "button";
  made.textContent = text;
  made.addEventListener("click", action);
  return made;
}

/** Run a change of the list, list again, and say what came of it (or why not). */
async function change(step) {
  let said;
  try {
    said = await step();
  } catch (error) {
    said = error.message;
  }
  await refresh();
  listSaid.textContent = said;
}

/** The title's cell becomes a small form: the new title, Save and Cancel. */
function rename(titleCell, image) {
  const form = document.createElement("form");
  form.className = "rename";
  const label = document.createElement("label");
  const input = document.createElement("input");
  const bound = upload.elements.namedItem("title").maxLength;  // an upload's title's
  Object.assign(input, {name: "title", value: image.title, maxLength: bound, required: true});
  label.append("New title ", input);
  const save = document.createElement("button");
  save.textContent = "Save title";
  form.append(label, save, button("Cancel", refresh));
  form.addEventListener("submit", (event) => {
    event.preventDefault();
    change(async () => {
      const renamed = await api(`/api/apps/image/images/${image.id}`,
        {method: "PATCH", body: JSON.stringify({title: input.value})});
      return `renamed ${image.title} to ${renamed.title}`;
    });
  });
  titleCell.replaceChildren(form);
  input.focus();
}

function remove(image) {
  if (!confirm(`Delete ${image.title}? Its picture and hotspots go for good (export its lesson first to keep them).`)) return;
  change(async () => {
    await api(`/api/apps/image/images/${image.id}`, {method: "DELETE"});
    return `deleted ${image.title}`;
  });
}

function row(image, shown) {
  const onWall = image.id === shown;
  const show = button(onWall ? "On the wall" : "Show on the wall", () => showImage(image.id));
  show.disabled = onWall;
  const lesson = document.createElement("a");
  lesson.href = `/api/apps/image/images/${image.id}/lesson`;
  lesson.download = "";  // the file's name is the server's (Content-Disposition)
  lesson.textContent = "Export lesson";
  const title = cell(image.title, "Title");
  const remover = button("Delete", () => remove(image));
  remover.disabled = onWall;  // the server refuses it too (409)
  const actions = cell("", "Actions");
  actions.append(show, lesson, button("Rename", () => rename(title, image)), remover);
  const tr = document.createElement("tr");
  tr.append(title, cell(`${image.width} × ${image.height} px`, "Size"), actions);
  return tr;
}

/** The image the wall shows (none while another app is up). */
function onWall() {
  return state?.app === "image" ? state.apps?.image?.image : null;
}

async function refresh() {
  const images = await api("/api/apps/image/images");
  const shown = onWall();
  document.querySelector("#image-list tbody").replaceChildren(...images.map((i) => row(i, shown)));
}

async function showImage(id) {
  await api(`/api/apps/image/walls/${wallId}/show`, {method: "POST", body: JSON.stringify({image: id})});
}

upload.addEventListener("submit", async (event) => {
  event.preventDefault();
  uploadSaid.textContent = "uploading and building the pyramid…";
  try {
    const added = await sendForm("/api/apps/image/images", upload);
    uploadSaid.textContent = `added ${added.title} (${added.width} × ${added.height} px)`;
    upload.reset();
  } catch (error) {
    uploadSaid.textContent = error.message;
    return;
  }
  await refresh();
});

lessonForm.addEventListener("submit", async (event) => {
  event.preventDefault();
  lessonSaid.textContent = "importing…";
  try {
    const added = await sendForm("/api/apps/image/lessons", lessonForm);
    const spots = await api(`/api/apps/image/images/${added.id}/hotspots`);
    lessonSaid.textContent =
      `imported ${added.title} (${added.width} × ${added.height} px, ${spots.length} hotspots)`;
    lessonForm.reset();
  } catch (error) {
    lessonSaid.textContent = error.message;  // every problem, one line each
    return;
  }
  await refresh();
});

let shownBefore;
onStatus((detail) => {
  state = detail.status.state;
  const shown = onWall();
  if (shown !== shownBefore) {
    shownBefore = shown;
    refresh();
    showHotspots(shown).then(refreshQuiz);
  }
});
setInterval(() => refreshQuiz().catch(() => {}), 5000);
bindViewControls(panel, () => state);
refresh();
