// The instructor's phone remote of the wall's video: the controls alone, big.
import {wallId} from "tagwall/api.js";
import {VideoControls} from "./controls.js";

new VideoControls(document.querySelector("[data-video-controls]"), wallId).follow();
