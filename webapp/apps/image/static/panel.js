// The image app's dashboard panel: upload an image (multipart, with the session's CSRF
// token), list the stored ones, show one on the wall, pan and zoom it.
import {api, onStatus, wallId} from "tagwall/api.js";
import {bindViewControls} from "tagwall/panels/view.js";

const panel = document.getElementById("image-panel");
const form = document.getElementById("image-upload");
const status = document.getElementById("image-upload-status");
let state = null;

function cell(text, label) {
  const td = document.createElement("td");
  td.textContent = text;
  td.dataset.label = label;  // a phone shows it before the value (table.stacked)
  return td;
}

async function refresh() {
  const images = await api("/api/image/images");
  const shown = state?.apps?.image?.image;
  document.querySelector("#image-list tbody").replaceChildren(...images.map((image) => {
    const tr = document.createElement("tr");
    const button = document.createElement("button");
    button.textContent = image.id === shown ? "On the wall" : "Show on the wall";
    button.disabled = image.id === shown;
    button.dataset.imageShow = image.id;
    button.addEventListener("click", () => showImage(image.id));
    const action = document.createElement("td");
    action.append(button);
    action.dataset.label = "Wall";
    tr.append(cell(image.title, "Title"), cell(`${image.width} × ${image.height} px`, "Size"), action);
    return tr;
  }));
}

async function showImage(id) {
  await api(`/api/image/walls/${wallId}/show`, {method: "POST", body: JSON.stringify({image: id})});
}

form.addEventListener("submit", async (event) => {
  event.preventDefault();
  status.textContent = "uploading and building the pyramid…";
  const response = await fetch("/api/image/images", {
    method: "POST",
    body: new FormData(form),
    credentials: "same-origin",
    headers: {"X-CSRF-Token": document.body.dataset.csrf},
  });
  const body = await response.json().catch(() => ({}));
  if (!response.ok) {
    status.textContent = typeof body.detail === "string" ? body.detail : `upload failed (${response.status})`;
    return;
  }
  status.textContent = `added ${body.title} (${body.width} × ${body.height} px)`;
  form.reset();
  await refresh();
});

let shownBefore;
onStatus((detail) => {
  state = detail.status.state;
  const shown = state?.apps?.image?.image;
  if (shown !== shownBefore) {
    shownBefore = shown;
    refresh();
  }
});
bindViewControls(panel, () => state);
refresh();
