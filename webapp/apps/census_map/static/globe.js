// The census map on a globe, one display's part of the wall's one camera (CesiumJS,
// served from our own origin at /static/cesium; nothing is fetched from elsewhere: the
// imagery is Cesium's bundled Natural Earth II, no Ion, no base layer of its own).
//
// Cesium draws into a canvas of its own, kept out of sight at the display's native
// size; the census layer copies each finished picture into the tile's frame like any
// other layer, under the codes, so the globe swaps at the wall clock's instant with
// everything else and codes stay pixel-exact over it.
import {displayFrustum} from "./frustum.js";

const CESIUM_URL = "/static/cesium/";
const SETTLE_MS = 20000;  // at most this long for imagery before answering ready
// Settling takes dozens of frames, and under software GL each costs the GPU process about
// a second at 1920 x 1080 (multisampled), whatever it shows: drafts at a quarter of the
// size cost a sixteenth and load the same tiles (Cesium divides a tile's screen-space
// error by the resolution scale); only the picture kept is drawn at full size.
const DRAFT_SCALE = 0.25;
const LIFT_M = 0;  // tracts lie on the ellipsoid (no terrain)

/** Why this browser cannot draw the globe ("" when it can). */
export function globeMissing() {
  const canvas = document.createElement("canvas");
  const gl = canvas.getContext("webgl2") ?? canvas.getContext("webgl");
  return gl ? "" : "no WebGL";
}

// Cesium's module build, from our own origin, under the pages' usual Content-Security-
// Policy (no 'unsafe-eval', no blob: scripts): its workers start from
// /static/cesium/Workers as modules of our origin (its classic build, Cesium.js, starts
// them from blobs), and the one string it evaluated at import is replaced when it is
// installed (the Makefile). What it still tries is refused and not needed here: a
// WebAssembly probe for meshopt (glTF models) and protobuf's optional require.
let cesiumLoading = null;
function cesium() {
  window.CESIUM_BASE_URL = CESIUM_URL;
  cesiumLoading ??= import(`${CESIUM_URL}index.js`);
  return cesiumLoading;
}

let WallFrustum = null;

/** Cesium's PerspectiveFrustum, off centre as `tangents` (displayFrustum) say at any near
 * distance: Cesium draws with the near plane it picks for what it shows, and its own
 * offsets (xOffset, yOffset) are lengths at one near distance, so here they follow the
 * near plane. (A PerspectiveOffCenterFrustum keeps its edges when the near plane moves,
 * and the globe's level of detail needs a PerspectiveFrustum's field of view.) */
function wallFrustum(Cesium, tangents) {
  WallFrustum ??= class extends Cesium.PerspectiveFrustum {
    get xOffset() { return (this.near ?? 1) * (this.tangents?.x ?? 0); }
    set xOffset(value) { /* follows the near plane */ }
    get yOffset() { return (this.near ?? 1) * (this.tangents?.y ?? 0); }
    set yOffset(value) { /* follows the near plane */ }
    clone(result) {
      const copy = result instanceof WallFrustum ? result : new WallFrustum();
      copy.tangents = this.tangents;
      copy.fov = this.fov;
      copy.aspectRatio = this.aspectRatio;
      copy.near = this.near;
      copy.far = this.far;
      return copy;
    }
  };
  const {left, right, top, bottom} = tangents;
  const made = new WallFrustum();
  made.tangents = {x: (left + right) / 2, y: (top + bottom) / 2};
  made.aspectRatio = (right - left) / (top - bottom);
  // Cesium's fov is across the longer side of the picture
  made.fov = 2 * Math.atan(Math.max(right - left, top - bottom) / 2);
  made.near = 1.0;
  made.far = 1e8;
  return made;
}

export class Globe {
  /** A globe for `display` (its native resolution and to_pixels). */
  static async create(display) {
    const Cesium = await cesium();
    return new Globe(Cesium, display);
  }

  constructor(Cesium, display) {
    this.Cesium = Cesium;
    this.display = display;
    const [width, height] = display.resolution;
    const box = document.createElement("div");
    // Out of sight behind the frames, at the display's native pixels (devicePixelRatio
    // is undone, so the picture is exactly as large as the display).
    const ratio = window.devicePixelRatio || 1;
    Object.assign(box.style, {
      position: "fixed", left: "0", top: "0", zIndex: "-1", visibility: "hidden",
      width: `${width / ratio}px`, height: `${height / ratio}px`,
    });
    document.body.append(box);
    const credits = document.createElement("div");  // Cesium's credits, never shown
    const imagery = Cesium.TileMapServiceImageryProvider.fromUrl(
      Cesium.buildModuleUrl("Assets/Textures/NaturalEarthII"),
    );
    this.widget = new Cesium.CesiumWidget(box, {
      baseLayer: Cesium.ImageryLayer.fromProviderAsync(imagery),
      useDefaultRenderLoop: false,
      creditContainer: credits,
      skyBox: false,
      skyAtmosphere: false,
      scene3DOnly: true,
      requestRenderMode: false,
      contextOptions: {webgl: {preserveDrawingBuffer: true, alpha: false}},
    });
    // Cesium sizes its canvas by its stylesheet (widgets.css, not loaded here): without
    // these the canvas keeps the default 300 x 150 and the picture is that, scaled up.
    for (const element of [this.widget.canvas.parentElement, this.widget.canvas]) {
      Object.assign(element.style, {width: "100%", height: "100%"});
    }
    const scene = this.widget.scene;
    scene.backgroundColor = Cesium.Color.fromCssColorString("#05070a");
    scene.fog.enabled = false;
    scene.globe.showGroundAtmosphere = false;
    scene.globe.enableLighting = false;
    scene.sun = undefined;
    scene.moon = undefined;
    this.ready = imagery;
    this.map = null;      // the globe body shown: {dataset, camera, tracts}
    this.fills = null;    // the tracts' primitive
    this.lines = null;    // their outlines
    this.styleKey = null;
  }

  get canvas() {
    return this.widget.canvas;
  }

  /** Point the camera as the wall's camera, seen through this display. The server
   * says where the one camera stands and which way it looks (webapp/apps/census_map/
   * globe.py: turned and tilted there, Earth-centred `position`, `direction` and `up`,
   * the way the top of the wall faces); this display looks along the same direction
   * through its own off-centre part of it, its picture's up turned in the camera's
   * plane as the panel hangs (frustum.js: `up` in the wall's right and up). */
  aim(camera) {
    const Cesium = this.Cesium;
    const frustum = displayFrustum(this.display, camera.eye);
    const position = Cesium.Cartesian3.fromArray(camera.position);
    const direction = Cesium.Cartesian3.fromArray(camera.direction);
    const wallUp = Cesium.Cartesian3.fromArray(camera.up);
    const right = Cesium.Cartesian3.cross(direction, wallUp, new Cesium.Cartesian3());
    const [ur, uu] = frustum.up;
    const up = Cesium.Cartesian3.add(
      Cesium.Cartesian3.multiplyByScalar(right, ur, new Cesium.Cartesian3()),
      Cesium.Cartesian3.multiplyByScalar(wallUp, uu, new Cesium.Cartesian3()),
      new Cesium.Cartesian3(),
    );
    const cam = this.widget.scene.camera;
    cam.frustum = wallFrustum(Cesium, frustum);
    cam.setView({destination: position, orientation: {direction, up}});
  }

  /** The tracts of `map` (a new data set or view: drawn anew), coloured by `style`. */
  show(map, style) {
    if (this.map !== map) {
      this.map = map;
      this.build(map, style);
    }
    this.aim(map.camera);
  }

  build(map, style) {
    const Cesium = this.Cesium;
    const primitives = this.widget.scene.primitives;
    if (this.fills) primitives.remove(this.fills);
    if (this.lines) primitives.remove(this.lines);
    const fills = [];
    const lines = [];
    for (const tract of map.tracts) {
      const look = style(tract);
      for (const [outer, ...holes] of tract.polygons) {
        const hierarchy = new Cesium.PolygonHierarchy(
          Cesium.Cartesian3.fromDegreesArray(outer),
          holes.map((hole) => new Cesium.PolygonHierarchy(Cesium.Cartesian3.fromDegreesArray(hole))),
        );
        fills.push(new Cesium.GeometryInstance({
          id: tract.id,
          geometry: new Cesium.PolygonGeometry({polygonHierarchy: hierarchy, height: LIFT_M}),
          attributes: {
            color: Cesium.ColorGeometryInstanceAttribute.fromColor(
              Cesium.Color.fromCssColorString(look.fill)),
            show: new Cesium.ShowGeometryInstanceAttribute(look.shown),
          },
        }));
        for (const ring of [outer, ...holes]) {
          lines.push(new Cesium.GeometryInstance({
            id: `${tract.id}:line:${lines.length}`,
            geometry: new Cesium.SimplePolylineGeometry({
              positions: Cesium.Cartesian3.fromDegreesArray([...ring, ring[0], ring[1]]),
              arcType: Cesium.ArcType.GEODESIC,
            }),
            attributes: {
              color: Cesium.ColorGeometryInstanceAttribute.fromColor(
                Cesium.Color.fromCssColorString(look.line)),
              show: new Cesium.ShowGeometryInstanceAttribute(look.shown),
            },
          }));
        }
      }
    }
    this.fills = primitives.add(new Cesium.Primitive({
      geometryInstances: fills,
      appearance: new Cesium.PerInstanceColorAppearance({flat: true, translucent: false}),
      asynchronous: false,
    }));
    // The outlines lie on the ellipsoid as the fills do: depth-tested, they fought the
    // fills for every pixel and showed as dotted lines, dotted differently on each display
    // (each has its own projection). Drawn after the fills without the test, they are
    // whole; nothing else on the globe stands between them and the camera.
    this.lines = primitives.add(new Cesium.Primitive({
      geometryInstances: lines,
      appearance: new Cesium.PerInstanceColorAppearance({
        flat: true, translucent: false, renderState: {depthTest: {enabled: false}},
      }),
      asynchronous: false,
    }));
    this.lineOwners = lines.map((line) => line.id.split(":line:")[0]);
    this.styleKey = null;
  }

  /** Colours and groups shown, tract by tract (`style(tract)`: {fill, line, shown}). */
  restyle(key, style) {
    if (!this.map || key === this.styleKey) return;
    const Cesium = this.Cesium;
    this.render(DRAFT_SCALE);  // a primitive's attributes exist once it was drawn
    const looks = new Map(this.map.tracts.map((tract) => [tract.id, style(tract)]));
    for (const [id, look] of looks) {
      const attributes = this.fills.getGeometryInstanceAttributes(id);
      if (!attributes) continue;
      attributes.color = Cesium.ColorGeometryInstanceAttribute.toValue(
        Cesium.Color.fromCssColorString(look.fill), attributes.color);
      attributes.show = Cesium.ShowGeometryInstanceAttribute.toValue(look.shown, attributes.show);
    }
    this.lineOwners.forEach((owner, index) => {
      const look = looks.get(owner);
      const attributes = this.lines.getGeometryInstanceAttributes(`${owner}:line:${index}`);
      if (!attributes || !look) return;
      attributes.color = Cesium.ColorGeometryInstanceAttribute.toValue(
        Cesium.Color.fromCssColorString(look.line), attributes.color);
      attributes.show = Cesium.ShowGeometryInstanceAttribute.toValue(look.shown, attributes.show);
    });
    this.styleKey = key;
  }

  /** Draw a frame at `scale` times the display's pixels (the picture shown: 1). */
  render(scale = 1) {
    this.widget.resolutionScale = scale;
    this.widget.resize();
    this.widget.render();
  }

  /** Render until the imagery the camera sees has loaded (or SETTLE_MS passed), in
   * drafts, then the picture. */
  async settle() {
    await this.ready;
    const until = performance.now() + SETTLE_MS;
    let frames = 0;
    for (;;) {
      this.render(DRAFT_SCALE);
      frames += 1;
      if ((frames > 2 && this.widget.scene.globe.tilesLoaded) || performance.now() > until) break;
      await new Promise((resolve) => setTimeout(resolve, 15));
    }
    this.render();
  }
}
