// The test pattern's dashboard panel: layers, pan and zoom.
import {changeState, onStatus} from "tagwall/api.js";
import {bindViewControls} from "tagwall/panels/view.js";

const panel = document.getElementById("pattern-panel");
let state = null;

onStatus((detail) => {
  state = detail.status.state;
  for (const box of panel.querySelectorAll("[data-layer]")) {
    box.checked = state.layers[box.dataset.layer] ?? true;
  }
});

for (const box of panel.querySelectorAll("[data-layer]")) {
  box.addEventListener("change", () => changeState({layers: {[box.dataset.layer]: box.checked}}));
}
bindViewControls(panel, () => state);
