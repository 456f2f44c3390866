#!/usr/bin/env node
// What a frame costs: `node bench.js LEVEL [CAMERAS] [--rounds N]` traces cameras with the
// JavaScript runtime and prints the median, mean and slowest time of one trace per camera, and
// of the draw list of its direct cells; then the same cameras through the three.js plugin's
// `update(camera)` (trace, draw list, and setting `.visible` and geometry groups) on the level
// loaded by GLTFLoader in Node (a .glb without textures). Without a cameras file it makes 512 as
// `cargo bench --bench stages -- cull` does: the centres of random cells, looking level in a
// random direction, 75 degrees vertical, 16:9, near 0.05 m (seeded, so runs compare).

import { readFileSync } from 'node:fs';

import { PerspectiveCamera, Vector3 } from 'three';
import { GLTFLoader } from 'three/examples/jsm/loaders/GLTFLoader.js';

import { PortcullisLoaderPlugin } from './index.js';

import { loadLevel, parseCamera } from './cli.js';
import { Doors, Trace, View } from './runtime.js';
import { prng } from './test/cameras.js';


const args = process.argv.slice(2);
let rounds = 20;
const files = [];
for (let i = 0; i < args.length; i++) {
  if (args[i] === '--rounds') rounds = Number(args[++i]);
  else files.push(args[i]);
}
if (files.length === 0) {
  process.stderr.write('usage: node bench.js LEVEL [CAMERAS] [--rounds N]\n');
  process.exit(2);
}
const level = loadLevel(files[0]);
let views;
if (files[1]) {
  views = readFileSync(files[1], 'utf8').split('\n').map(parseCamera).filter((v) => v !== null);
} else {
  const rand = prng(512);
  views = [];
  for (let i = 0; i < 512 && level.cellCount > 0; i++) {
    const c = Math.floor(rand() * level.cellCount);
    const eye = [0, 1, 2].map((a) => (level.cellMin[3 * c + a] + level.cellMax[3 * c + a]) / 2);
    const angle = rand() * 2 * Math.PI;
    views.push(new View(eye, [Math.cos(angle), 0, Math.sin(angle)], [0, 1, 0], 75, 16 / 9, 0.05));
  }
}
const doors = new Doors(level);
const trace = new Trace();
const traceTimes = [];
const listTimes = [];
let entered = 0;
let visible = 0;
for (let r = 0; r < rounds + 2; r++) {
  for (const view of views) {
    const t0 = process.hrtime.bigint();
    level.trace(view, doors, undefined, trace);
    const t1 = process.hrtime.bigint();
    const cells = [];
    for (const v of trace.visible) if (v.transform === null && v.cell !== null) cells.push(v.cell);
    level.drawList(cells);
    const t2 = process.hrtime.bigint();
    if (r >= 2) {
      // The first two rounds warm the JIT up.
      traceTimes.push(Number(t1 - t0) / 1000);
      listTimes.push(Number(t2 - t1) / 1000);
      entered += trace.stats.entered;
      visible += trace.visible.length;
    }
  }
}
const summary = (xs) => {
  const s = [...xs].sort((a, b) => a - b);
  const median = s.length % 2 ? s[(s.length - 1) / 2] : (s[s.length / 2 - 1] + s[s.length / 2]) / 2;
  return { median, mean: s.reduce((a, b) => a + b, 0) / s.length, max: s[s.length - 1] };
};
const f = (x) => (x >= 1000 ? `${(x / 1000).toFixed(2)} ms` : `${x.toFixed(1)} µs`);
const tr = summary(traceTimes);
const dl = summary(listTimes);
const n = traceTimes.length;
console.log(`${files[0]}: ${level.cellCount} cells, ${level.portalCount} portals; ${views.length} cameras x ${rounds} rounds (node ${process.version})`);
console.log(`trace:     median ${f(tr.median)}, mean ${f(tr.mean)}, slowest ${f(tr.max)} (${(entered / n).toFixed(1)} entries, ${(visible / n).toFixed(1)} visible per trace)`);
console.log(`draw list: median ${f(dl.median)}, mean ${f(dl.mean)}, slowest ${f(dl.max)}`);

// The plugin's update, per frame.
let gltf = null;
try {
  const b = readFileSync(files[0]);
  const loader = new GLTFLoader().register((parser) => new PortcullisLoaderPlugin(parser));
  gltf = await loader.parseAsync(b.buffer.slice(b.byteOffset, b.byteOffset + b.byteLength), '');
} catch (e) {
  console.log(`update(camera): not measured, GLTFLoader cannot load the level in Node (${e.message})`);
}
if (gltf !== null) {
  const p = gltf.userData.portcullis;
  const cams = views.map((v) => {
    const cam = new PerspectiveCamera((Math.atan(v.tanY) * 360) / Math.PI, v.tanX / v.tanY, v.near, 1000);
    cam.position.set(...v.eye);
    cam.up.set(...v.up);
    cam.lookAt(new Vector3(v.eye[0] + v.forward[0], v.eye[1] + v.forward[1], v.eye[2] + v.forward[2]));
    cam.updateMatrixWorld();
    return cam;
  });
  const times = [];
  for (let r = 0; r < rounds + 2; r++) {
    for (const cam of cams) {
      const t0 = process.hrtime.bigint();
      p.update(cam);
      const t1 = process.hrtime.bigint();
      if (r >= 2) times.push(Number(t1 - t0) / 1000);
    }
  }
  const u = summary(times);
  console.log(`update(camera): median ${f(u.median)}, mean ${f(u.mean)}, slowest ${f(u.max)} (${p.wholeObjects.length} whole-node meshes, ${p.splitObjects.length} split primitives)`);
}
