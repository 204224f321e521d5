// The dashboard's calls to the JSON API: same-site cookie plus the session's CSRF token.
const csrf = document.body.dataset.csrf;
export const wallId = document.body.dataset.wall;

export async function api(path, options = {}) {
  const response = await fetch(path, {
    ...options,
    credentials: "same-origin",
    headers: {"X-CSRF-Token": csrf, "Content-Type": "application/json"},
  });
  if (!response.ok) throw new Error(`${path}: ${response.status}`);
  return response.json();
}

/** Change the wall's state (a StatePatch). */
export function changeState(patch) {
  return api(`/api/walls/${wallId}/state`, {method: "POST", body: JSON.stringify(patch)});
}

/** Panels follow the wall through this event: detail = {status, waiting}. */
export const STATUS_EVENT = "wall-status";
