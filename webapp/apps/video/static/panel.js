// The video app's dashboard panel: upload a video (multipart, with the session's CSRF
// token), list the stored ones (show one on the wall, delete), play, pause, seek, loop
// and choose the sound's display of the one on the wall (controls.js), and the phone
// remote's code to scan.
import {api, sendForm, wallId} from "tagwall/api.js";
import {VideoControls, clockText} from "./controls.js";

const panel = document.getElementById("video-panel");
const upload = document.getElementById("video-upload");
const uploadSaid = document.getElementById("video-upload-status");
const listSaid = document.getElementById("video-list-status");

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

function row(video, shown) {
  const onWall = video.id === shown;
  const show = button(onWall ? "On the wall" : "Show on the wall", () => change(async () => {
    await api(`/api/apps/video/walls/${wallId}/show`, {method: "POST", body: JSON.stringify({video: video.id})});
    return `${video.title} is on the wall, paused at its start`;
  }));
  show.disabled = onWall;
  const remover = button("Delete", () => {
    if (!confirm(`Delete ${video.title}? Its file goes for good.`)) return;
    change(async () => {
      await api(`/api/apps/video/videos/${video.id}`, {method: "DELETE"});
      return `deleted ${video.title}`;
    });
  });
  remover.disabled = onWall;  // the server refuses it too (409)
  const actions = cell("", "Actions");
  actions.append(show, remover);
  const sound = video.audio_codec ? `, ${video.audio_codec}` : ", no sound";
  const tr = document.createElement("tr");
  tr.append(
    cell(video.title, "Title"),
    cell(clockText(video.duration_s), "Length"),
    cell(`${video.width} × ${video.height} px, ${video.fps} fps, ${video.video_codec}${sound}`, "Picture"),
    actions,
  );
  return tr;
}

let shownBefore;
let listed = [];

async function refresh() {
  listed = await api("/api/apps/video/videos");
  showList();
}

function showList() {
  document.querySelector("#video-list tbody")
    .replaceChildren(...listed.map((video) => row(video, shownBefore)));
}

const controls = new VideoControls(panel.querySelector("[data-video-controls]"), wallId, (now) => {
  const shown = now.on_wall ? now.video?.id ?? null : null;
  if (shown !== shownBefore) {
    shownBefore = shown;
    showList();
  }
});

upload.addEventListener("submit", async (event) => {
  event.preventDefault();
  uploadSaid.textContent = "uploading and checking…";
  try {
    const added = await sendForm("/api/apps/video/videos", upload);
    uploadSaid.textContent = `added ${added.title} (${clockText(added.duration_s)}, ${added.width} × ${added.height} px)`;
    upload.reset();
  } catch (error) {
    uploadSaid.textContent = error.message;
    return;
  }
  await refresh();
});

document.getElementById("video-remote-show").addEventListener("click", async () => {
  const code = await api(`/api/apps/video/walls/${wallId}/remote`);
  document.getElementById("video-remote-code").src = code.image;
  document.getElementById("video-remote-link").textContent = code.url;
  document.getElementById("video-remote").hidden = false;
});

controls.follow();
refresh();
