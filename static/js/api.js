// The dashboard's calls to the JSON API: same-site cookie plus the session's CSRF token.
const csrf = document.body.dataset.csrf;
export const wallId = document.body.dataset.wall;

export async function api(path, options = {}) {
  const response = await fetch(path, {
    ...options,
    credentials: "same-origin",
    headers: {"X-CSRF-Token": csrf, "Content-Type": "application/json"},
  });
  return answer(path, response);
}

/** Send a form with its files (multipart), as `api` sends JSON. */
export async function sendForm(path, form) {
  const response = await fetch(path, {
    method: "POST",
    body: new FormData(form),
    credentials: "same-origin",
    headers: {"X-CSRF-Token": csrf},
  });
  return answer(path, response);
}

async function answer(path, response) {
  if (!response.ok) {
    // The server says why in its problem's detail; say that, not just the status.
    const detail = await response.json().then((body) => body.detail, () => null);
    const said = Array.isArray(detail) ? detail[0]?.msg : detail;  // a request's first fault
    throw new Error(typeof said === "string" ? said : `${path}: ${response.status}`);
  }
  return response.json();
}

/** Change the wall's state (a StatePatch). */
export function changeState(patch) {
  return api(`/api/walls/${wallId}/state`, {method: "POST", body: JSON.stringify(patch)});
}

/** Panels follow the wall through this event: detail = {status, waiting, class_session}. */
const STATUS_EVENT = "wall-status";
let lastStatus = null;

/** Tell the page's panels the wall's status (the dashboard does, at every status). */
export function publishStatus(detail) {
  lastStatus = detail;
  document.dispatchEvent(new CustomEvent(STATUS_EVENT, {detail}));
}

/**
 * Follow the wall's status: `listener(detail)` at once with the latest one, if any, and
 * at every one after. A panel whose modules load after the first status still starts
 * from it, so its buttons work from the moment they show.
 */
export function onStatus(listener) {
  document.addEventListener(STATUS_EVENT, (event) => listener(event.detail));
  if (lastStatus) listener(lastStatus);
}

/** A time as people at the wall read it: in the wall's time zone (its config's). */
export function localTime(when, options = {}) {
  const zone = JSON.parse(document.body.dataset.wallInfo || "{}").time_zone;
  return new Date(when).toLocaleTimeString([], {timeZone: zone || undefined, ...options});
}
