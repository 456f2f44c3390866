// A three.js GLTFLoader plugin for levels written by `portcullis convert`: it reads the
// `PORTCULLIS_portals` extension into the JavaScript runtime (runtime.js) and attaches a
// `PortcullisLevel` to `gltf.userData.portcullis`, whose `update(camera)` traces the camera's
// view through the portals each frame and shows only what the visible cells draw.
//
//   import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
//   import { PortcullisLoaderPlugin } from 'portcullis-three';
//   const loader = new GLTFLoader().register((parser) => new PortcullisLoaderPlugin(parser));
//   const gltf = await loader.loadAsync('level.glb');
//   scene.add(gltf.scene);
//   // each frame, before renderer.render(scene, camera):
//   gltf.userData.portcullis.update(camera);
//
// How drawing follows the runtime's draw list (Level#drawList of the cells seen directly):
// - a node the visible cells draw whole: the Object3Ds of its mesh primitives get
//   `.visible = true`, else false (a single-primitive node that has child nodes is hidden by
//   swapping in an invisible material instead, so its children stay drawn);
// - a split node (`split.primitives`): each split primitive's Mesh gets, at load, a geometry of
//   its own that shares the primitive's vertex attributes and takes the extension's split index
//   accessor as its index, and its material as a one-element array; each frame its geometry
//   groups are set to the joined ranges of the draw list, so three.js issues one draw call per
//   range and draws nothing of it when it has none. Its other primitives (points, lines) are
//   never drawn, as the extension's rule says (a split node is drawn only through its ranges);
// - authored portal nodes (`portals[].node`) and `--split-by-cell` parts that no cell names are
//   hidden: no cell draws them;
// - every other object (lights, cameras, meshes in no room) is left as it is, unless the option
//   `hideUnlisted` is set, which hides the meshes that no cell names.
// Cells seen only through mirrors and teleporters are not drawn by `update` (they need their own
// pass with the entry's `transform`); `update` returns the trace, whose `visible` entries carry
// each cell's screen rectangle (for scissoring), transform and winding.

import { Matrix4, MeshBasicMaterial, Vector3 } from 'three';

import { DEFAULT_OPTIONS, Doors, Level, Trace, View } from './runtime.js';

export * from './runtime.js';

const NAME = 'PORTCULLIS_portals';

/** The invisible material that hides a mesh without hiding its children. */
const HIDDEN = new MeshBasicMaterial({ visible: false });
HIDDEN.name = 'portcullis-hidden';

/**
 * The GLTFLoader plugin: `loader.register((parser) => new PortcullisLoaderPlugin(parser,
 * options))`. Options: `hideUnlisted` (hide every mesh no cell names), `trace` (the trace
 * limits: `maxDepth`, `maxTransformDepth`, `usePvs`).
 */
export class PortcullisLoaderPlugin {
  constructor(parser, options = {}) {
    this.parser = parser;
    this.name = NAME;
    this.options = options;
  }

  async afterRoot(result) {
    const parser = this.parser;
    const json = parser.json;
    const ext = json.extensions && json.extensions[NAME];
    if (!ext) return;
    const vis = ext.visibility;
    let visibilityBytes = null;
    if (vis && Number.isInteger(vis.bufferView)) visibilityBytes = new Uint8Array(await parser.getDependency('bufferView', vis.bufferView));
    const level = Level.fromGltf(json, { visibilityBytes });
    const splitIndex = level.splitIndices === null ? null : await parser.getDependency('accessor', level.splitIndices);
    result.userData.portcullis = new PortcullisLevel(level, result.scene, parser.associations, json, splitIndex, this.options);
  }
}

/**
 * A loaded level: the runtime's `Level`, the scene it was loaded into, and the per-frame
 * `update(camera)`.
 */
export class PortcullisLevel {
  /**
   * @param {Level} level the runtime level
   * @param {import('three').Object3D} root the glTF scene (its frame is the level's)
   * @param {Map<object, object>} associations GLTFParser.associations
   * @param {object} json the glTF JSON
   * @param {import('three').BufferAttribute|null} splitIndex the split index accessor
   * @param {object} options see PortcullisLoaderPlugin
   */
  constructor(level, root, associations, json, splitIndex, options = {}) {
    this.level = level;
    this.root = root;
    this.doors = new Doors(level);
    this.options = { ...DEFAULT_OPTIONS, ...(options.trace || {}) };
    this.trace = new Trace();
    /** The draw list of the last update: `{nodes, ranges}`. */
    this.drawn = { nodes: [], ranges: [] };
    /** Per glTF node index, the Object3Ds it was loaded as. */
    this.nodeObjects = new Map();
    /** Per glTF node index, `{object, primitive}` for each Object3D of its mesh primitives. */
    this.primitiveObjects = new Map();
    const nodeOf = (o) => {
      const a = associations.get(o);
      return a && a.nodes !== undefined ? a.nodes : undefined;
    };
    root.traverse((o) => {
      const n = nodeOf(o);
      if (n === undefined) return;
      if (!this.nodeObjects.has(n)) this.nodeObjects.set(n, []);
      this.nodeObjects.get(n).push(o);
    });
    const nodes = json.nodes || [];
    for (const [n, objects] of this.nodeObjects) {
      const mesh = nodes[n] ? nodes[n].mesh : undefined;
      if (mesh === undefined) continue;
      const found = [];
      const visit = (o, top) => {
        if (!top && nodeOf(o) !== undefined) return; // a child node
        const a = associations.get(o);
        if (a && a.meshes === mesh && a.primitives !== undefined) found.push({ object: o, primitive: a.primitives });
        for (const c of o.children) visit(c, false);
      };
      for (const o of objects) visit(o, true);
      this.primitiveObjects.set(n, found);
    }

    // What each object is to the level.
    const named = new Set(level.named);
    const splitKey = (node, primitive) => `${node}/${primitive}`;
    const splitPrims = new Map(level.splitPrimitives.map((p, k) => [splitKey(p.node, p.primitive), k]));
    const splitNodes = new Set(level.splitPrimitives.map((p) => p.node));
    /** Objects shown when their node is drawn whole: `[node, object]`. */
    this.wholeObjects = [];
    /** Split primitives' objects: `{key, object, geometry, original}`. */
    this.splitObjects = [];
    /** Objects no cell draws. */
    this.neverObjects = [];
    const hidden = new Set();
    for (const p of ext(json).portals || []) if (Number.isInteger(p.node) && !named.has(p.node)) hidden.add(p.node);
    for (const node of nodes) {
      const parts = node.extensions && node.extensions[NAME] && node.extensions[NAME].parts;
      for (const p of parts || []) if (!named.has(p)) hidden.add(p);
    }
    for (const [n, prims] of this.primitiveObjects) {
      for (const { object, primitive } of prims) {
        if (splitNodes.has(n)) {
          const k = splitPrims.get(splitKey(n, primitive));
          if (k === undefined || !splitIndex || !object.geometry) this.neverObjects.push(object);
          else this.splitObjects.push(this.splitGeometry(object, splitKey(n, primitive), splitIndex));
        } else if (named.has(n)) {
          this.wholeObjects.push([n, object]);
        } else if (hidden.has(n) || options.hideUnlisted) {
          this.neverObjects.push(object);
        }
      }
    }
    for (const o of this.neverObjects) setShown(o, false);
    this.showAll();
  }

  /** Gives a split primitive's mesh a geometry of its own over the split index accessor. */
  splitGeometry(object, key, splitIndex) {
    const original = object.geometry;
    const g = shareAttributes(original);
    g.setIndex(splitIndex);
    g.boundingBox = original.boundingBox;
    g.boundingSphere = original.boundingSphere;
    if (g.boundingSphere === null) g.computeBoundingSphere();
    const material = object.material;
    object.geometry = g;
    object.material = Array.isArray(material) ? material : [material];
    return { key, object, geometry: g, original, material };
  }

  /** Shows everything the level's cells draw (as before culling). */
  showAll() {
    for (const [, o] of this.wholeObjects) setShown(o, true);
    for (const s of this.splitObjects) {
      s.geometry.clearGroups();
      const ranges = this.level.splitPrimitives.filter((p) => `${p.node}/${p.primitive}` === s.key);
      for (const p of ranges) s.geometry.addGroup(p.first, p.count, 0);
    }
  }

  /** Opens or closes portal `p` (and its partner) for the next updates. */
  setDoor(p, closed) {
    this.doors.set(this.level, p, closed);
  }

  /**
   * The runtime's view of a three.js PerspectiveCamera, in the level's frame (the glTF scene's
   * world transform undone): eye, -Z as look, +Y as up, the vertical field of view (with
   * zoom), aspect and near plane. Null for another kind of camera.
   */
  viewOf(camera) {
    if (!camera.isPerspectiveCamera) return null;
    camera.updateMatrixWorld();
    this.root.updateWorldMatrix(true, false);
    const toLevel = new Matrix4().copy(this.root.matrixWorld).invert();
    const m = new Matrix4().multiplyMatrices(toLevel, camera.matrixWorld);
    const e = m.elements;
    const eye = [e[12], e[13], e[14]];
    const look = [-e[8], -e[9], -e[10]];
    const up = [e[4], e[5], e[6]];
    const scale = new Vector3(-e[8], -e[9], -e[10]).length() / new Vector3().setFromMatrixColumn(camera.matrixWorld, 2).length();
    const fov = camera.zoom === 1 ? camera.fov : (2 * Math.atan(Math.tan((camera.fov * Math.PI) / 360) / camera.zoom) * 180) / Math.PI;
    /** The last camera as `portcullis cull` reads one (for reproducing a frame). */
    this.lastCamera = { eye, look, up, fov_y: fov, aspect: camera.aspect, near: camera.near * scale };
    return new View(eye, look, up, fov, camera.aspect, camera.near * scale);
  }

  /**
   * Traces `camera` (a three.js PerspectiveCamera, or a runtime View) and shows only what the
   * cells it sees directly draw. Returns the trace (`location`, `visible` with rects, `stats`);
   * for another kind of camera it shows everything and returns null.
   */
  update(camera) {
    const view = camera instanceof View ? camera : this.viewOf(camera);
    if (view === null) {
      this.showAll();
      return null;
    }
    this.level.trace(view, this.doors, this.options, this.trace);
    const direct = [];
    for (const v of this.trace.visible) if (v.transform === null && v.cell !== null) direct.push(v.cell);
    const list = this.level.drawList(direct);
    this.drawn = list;
    const whole = new Set(list.nodes);
    for (const [n, o] of this.wholeObjects) setShown(o, whole.has(n));
    const byKey = new Map();
    for (const r of list.ranges) {
      const key = `${r.node}/${r.primitive}`;
      if (!byKey.has(key)) byKey.set(key, []);
      byKey.get(key).push(r);
    }
    for (const s of this.splitObjects) {
      s.geometry.clearGroups();
      for (const r of byKey.get(s.key) || []) s.geometry.addGroup(r.first, r.count, 0);
    }
    return this.trace;
  }

  /** Whether the sky (the outside) may show: the outside is seen, or a visible cell may see it. */
  seesOutside() {
    return this.trace.visible.some((v) => v.cell === null || (v.transform === null && this.level.seesOutside(v.cell)));
  }

  /** Undoes what the plugin changed: original geometries and materials, everything shown. */
  dispose() {
    for (const s of this.splitObjects) {
      s.object.geometry = s.original;
      s.object.material = s.material;
      s.geometry.dispose();
    }
    for (const [, o] of this.wholeObjects) setShown(o, true);
    for (const o of this.neverObjects) setShown(o, true);
    this.splitObjects = [];
  }
}

function ext(json) {
  return json.extensions[NAME];
}

/** A geometry sharing `g`'s attributes (not copying them), without its index. */
function shareAttributes(g) {
  const out = new g.constructor();
  for (const name of Object.keys(g.attributes)) out.setAttribute(name, g.attributes[name]);
  for (const name of Object.keys(g.morphAttributes)) out.morphAttributes[name] = g.morphAttributes[name];
  out.morphTargetsRelative = g.morphTargetsRelative;
  out.name = g.name;
  out.userData = g.userData;
  return out;
}

/** Shows or hides a mesh; one with children is hidden by its material so they stay drawn. */
function setShown(o, shown) {
  if (o.children.length === 0) {
    o.visible = shown;
    return;
  }
  o.visible = true;
  if (!shown && o.material !== HIDDEN) {
    o.userData.portcullisMaterial = o.material;
    o.material = HIDDEN;
  } else if (shown && o.material === HIDDEN) {
    o.material = o.userData.portcullisMaterial;
    delete o.userData.portcullisMaterial;
  }
}

/** Whether a mesh is drawn now (by `.visible` and the hiding material). */
export function isShown(o) {
  return o.visible && o.material !== HIDDEN;
}
