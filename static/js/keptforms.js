// Forms that survive a dropped connection (a phone's answer on flaky Wi-Fi): a form
// marked `data-keep` is sent with fetch; when the network fails, what was typed is
// kept on the phone (localStorage) and sent as soon as the phone is back online —
// on this page, or on the next page of ours it opens — and the page says so.
// Without JavaScript the form posts as any form does.
//
// What is kept belongs to the session that typed it: the CSRF token it carries, the
// one every form of that session's pages holds (and the server checks as it takes
// it). A page of another session (the phone in other hands, a cookie gone, a new
// sign-in) neither shows nor sends it, and forgets it; signing out forgets all of it.
// So a shared phone holds nothing of the person who used it before.

const PREFIX = "tagwall:kept:";
const NOTICE_ID = "kept-notice";
const SENT_ID = "kept-sent";

function notice(form, text) {
  let element = document.getElementById(NOTICE_ID);
  if (!element) {
    element = document.createElement("p");
    element.id = NOTICE_ID;
    element.className = "hint kept";
    element.setAttribute("role", "status");
    form.after(element);
  }
  element.textContent = text;
}

/** Say, at the top of the page now shown, what became of what was kept and sent. */
function announce(text) {
  let element = document.getElementById(SENT_ID);
  if (!element) {
    element = document.createElement("p");
    element.id = SENT_ID;
    element.className = "hint kept";
    element.setAttribute("role", "status");
    (document.querySelector("main") ?? document.body).prepend(element);
  }
  element.textContent = text;
}

function reload() {
  window.location.reload();
}

/**
 * Show the page the server answered with (after its redirect, fetch followed it) in
 * place, at its address; a page that runs modules of its own is opened instead.
 */
async function show(response) {
  const page = new DOMParser().parseFromString(await response.text(), "text/html");
  if (page.querySelector("script[type=module]:not([src$='/keptforms.js'])")) {
    window.location.assign(response.url);
    return;
  }
  if (response.redirected) {
    window.history.pushState(null, "", response.url);
    window.addEventListener("popstate", reload);  // back from a page shown in place
  }
  document.title = page.title;
  document.body.replaceWith(document.adoptNode(page.body));
  keepForms();
}

async function post(action, fields) {
  return fetch(action, {
    method: "POST",
    body: new URLSearchParams(fields),
    credentials: "same-origin",
    headers: {"Content-Type": "application/x-www-form-urlencoded"},
  });
}

/** The session this page is for: its forms' CSRF token (null: a page without one). */
function session() {
  return document.querySelector("input[name=csrf]")?.value ?? null;
}

function keptKeys() {
  return Object.keys(localStorage).filter((key) => key.startsWith(PREFIX));
}

/** What this page's session kept, oldest first; what other sessions kept is forgotten. */
function keptHere() {
  const owner = session();
  const here = [];
  if (owner === null) return here;
  for (const key of keptKeys()) {
    const kept = JSON.parse(localStorage[key]);
    if (kept.fields.csrf === owner) here.push({key, ...kept});
    else localStorage.removeItem(key);
  }
  return here.sort((a, b) => a.at - b.at);
}

function forgetAll() {
  for (const key of keptKeys()) localStorage.removeItem(key);
}

/** Send what this session kept, oldest first; what still fails stays for the next try. */
async function sendKept() {
  for (const {key, action, fields} of keptHere()) {
    let response;
    try {
      response = await post(action, fields);
    } catch {
      return;  // still offline
    }
    localStorage.removeItem(key);
    if (action === currentAction()) await show(response);
    announce(response.ok
      ? "Sent: what you typed while offline has arrived."
      : "Sent, but not taken: the page says why.");
  }
}

function currentAction() {
  const form = document.querySelector("form[data-keep]");
  return form ? new URL(form.action, window.location.href).pathname : null;
}

function keepForms() {
  const here = new Map(keptHere().map((kept) => [kept.action, kept]));
  for (const form of document.querySelectorAll("form[data-keep]")) {
    const action = new URL(form.action, window.location.href).pathname;
    const kept = here.get(action);
    if (kept) {  // typed before a reload, not sent yet
      for (const [name, value] of Object.entries(kept.fields)) {
        if (name !== "csrf" && form.elements[name]) form.elements[name].value = value;
      }
      notice(form, form.dataset.keep);
    }
    form.addEventListener("submit", async (event) => {
      event.preventDefault();
      const fields = Object.fromEntries(new FormData(form));
      try {
        await show(await post(action, fields));
      } catch {
        localStorage.setItem(PREFIX + action, JSON.stringify({action, fields, at: Date.now()}));
        notice(form, form.dataset.keep);
      }
    });
  }
}

// Signing out (the profile page's button, the dashboard's) ends the session what is
// kept belongs to: nothing of it stays on a phone the next person picks up.
for (const form of document.querySelectorAll("form[action='/logout']")) {
  form.addEventListener("submit", forgetAll);
}
window.addEventListener("online", sendKept);
keepForms();
sendKept();
