// The test pattern's dashboard panel: layers, pan and zoom.
import {STATUS_EVENT, changeState} from "../api.js";

let state = null;

document.addEventListener(STATUS_EVENT, (event) => {
  state = event.detail.status.state;
  for (const box of document.querySelectorAll("[data-layer]")) {
    box.checked = state.layers[box.dataset.layer] ?? true;
  }
});

for (const box of document.querySelectorAll("[data-layer]")) {
  box.addEventListener("change", () => changeState({layers: {[box.dataset.layer]: box.checked}}));
}
for (const button of document.querySelectorAll("[data-pan]")) {
  button.addEventListener("click", () => {
    if (!state) return;
    const [dx, dy] = button.dataset.pan.split(",").map(Number);
    const view = state.view;
    const step = 1 / view.zoom;
    changeState({view: {...view, center: [view.center[0] + dx * step, view.center[1] + dy * step]}});
  });
}
for (const button of document.querySelectorAll("[data-zoom]")) {
  button.addEventListener("click", () => {
    if (state) changeState({view: {...state.view, zoom: state.view.zoom * Number(button.dataset.zoom)}});
  });
}
document.getElementById("reset-view").addEventListener("click", () => {
  changeState({view: {center: [0.5, 0.5], zoom: 1, yaw: 0, pitch: 0}});
});
