// Pan and zoom buttons of an app's dashboard panel: `data-pan="dx,dy"` (fractions of the
// view), `data-zoom="factor"`, `data-reset-view`, all inside the panel's own element.
import {changeState} from "../api.js";

export function bindViewControls(panel, currentState) {
  for (const button of panel.querySelectorAll("[data-pan]")) {
    button.addEventListener("click", () => {
      const state = currentState();
      if (!state) return;
      const [dx, dy] = button.dataset.pan.split(",").map(Number);
      const view = state.view;
      const step = 1 / view.zoom;
      changeState({view: {...view, center: [view.center[0] + dx * step, view.center[1] + dy * step]}});
    });
  }
  for (const button of panel.querySelectorAll("[data-zoom]")) {
    button.addEventListener("click", () => {
      const state = currentState();
      if (state) changeState({view: {...state.view, zoom: state.view.zoom * Number(button.dataset.zoom)}});
    });
  }
  for (const button of panel.querySelectorAll("[data-reset-view]")) {
    button.addEventListener("click", () => {
      changeState({view: {center: [0.5, 0.5], zoom: 1, yaw: 0, pitch: 0}});
    });
  }
}
