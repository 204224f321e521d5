// Forms that survive a dropped connection (a phone's answer on flaky Wi-Fi): a form
// marked `data-keep` is sent with fetch; when the network fails, what was typed is
// kept on the phone (localStorage) and sent as soon as the phone is back online —
// on this page, or on the next page of ours it opens — and the page says so.
// Without JavaScript the form posts as any form does.

const PREFIX = "tagwall:kept:";
const NOTICE_ID = "kept-notice";

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
  if (response.redirected) window.history.pushState(null, "", response.url);
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

/** Send what is kept, oldest first; what still fails stays for the next try. */
async function sendKept() {
  const keys = Object.keys(localStorage).filter((key) => key.startsWith(PREFIX)).sort(
    (a, b) => JSON.parse(localStorage[a]).at - JSON.parse(localStorage[b]).at);
  for (const key of keys) {
    const {action, fields} = JSON.parse(localStorage[key]);
    let response;
    try {
      response = await post(action, fields);
    } catch {
      return;  // still offline
    }
    localStorage.removeItem(key);
    if (action === currentAction()) await show(response);
  }
}

function currentAction() {
  const form = document.querySelector("form[data-keep]");
  return form ? new URL(form.action, window.location.href).pathname : null;
}

function keepForms() {
  for (const form of document.querySelectorAll("form[data-keep]")) {
    const action = new URL(form.action, window.location.href).pathname;
    const kept = localStorage.getItem(PREFIX + action);
    if (kept) {  // typed before a reload, not sent yet
      for (const [name, value] of Object.entries(JSON.parse(kept).fields)) {
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

window.addEventListener("online", sendKept);
window.addEventListener("popstate", () => window.location.reload());  // back from a page shown in place
keepForms();
sendKept();
