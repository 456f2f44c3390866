// What a view costs an engine to draw, in triangles and draw calls submitted: a port of
// crates/portcullis-runtime/src/runtime/cost.rs for `cli.js cull --stats`, from the glTF's JSON alone (accessor counts,
// POSITION bounds, node transforms). Three ways are priced, each with frustum culling of every
// node's box: `frustum` (every node of the level's geometry), `nodes` (the visible cells' nodes
// drawn whole), `lists` (the visible cells' draw lists, Level#drawList). A cell seen through a
// mirror or teleporter is priced again for each such view, without frustum culling.

import { mulMat } from './runtime.js';

const NAME = 'PORTCULLIS_portals';

function transformPoint(m, p) {
  const out = [0, 0, 0];
  for (let r = 0; r < 3; r++) {
    let res = m[r] * p[0];
    res = m[4 + r] * p[1] + res;
    res = m[8 + r] * p[2] + res;
    res = m[12 + r] + res;
    out[r] = res;
  }
  return out;
}

/** A node's local transform, as glam builds it (`matrix`, else translation, rotation, scale). */
function local(n) {
  if (Array.isArray(n.matrix) && n.matrix.length === 16) return n.matrix.slice();
  const t = Array.isArray(n.translation) ? n.translation : [0, 0, 0];
  let q = Array.isArray(n.rotation) ? n.rotation : [0, 0, 0, 1];
  if (Array.isArray(n.rotation)) {
    const rcp = 1.0 / Math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    q = q.map((v) => v * rcp);
  }
  const s = Array.isArray(n.scale) ? n.scale : [1, 1, 1];
  const [x, y, z, w] = q;
  const x2 = x + x, y2 = y + y, z2 = z + z;
  const xx = x * x2, xy = x * y2, xz = x * z2;
  const yy = y * y2, yz = y * z2, zz = z * z2;
  const wx = w * x2, wy = w * y2, wz = w * z2;
  const xa = [1.0 - (yy + zz), xy + wz, xz - wy, 0.0];
  const ya = [xy - wz, 1.0 - (xx + zz), yz + wx, 0.0];
  const za = [xz + wy, yz - wx, 1.0 - (xx + yy), 0.0];
  return [...xa.map((v) => v * s[0]), ...ya.map((v) => v * s[1]), ...za.map((v) => v * s[2]), t[0], t[1], t[2], 1.0];
}

/** The meshes of a converted level's scene, per glTF node: world box and triangles per
 * primitive. */
export class Meshes {
  constructor(json) {
    const nodes = json.nodes || [];
    const meshes = json.meshes || [];
    const accessors = json.accessors || [];
    const parts = new Set();
    for (const n of nodes) {
      const ours = n.extensions && n.extensions[NAME];
      for (const p of (ours && ours.parts) || []) parts.add(p);
    }
    this.parts = [...parts].sort((a, b) => a - b);
    this.nodes = new Array(nodes.length).fill(null);
    const scenes = json.scenes || [];
    const scene = scenes[json.scene === undefined ? 0 : json.scene];
    let roots;
    if (scene !== undefined) roots = scene.nodes || [];
    else {
      const child = new Array(nodes.length).fill(false);
      for (const n of nodes) for (const c of n.children || []) if (c < child.length) child[c] = true;
      roots = nodes.map((_, i) => i).filter((i) => !child[i]);
    }
    const IDENTITY = [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1];
    const stack = roots.map((n) => [n, IDENTITY]);
    const seen = new Array(nodes.length).fill(false);
    while (stack.length > 0) {
      const [n, parent] = stack.pop();
      const node = nodes[n];
      if (node === undefined || seen[n]) continue;
      seen[n] = true;
      const world = mulMat(parent, local(node));
      const mesh = node.mesh === undefined ? undefined : meshes[node.mesh];
      if (mesh !== undefined) this.nodes[n] = nodeMesh(accessors, mesh, world);
      for (const c of node.children || []) stack.push([c, world]);
    }
  }

  node(n) {
    return this.nodes[n] || null;
  }

  /** Node n drawn whole, if `view` (when given) sees its box. */
  whole(n, view) {
    const m = this.node(n);
    if (m !== null && (view === null || view.seesBox(m.min, m.max))) return { triangles: m.primitives.reduce((a, b) => a + b, 0), calls: m.primitives.length };
    return { triangles: 0, calls: 0 };
  }

  /** A draw list, each part if `view` (when given) sees its node's box. */
  list(list, view) {
    const s = { triangles: 0, calls: 0 };
    for (const n of list.nodes) add(s, this.whole(n, view));
    for (const r of list.ranges) {
      const m = this.node(r.node);
      if (m !== null && (view === null || view.seesBox(m.min, m.max))) add(s, { triangles: Math.floor(r.count / 3), calls: 1 });
    }
    return s;
  }
}

function add(s, o) {
  s.triangles += o.triangles;
  s.calls += o.calls;
}

function nodeMesh(accessors, mesh, world) {
  let min = [Infinity, Infinity, Infinity];
  let max = [-Infinity, -Infinity, -Infinity];
  const primitives = [];
  for (const p of mesh.primitives || []) {
    const attrs = p.attributes || {};
    const pos = attrs.POSITION === undefined ? undefined : accessors[attrs.POSITION];
    const ix = p.indices === undefined ? undefined : accessors[p.indices];
    const n = ix !== undefined ? ix.count || 0 : pos !== undefined ? pos.count || 0 : 0;
    const mode = p.mode === undefined ? 4 : p.mode;
    primitives.push(mode === 4 ? Math.floor(n / 3) : mode === 5 || mode === 6 ? Math.max(n - 2, 0) : 0);
    const lo = pos && pos.min;
    const hi = pos && pos.max;
    if (!(Array.isArray(lo) && Array.isArray(hi) && lo.length === 3 && hi.length === 3)) {
      min = [-Infinity, -Infinity, -Infinity];
      max = [Infinity, Infinity, Infinity];
      continue;
    }
    for (let i = 0; i < 8; i++) {
      const c = [i & 1 ? hi[0] : lo[0], i & 2 ? hi[1] : lo[1], i & 4 ? hi[2] : lo[2]];
      const w = transformPoint(world, c);
      min = min.map((v, a) => (v < w[a] ? v : w[a]));
      max = max.map((v, a) => (v > w[a] ? v : w[a]));
    }
  }
  return { min, max, primitives };
}

/** What `view` costs by the cells `trace` found visible: `{frustum, nodes, lists}`. */
export function cost(level, meshes, view, trace) {
  const out = { frustum: { triangles: 0, calls: 0 }, nodes: { triangles: 0, calls: 0 }, lists: { triangles: 0, calls: 0 } };
  const named = level.named;
  const namedSet = new Set(named);
  for (const n of [...named, ...meshes.parts.filter((n) => !namedSet.has(n))]) add(out.frustum, meshes.whole(n, view));
  const cells = trace.visible.filter((v) => v.transform === null && v.cell !== null).map((v) => v.cell);
  const nodes = [...new Set(cells.flatMap((c) => level.nodesOf(c)))].sort((a, b) => a - b);
  for (const n of nodes) add(out.nodes, meshes.whole(n, view));
  add(out.lists, meshes.list(level.drawList(cells), view));
  for (const v of trace.visible) {
    if (v.transform === null || v.cell === null) continue;
    for (const n of level.nodesOf(v.cell)) add(out.nodes, meshes.whole(n, null));
    add(out.lists, meshes.list(level.drawList([v.cell]), null));
  }
  return out;
}

/** What cell c draws of its own, by its draw list, without culling. */
export function cellCost(level, meshes, c) {
  return meshes.list(level.drawList([c]), null);
}
