// The instructor dashboard: live status and scans over its own socket, actions through
// the JSON API. App panels follow the status this page publishes (onStatus).
import {api, changeState, localTime, onStatus, publishStatus, wallId} from "../api.js";
import {socketUrl} from "../wallsocket.js";

const $ = (id) => document.getElementById(id);
const MAX_FEED = 50;

function cell(text, className) {
  const td = document.createElement("td");
  td.textContent = text;
  if (className) td.className = className;
  return td;
}

function option(value, text, selected) {
  const element = document.createElement("option");
  element.value = value;
  element.textContent = text;
  element.selected = selected;
  return element;
}

function button(text, onClick) {
  const element = document.createElement("button");
  element.textContent = text;
  element.addEventListener("click", onClick);
  return element;
}

// --- live status -----------------------------------------------------------------------

// A choice follows the wall when the wall's value changes, so a status arriving while
// the instructor is picking (or between picking and pressing Switch) never undoes it.
const onWall = {};

function follow(id, value) {
  if (onWall[id] === value) return;
  onWall[id] = value;
  $(id).value = value;
}

function showStatus({status, waiting, class_session}) {
  const state = status.state;
  $("version").textContent = status.version;
  $("app").textContent = state.app;
  $("mode").textContent = state.mode;
  follow("mode-choice", state.mode);
  follow("app-choice", state.app);
  for (const panel of document.querySelectorAll("[data-for-apps]")) {
    panel.hidden = !panel.dataset.forApps.split(" ").includes(state.app);
  }
  for (const panel of document.querySelectorAll("[data-app-panel]")) {
    panel.hidden = panel.dataset.appPanel !== state.app;  // only the app on the wall's
  }
  $("public-shown").textContent = state.public
    ? `${state.public.title} (by ${state.public.author})` : "nothing";
  $("public-moderated").checked = state.public_policy.moderated;
  $("public-locked").checked = state.public_policy.locked;
  showWaiting(waiting);
  showTiles(status);
  publishStatus({status, waiting, class_session});
}

function showWaiting(waiting) {
  $("waiting-count").textContent = waiting.length;
  const ids = waiting.map((item) => item.id).join(",");
  if ($("waiting").dataset.ids === ids) return;  // keep buttons stable under the pointer
  $("waiting").dataset.ids = ids;
  $("waiting").replaceChildren(...waiting.map((item) => {
    const li = document.createElement("li");
    li.dataset.publication = item.id;
    const text = document.createElement("span");
    text.textContent = `${item.title} — ${item.author} `;
    li.append(
      text,
      button("Approve", () => moderate(item.id, "approve")),
      button("Reject", () => moderate(item.id, "reject")),
      preview(item),
    );
    return li;
  }));
}

/** What the public screen would show: the publication's HTML as the server rendered it
 * (escaped), in a frame sandboxed without any permission: no script runs there, no
 * form sends, and it cannot reach this page or its session. */
function preview(item) {
  const frame = document.createElement("iframe");
  frame.className = "preview";
  frame.title = `Preview: ${item.title}`;
  frame.setAttribute("sandbox", "");
  frame.setAttribute("referrerpolicy", "no-referrer");
  frame.srcdoc = "<!doctype html><meta charset=utf-8>"
    + `<link rel="stylesheet" href="${location.origin}/static/css/tagwall.css">`
    + `<body class="preview">${item.html}</body>`;
  return frame;
}

// Apply times relative to the earliest tile at the wall's version: how in step they are.
function showTiles(status) {
  const current = status.tiles.filter((t) => t.version === status.version && t.applied_at);
  const first = Math.min(...current.map((t) => t.applied_at));
  $("tiles").replaceChildren(...status.tiles.map((tile) => {
    const tr = document.createElement("tr");
    const seen = tile.last_seen ? localTime(tile.last_seen) : "never";
    tr.append(
      cell(tile.tile_id),
      cell(tile.connected ? "yes" : "no", tile.connected ? "up" : "down"),
      cell(tile.version ?? "–"),
      cell(current.includes(tile) ? `+${(tile.applied_at - first).toFixed(1)} ms` : "–"),
      cell(seen),
      cell(tile.address ?? ""),
      cell((tile.notes ?? []).map((note) => `${tile.tile_id} ${note}`).join("; ")),
    );
    return tr;
  }));
}

function showScan(scan) {
  const li = document.createElement("li");
  li.textContent = `${localTime(scan.at)} · ${scan.label || scan.code}`
    + ` (${scan.app}) · visitor ${scan.visitor}`;
  $("scans").prepend(li);
  while ($("scans").children.length > MAX_FEED) $("scans").lastChild.remove();
}

function connect(attempt = 0) {
  const ws = new WebSocket(socketUrl(`/ws/dashboard/${wallId}`));
  ws.onopen = () => { attempt = 0; $("live").textContent = "live"; $("live").className = "up"; };
  ws.onmessage = (frame) => {
    const message = JSON.parse(frame.data);
    if (message.type === "status") showStatus(message);
    else if (message.type === "scan") showScan(message);
  };
  ws.onclose = (close) => {
    $("live").textContent = `offline (${close.reason || close.code})`;
    $("live").className = "down";
    const delay = Math.min(15000, 500 * 2 ** attempt) * (0.5 + Math.random() / 2);
    setTimeout(() => connect(attempt + 1), delay);
  };
}

// --- actions ---------------------------------------------------------------------------

function moderate(id, decision) {
  return api(`/api/walls/${wallId}/public/${id}/${decision}`, {method: "POST"});
}

function setPolicy() {
  const policy = {moderated: $("public-moderated").checked, locked: $("public-locked").checked};
  return api(`/api/walls/${wallId}/public/policy`, {method: "PUT", body: JSON.stringify(policy)});
}

$("public-moderated").addEventListener("change", setPolicy);
$("public-locked").addEventListener("change", setPolicy);
$("public-clear").addEventListener("click", () =>
  api(`/api/walls/${wallId}/public/clear`, {method: "POST"}));
$("apply-app").addEventListener("click", () =>
  changeState({app: $("app-choice").value, mode: $("mode-choice").value || "default"}));

let pairingTimer = null;

async function showPairingCode() {
  const code = await api("/api/pairing", {method: "POST"});
  $("pairing-code").src = code.image;
  $("pairing").hidden = false;
  const expires = new Date(code.expires_at).getTime();
  clearInterval(pairingTimer);
  const tick = () => {
    const left = Math.round((expires - Date.now()) / 1000);
    $("pairing-left").textContent = Math.max(0, left);
    if (left <= 0) { clearInterval(pairingTimer); $("pairing").hidden = true; }
  };
  tick();
  pairingTimer = setInterval(tick, 1000);
}
$("pair-start").addEventListener("click", showPairingCode);

// --- codes -----------------------------------------------------------------------------

const tagSetSelect = $("tag-set");

async function refreshCodes() {
  const info = await api(`/api/walls/${wallId}/tag-sets`);
  if (document.activeElement !== tagSetSelect) {
    tagSetSelect.replaceChildren(
      option("", "(permanent codes only)", info.active === null),
      ...info.sets.map((name) => option(name, name, name === info.active)),
    );
  }
  $("codes-placed").textContent = info.placed;
  $("codes-layout").textContent = info.layout;
  $("codes-unplaced").replaceChildren(...info.unplaced.map((code) => {
    const li = document.createElement("li");
    li.className = "down";
    li.textContent = `not placed: ${code.label || code.code} (${code.code}): ${code.reason}`;
    return li;
  }));
}

tagSetSelect.addEventListener("change", () => {
  const name = tagSetSelect.value || null;
  api(`/api/walls/${wallId}/tag-set`, {method: "PUT", body: JSON.stringify({name})})
    .then(refreshCodes);
});
onStatus((detail) => {
  if (tagSetSelect.dataset.layout !== String(detail.status.state.tag_layout)) {
    tagSetSelect.dataset.layout = detail.status.state.tag_layout;
    refreshCodes();
  }
});

// The feed starts from the wall's last scans, so a reload loses none of it.
JSON.parse($("scans").dataset.recent).forEach(showScan);
connect();
