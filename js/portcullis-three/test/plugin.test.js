// The GLTFLoader plugin in Node: converted samples parsed by three's own GLTFLoader with the
// plugin registered, then, per camera, the objects shown must be exactly what the runtime's draw
// list of the directly visible cells says (nodes drawn whole by `.visible`, split primitives by
// their geometry groups), portal meshes and unnamed parts hidden, everything else untouched, and
// the trace the plugin ran must be the one `portcullis cull` prints for the same camera.

import assert from 'node:assert/strict';
import { readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';

import { Group, Object3D, PerspectiveCamera, Vector3 } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

import { PortcullisLoaderPlugin, PortcullisLevel, isShown } from '../index.js';
import { report } from '../runtime.js';
import { formatReport } from '../cli.js';
import { SAMPLES, binary, compare, convert, rustCull, tempDir } from './helpers.js';

const bin = binary();
const skip = bin ? false : 'no portcullis binary (build it with cargo build --release, or set PORTCULLIS)';
const dir = bin ? tempDir() : null;

async function load(file, options = {}) {
  const b = readFileSync(file);
  const ab = b.buffer.slice(b.byteOffset, b.byteOffset + b.byteLength);
  const loader = new GLTFLoader().register((parser) => new PortcullisLoaderPlugin(parser, options));
  return loader.parseAsync(ab, '');
}

function converted(name, extra = [], suffix = '') {
  const out = join(dir, `${name}${suffix}.glb`);
  assert.ok(convert(join(SAMPLES, `${name}.gltf`), out, extra), `${name} converts`);
  return out;
}

/** Cameras looking along the four horizontal axes from each cell's centre, and a few random. */
function cameraPoses(level) {
  const poses = [];
  for (let c = 0; c < level.cellCount; c++) {
    const eye = [0, 1, 2].map((a) => (level.cellMin[3 * c + a] + level.cellMax[3 * c + a]) / 2);
    for (const look of [[1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0.2, -1]]) poses.push({ eye, look });
  }
  return poses;
}

function threeCamera({ eye, look }, root = null) {
  const cam = new PerspectiveCamera(70, 1.5, 0.05, 1000);
  const target = new Vector3(eye[0] + look[0], eye[1] + look[1], eye[2] + look[2]);
  cam.position.set(...eye);
  if (root !== null) {
    root.updateWorldMatrix(true, false);
    cam.position.applyMatrix4(root.matrixWorld);
    target.applyMatrix4(root.matrixWorld);
    cam.up.set(0, 1, 0).transformDirection(root.matrixWorld);
  }
  cam.lookAt(target);
  cam.updateMatrixWorld();
  return cam;
}

/** The objects of the level's meshes and how they are drawn now. */
function drawnState(p) {
  const whole = p.wholeObjects.map(([n, o]) => [n, isShown(o)]);
  const split = p.splitObjects.map((s) => [s.key, s.geometry.groups.map((g) => [g.start, g.count])]);
  return { whole, split };
}

/** What the draw list of the trace's direct cells says should be drawn. */
function expectedState(p, trace) {
  const cells = trace.visible.filter((v) => v.transform === null && v.cell !== null).map((v) => v.cell);
  const list = p.level.drawList(cells);
  const nodes = new Set(list.nodes);
  const whole = p.wholeObjects.map(([n]) => [n, nodes.has(n)]);
  const split = p.splitObjects.map((s) => [s.key, list.ranges.filter((r) => `${r.node}/${r.primitive}` === s.key).map((r) => [r.first, r.count])]);
  return { whole, split };
}

/** Runs each camera through the plugin, checks the objects against the draw list, and returns
 * the answers with the camera lines, for `portcullis cull`. */
function fly(p, poses, root = null) {
  const lines = [];
  const answers = [];
  for (const pose of poses) {
    const trace = p.update(threeCamera(pose, root));
    assert.ok(trace !== null);
    assert.deepEqual(drawnState(p), expectedState(p, trace), `camera at ${pose.eye} looking ${pose.look}`);
    lines.push(JSON.stringify(p.lastCamera));
    answers.push(formatReport(report(trace)));
  }
  return { lines, answers };
}

for (const [name, extra, suffix] of [
  ['block_door', [], ''],
  ['two_rooms', [], ''],
  ['bound_boxes', [], ''],
  ['mirror', [], ''],
  ['pillar_room', [], ''],
  ['block_door', ['--split-by-cell'], '.split-by-cell'],
  ['block_pillar_hall', ['--no-draw-lists'], '.no-draw-lists'],
]) {
  test(`the plugin shows what the draw list says, ${name}${suffix}`, { skip }, async (t) => {
    const file = converted(name, extra, suffix);
    const gltf = await load(file);
    const p = gltf.userData.portcullis;
    assert.ok(p instanceof PortcullisLevel, 'gltf.userData.portcullis');
    const json = gltf.parser.json;
    const ext = json.extensions.PORTCULLIS_portals;
    // Every node some cell names has its meshes handled; portal meshes no cell names are hidden.
    const named = new Set(p.level.named);
    for (const n of named) if (json.nodes[n].mesh !== undefined) assert.ok((p.primitiveObjects.get(n) || []).length > 0, `node ${n} found through the associations`);
    for (const q of ext.portals || []) {
      if (Number.isInteger(q.node) && !named.has(q.node)) for (const { object } of p.primitiveObjects.get(q.node) || []) assert.equal(isShown(object), false, `portal node ${q.node} hidden`);
    }
    if (ext.split) assert.equal(p.splitObjects.length, ext.split.primitives.length, 'one geometry per split primitive');
    const poses = cameraPoses(p.level);
    const { lines, answers } = fly(p, poses);
    // The plugin's traces are portcullis's for the same cameras.
    const camFile = join(dir, `${name}${suffix}.plugin.jsonl`);
    writeFileSync(camFile, lines.join('\n') + '\n');
    const r = compare(rustCull(file, camFile), answers);
    assert.deepEqual(r.problems.slice(0, 3), [], `${r.problems.length} of ${r.cameras} differ from portcullis cull`);
    // Something was hidden by some camera (or the level has one cell).
    t.diagnostic(`${name}${suffix}: ${poses.length} cameras, ${p.wholeObjects.length} whole-node meshes, ${p.splitObjects.length} split primitives, ${p.neverObjects.length} never drawn`);
  });
}

test('doors, a moved level, other cameras, dispose', { skip }, async () => {
  const file = converted('two_rooms');
  const gltf = await load(file);
  const p = gltf.userData.portcullis;
  const kitchen = { eye: [1, 1.5, 2], look: [1, 0, 0] };
  const shown = () => new Map(p.wholeObjects.map(([n, o]) => [n, isShown(o)]));
  p.update(threeCamera(kitchen));
  const open = shown();
  const lounge = p.level.nodesOf(1);
  assert.ok(lounge.every((n) => open.get(n)), 'the lounge is seen through the door');
  p.setDoor(0, true);
  p.update(threeCamera(kitchen));
  assert.ok(lounge.every((n) => !shown().get(n)), 'the door closed hides the lounge');
  assert.ok(p.level.nodesOf(0).every((n) => shown().get(n)), 'the kitchen is drawn');
  p.setDoor(1, false); // the partner: the same door
  p.update(threeCamera(kitchen));
  assert.deepEqual(shown(), open);

  // The level moved, turned and scaled in the world: the same cells, the same objects.
  const poses = cameraPoses(p.level);
  const before = poses.map((pose) => {
    p.update(threeCamera(pose));
    return JSON.stringify(drawnState(p));
  });
  assert.ok(new Set(before).size > 1, 'the cameras see different things');
  const world = new Group();
  world.position.set(1e4, -30, 7);
  world.rotation.set(0.3, 1.1, -0.2);
  world.scale.setScalar(2.5);
  world.add(gltf.scene);
  world.updateMatrixWorld(true);
  const after = poses.map((pose) => {
    p.update(threeCamera(pose, gltf.scene));
    return JSON.stringify(drawnState(p));
  });
  assert.deepEqual(after, before);

  // Not a perspective camera: everything the cells draw is shown.
  assert.equal(p.update(new Object3D()), null);
  assert.ok([...shown().values()].every((v) => v));

  // A node with child nodes is hidden by its material, its children stay drawn.
  const withChild = p.wholeObjects.find(([, o]) => o.children.length > 0);
  assert.equal(withChild, undefined, 'two_rooms has no such node (checked below by hand)');
  p.dispose();
  assert.ok(p.splitObjects.length === 0);
});

test('a mesh node with child nodes is hidden by its material, keeping its children', { skip }, async (t) => {
  // Make the kitchen's floor the parent of its walls in the glTF, then convert that.
  const src = JSON.parse(readFileSync(join(SAMPLES, 'two_rooms.gltf'), 'utf8'));
  const byName = (name, parent) => src.nodes.findIndex((n, i) => n.name === name && src.nodes[parent].children.includes(i));
  const kitchen = src.nodes.findIndex((n) => n.name === 'kitchen-room');
  const floor = byName('Floor', kitchen);
  const walls = byName('Walls', kitchen);
  src.nodes[kitchen].children = src.nodes[kitchen].children.filter((c) => c !== walls);
  src.nodes[floor].children = [walls];
  const input = join(dir, 'two_rooms.nested-nodes.gltf');
  writeFileSync(input, JSON.stringify(src));
  const file = join(dir, 'two_rooms.nested-nodes.glb');
  assert.ok(convert(input, file), 'the edited two_rooms converts');
  const gltf = await load(file);
  const p = gltf.userData.portcullis;
  const parents = p.wholeObjects.filter(([, o]) => o.children.length > 0);
  assert.equal(parents.length, 1, 'the floor holds the walls');
  const [n, o] = parents[0];
  // A camera in the lounge looking away from the door: the kitchen is not drawn.
  p.update(threeCamera({ eye: [7, 1.5, 2], look: [1, 0, 0] }));
  assert.equal(p.drawn.nodes.includes(n), false, 'the kitchen floor is not drawn');
  assert.equal(isShown(o), false);
  assert.equal(o.visible, true, 'the parent stays visible for its children');
  const [child] = o.children;
  const childNode = p.wholeObjects.find(([, c]) => c === child);
  assert.ok(childNode, 'the walls are a node of their own');
  // From the kitchen both are drawn again, and the material is back.
  p.update(threeCamera({ eye: [1, 1.5, 2], look: [1, 0, 0] }));
  assert.equal(isShown(o), true);
  assert.equal(isShown(child), true);
  t.diagnostic(`node ${n} (${o.name}) with child ${childNode[0]}: hidden by material, shown again`);
});

test('hideUnlisted hides the meshes no cell names', { skip }, async () => {
  const file = converted('bound_boxes');
  const keep = (await load(file)).userData.portcullis;
  const hide = (await load(file, { hideUnlisted: true })).userData.portcullis;
  assert.equal(keep.neverObjects.length, 0, 'the bound boxes are kept by default');
  assert.ok(hide.neverObjects.length >= 2, 'and hidden with hideUnlisted');
  assert.ok(hide.neverObjects.every((o) => !isShown(o)));
});
