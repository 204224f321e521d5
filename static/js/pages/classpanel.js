// The dashboard's class: Start class and End class, the live count of the students who
// joined (with the wall's status, every second), and what an ended class produced.
import {api, localTime, onStatus, wallId} from "../api.js";

const $ = (id) => document.getElementById(id);
const NAMING = {
  anonymous: "no names asked",
  nickname: "students give a nickname",
  roster: "students give their roster id",
  course: "students named by the course",
};
const CLOCK = {hour: "2-digit", minute: "2-digit"};

function say(error) {
  $("class-error").textContent = error ? error.message : "";
  $("class-error").hidden = !error;
}

function link(exported) {
  const li = document.createElement("li");
  const a = document.createElement("a");
  a.href = exported.url;
  a.textContent = exported.label;
  li.append(a);
  return li;
}

function showModes() {
  const chosen = $("class-app").selectedOptions[0];
  const modes = chosen ? chosen.dataset.modes.split(",").filter(Boolean) : [];
  $("class-mode").replaceChildren(...modes.map((mode) => new Option(mode, mode)));
  $("class-mode").disabled = modes.length === 0;
  $("class-mode-label").hidden = modes.length === 0;  // an app without modes
}

function showRunning(running) {
  $("class-running").hidden = !running;
  $("class-start").hidden = Boolean(running);
  if (!running) return;
  $("class-ended").hidden = true;
  $("class-title").textContent = running.title;
  $("class-started").textContent = localTime(running.started_at, CLOCK);
  $("class-naming").textContent = NAMING[running.names];
  $("class-joined").textContent = running.joined;
  $("class-joined-label").textContent = running.joined === 1 ? "student joined" : "students joined";
  showCourse(running.course);
}

// A class launched from a course: its roster, who joined and who is missing.
function showCourse(course) {
  $("class-course").hidden = !course;
  if (!course) return;
  $("class-roster-problem").hidden = !course.roster_problem;
  $("class-roster-problem").textContent =
    course.roster_problem ? `The course's roster could not be read: ${course.roster_problem}` : "";
  $("class-missing-count").textContent = course.missing.length;
  $("class-missing").textContent = course.missing.join(", ") || "nobody";
  $("class-joined-names").textContent = course.joined.join(", ") || "nobody yet";
}

// An ended class from a course: how its grades stand in the course's gradebook.
function showGrades(course) {
  const shown = Boolean(course && course.graded);
  $("class-grades").hidden = !shown;
  if (!shown) return;
  const absent = course.missing.length ? `; no score for ${course.missing.join(", ")} (not joined)` : "";
  const posted =
    `${course.grades_posted} score${course.grades_posted === 1 ? "" : "s"} in the course's gradebook${absent}`;
  if (!course.grades_waiting) {
    $("class-grades").textContent = posted;
    $("class-grades").className = "";
    return;
  }
  const next = course.next_try_at ? localTime(course.next_try_at, CLOCK) : "soon";
  $("class-grades").textContent =
    `${posted}; ${course.grades_waiting} not accepted yet, tried again at ${next}` +
    (course.grades_problem ? ` (${course.grades_problem})` : "");
  $("class-grades").className = "down";
  // the scores are tried again on the server: look again until they are all in
  setTimeout(() => { if (!running) api(`/api/walls/${wallId}/class`).then(show, say); }, 5000);
}

function showEnded(ended) {
  $("class-ended").hidden = false;
  $("class-ended-at").textContent = localTime(ended.ended_at, CLOCK);
  $("class-ended-title").textContent = ended.title;
  $("class-ended-joined").textContent =
    ended.joined === 1 ? "1 student" : `${ended.joined} students`;
  $("class-exports").replaceChildren(...ended.exports.map(link));
  showGrades(ended.course);
}

function show(info) {
  if (info && !info.running) showEnded(info);
  showRunning(info && info.running ? info : null);
}

$("class-app").addEventListener("change", showModes);
$("class-start").addEventListener("submit", (event) => {
  event.preventDefault();
  const choice = {
    title: $("class-title-choice").value,
    app: $("class-app").value,
    mode: $("class-mode").disabled ? null : $("class-mode").value,
    names: $("class-names").value,
  };
  api(`/api/walls/${wallId}/class`, {method: "POST", body: JSON.stringify(choice)})
    .then((info) => { say(null); show(info); }, say);
});
$("class-end").addEventListener("click", () => {
  api(`/api/walls/${wallId}/class/end`, {method: "POST"})
    .then((info) => { say(null); show(info); }, say);
});

// A status without a class after one ran (ended from another dashboard): fetch how it
// ended, with its downloads.
let running = false;
onStatus((detail) => {
  const now = detail.class_session || null;
  if (now) showRunning(now);
  else if (running) api(`/api/walls/${wallId}/class`).then(show, say);
  running = Boolean(now);
});

showModes();
api(`/api/walls/${wallId}/class`).then(show, say);
