// The census map on a globe, one display's part of the wall's one camera (CesiumJS,
// served from our own origin at /static/cesium; nothing is fetched from elsewhere: the
// imagery is Cesium's bundled Natural Earth II, no Ion, no base layer of its own; a
// site's own imagery and terrain servers come relayed through our origin, `ground`).
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
// Tracts lie on the ellipsoid, where the codes' placement has them, with terrain too:
// Cesium clears the globe's depth before it draws them (depthTestAgainstTerrain off),
// so land above the ellipsoid never hides them.
const LIFT_M = 0;

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

/** "(HTTP 502)" from a failed request's error, when it says. */
function statusOf(error) {
  const code = error?.statusCode ?? /Status Code: (\d+)/.exec(String(error?.message ?? error))?.[1];
  return code ? ` (HTTP ${code})` : "";
}

export class Globe {
  /** A globe for `display` (its native resolution and to_pixels), on the site's
   * `ground` ({imagery, terrain}: our relay's paths, or nulls) where it has one. */
  static async create(display, ground = {}) {
    const Cesium = await cesium();
    let terrain = null;
    let terrainNote = "";
    if (ground.terrain) {
      try {
        // asked first here for the status Cesium's error leaves out (then from the cache)
        const layer = await fetch(`${ground.terrain}layer.json`);
        if (!layer.ok) throw {statusCode: layer.status};
        terrain = await Cesium.CesiumTerrainProvider.fromUrl(ground.terrain);
      } catch (error) {
        terrainNote = `shows the globe without terrain: its server failed${statusOf(error)}`;
      }
    }
    return new Globe(Cesium, display, ground, terrain, terrainNote);
  }

  constructor(Cesium, display, ground = {}, terrain = null, terrainNote = "") {
    this.Cesium = Cesium;
    this.display = display;
    this.terrainNote = terrainNote;
    this.imageryFailures = new Map();  // HTTP status (or "") -> pictures the site's server failed
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
      ...(terrain ? {terrainProvider: terrain} : {}),
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
    this.layGround(ground, terrain);
    this.map = null;      // the globe body shown: {dataset, camera, tracts}
    this.fills = null;    // the tracts' primitive
    this.lines = null;    // their outlines
    this.styleKey = null;
  }

  /** The site's imagery over Natural Earth II, so wherever its server sends no
   * picture (down, slow, a tile it lacks) Natural Earth shows beneath, never a hole;
   * and its terrain, dropped for the bare ellipsoid as soon as its server fails (a
   * terrain tile that cannot load is a hole in the globe). */
  layGround(ground, terrain) {
    const Cesium = this.Cesium;
    if (ground.imagery) {
      const site = new Cesium.UrlTemplateImageryProvider({url: ground.imagery});
      site.errorEvent.addEventListener((failure) => {
        const status = failure.error?.statusCode;
        if (status === 404) return;  // a tile the server does not have: nothing wrong
        const key = status ? String(status) : "";
        this.imageryFailures.set(key, (this.imageryFailures.get(key) ?? 0) + 1);
      });
      this.widget.imageryLayers.addImageryProvider(site);
    }
    terrain?.errorEvent.addEventListener((failure) => {
      if (this.terrainNote) return;
      this.terrainNote = `shows the globe without terrain: its server failed${statusOf(failure.error)}`;
      this.widget.scene.terrainProvider = new Cesium.EllipsoidTerrainProvider();
    });
  }

  /** What this globe shows otherwise than the site asked (the tile's `applied` notes). */
  notes() {
    const notes = this.terrainNote ? [this.terrainNote] : [];
    if (this.imageryFailures.size) {
      const count = [...this.imageryFailures.values()].reduce((sum, n) => sum + n, 0);
      const codes = [...this.imageryFailures.keys()].filter(Boolean).map((c) => `HTTP ${c}`);
      notes.push(`shows Natural Earth where its imagery server failed (${count} pictures`
        + `${codes.length ? `, ${codes.join(", ")}` : ""})`);
    }
    return notes;
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
    // Cesium's own context (asked again for its kind, it is the one already made)
    const gl = this.canvas.getContext("webgl2") ?? this.canvas.getContext("webgl");
    const pixel = new Uint8Array(4);
    for (;;) {
      this.render(DRAFT_SCALE);
      // Wait for the GPU to draw it: under software GL, JavaScript otherwise queues
      // drafts far faster than they are drawn (130 while a site's imagery loads), and
      // the picture waits behind them all (docs/census.md, How fast).
      gl.readPixels(0, 0, 1, 1, gl.RGBA, gl.UNSIGNED_BYTE, pixel);
      frames += 1;
      if ((frames > 2 && this.widget.scene.globe.tilesLoaded) || performance.now() > until) break;
      await new Promise((resolve) => setTimeout(resolve, 15));
    }
    this.render();
  }
}
