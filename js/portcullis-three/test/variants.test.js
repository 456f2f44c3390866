// The rules and file layouts no shipped sample exercises, on converted levels edited by hand and
// compared with `portcullis cull` the same way: the PVS as `bits` in an external .bin file and as
// `bitsZeroRun` in a data: URI, a .gltf written by `convert` itself, doors authored closed (and
// --open), one-way portals inside the level and to the outside, nested cells with room
// priorities, a level without a stored PVS, and the depth and transform limits.

import assert from 'node:assert/strict';
import { existsSync, readFileSync, writeFileSync } from 'node:fs';
import { join } from 'node:path';
import { test } from 'node:test';

import { loadLevel } from '../cli.js';
import { Level } from '../runtime.js';
import { cameras, camerasText } from './cameras.js';
import { MAP01, SAMPLES, binary, compare, convert, jsCull, readGlb, rustCull, tempDir, writeGlb } from './helpers.js';

const bin = binary();
const skip = bin ? false : 'no portcullis binary (build it with cargo build --release, or set PORTCULLIS)';
const dir = bin ? tempDir() : null;
const totals = { levels: 0, cameras: 0 };

/** Compares both culls on `file` for each run of extra arguments. */
function agree(t, file, runs = [[]], { random = 200, seed = 3 } = {}) {
  const level = loadLevel(file);
  const camFile = `${file}.cameras.jsonl`;
  const list = cameras(level, { seed, random });
  writeFileSync(camFile, camerasText(list));
  const answers = [];
  for (const args of runs) {
    const rust = rustCull(file, camFile, args);
    const r = compare(rust, jsCull(file, camFile, args));
    assert.deepEqual(r.problems.slice(0, 5), [], `${file} ${args.join(' ')}: ${r.problems.length} of ${r.cameras} differ`);
    totals.cameras += r.cameras;
    answers.push(rust.map((l) => JSON.parse(l)));
  }
  totals.levels++;
  t.diagnostic(`${file.split('/').pop()}: ${list.length} cameras x ${runs.length} run(s)`);
  return { level, answers };
}

/** How many answers of a run have stats field `k` above zero. */
const hits = (answers, k) => answers.filter((a) => a.stats[k] > 0).length;

/** A sample (or MAP01) converted to .glb in the temp folder, or null when it does not convert. */
function converted(name) {
  const out = join(dir, `${name}.glb`);
  if (existsSync(out)) return out;
  const src = name === 'MAP01' ? MAP01 : join(SAMPLES, `${name}.gltf`);
  if (!existsSync(src)) return null;
  return convert(src, out, name === 'MAP01' ? ['--tags', 'doom'] : []) ? out : null;
}

/** The rows of a level's stored PVS, as `bits` lays them out. */
function pvsRows(file) {
  const level = loadLevel(file);
  assert.ok(level.pvs !== null, `${file} stores a PVS`);
  return { rows: Buffer.from(level.pvs.bits), rowBytes: level.pvs.rowBytes };
}

function zeroRun(bytes) {
  const out = [];
  let i = 0;
  while (i < bytes.length) {
    if (bytes[i] !== 0) {
      out.push(bytes[i++]);
      continue;
    }
    let run = 0;
    while (i < bytes.length && bytes[i] === 0 && run < 255) {
      run++;
      i++;
    }
    out.push(0, run);
  }
  return Buffer.from(out);
}

const pvsLevels = ['pillar_room', 'MAP01'];

for (const name of pvsLevels) {
  test(`the PVS as bits in an external .bin, ${name}`, { skip: skip || (name === 'MAP01' && !existsSync(MAP01) ? `${MAP01} is not there: skipped` : false) }, (t) => {
    const glb = converted(name);
    assert.ok(glb, `${name} converts`);
    const { json, bin: chunk } = readGlb(glb);
    const { rows, rowBytes } = pvsRows(glb);
    const ext = json.extensions.PORTCULLIS_portals;
    json.buffers[0] = { ...json.buffers[0], uri: `${name} level.bin` };
    json.buffers.push({ uri: `${name}.pvs.bin`, byteLength: rows.length + 4 });
    json.bufferViews.push({ buffer: json.buffers.length - 1, byteOffset: 4, byteLength: rows.length });
    ext.visibility = { ...ext.visibility, encoding: 'bits', rowBytes, bufferView: json.bufferViews.length - 1 };
    delete ext.visibility.lists;
    writeFileSync(join(dir, `${name} level.bin`), chunk);
    writeFileSync(join(dir, `${name}.pvs.bin`), Buffer.concat([Buffer.from([9, 9, 9, 9]), rows]));
    const file = join(dir, `${name}.bits.gltf`);
    writeFileSync(file, JSON.stringify(json));
    agree(t, file);
  });

  test(`the PVS zero-run compressed in a data: URI, ${name}`, { skip: skip || (name === 'MAP01' && !existsSync(MAP01) ? `${MAP01} is not there: skipped` : false) }, (t) => {
    const glb = converted(name);
    const { json, bin: chunk } = readGlb(glb);
    const { rows, rowBytes } = pvsRows(glb);
    const ext = json.extensions.PORTCULLIS_portals;
    const zr = zeroRun(rows);
    json.buffers[0] = { ...json.buffers[0], uri: `data:application/octet-stream;base64,${chunk.toString('base64')}` };
    json.buffers.push({ uri: `data:application/octet-stream;base64,${zr.toString('base64')}`, byteLength: zr.length });
    json.bufferViews.push({ buffer: json.buffers.length - 1, byteLength: zr.length });
    ext.visibility = { ...ext.visibility, encoding: 'bitsZeroRun', rowBytes, bufferView: json.bufferViews.length - 1 };
    delete ext.visibility.lists;
    const file = join(dir, `${name}.zerorun.gltf`);
    writeFileSync(file, JSON.stringify(json));
    agree(t, file);
  });
}

test('a .gltf that convert writes (data: URIs), MAP01 and mirror', { skip }, (t) => {
  for (const [src, extra] of [[MAP01, ['--tags', 'doom']], [join(SAMPLES, 'mirror.gltf'), []]]) {
    if (!existsSync(src)) {
      t.diagnostic(`${src} is not there: skipped`);
      continue;
    }
    const out = join(dir, `${src.split('/').pop().replace(/\.gl(b|tf)$/, '')}.converted.gltf`);
    assert.ok(convert(src, out, extra), `${src} converts to .gltf`);
    agree(t, out, [[]], { random: 100 });
  }
});

/** Edits a converted level: closes its first door, makes its second opening one-way (the
 * partner removed), and every other exterior opening one-way. Returns the closed portal. */
function withFlags(json) {
  const ext = json.extensions.PORTCULLIS_portals;
  const portals = ext.portals;
  const pairs = [];
  for (const [i, p] of portals.entries()) if (Number.isInteger(p.partner) && p.partner > i && p.cells.length === 2) pairs.push(i);
  let closed = null;
  if (pairs.length > 0) {
    closed = pairs[0];
    portals[closed].closed = true;
    portals[portals[closed].partner].closed = true;
  }
  if (pairs.length > 1) {
    const p = pairs[1];
    const q = portals[p].partner;
    const index = (i) => (i > q ? i - 1 : i);
    delete portals[p].partner;
    portals[p].oneWay = true;
    portals.splice(q, 1);
    for (const r of portals) if (Number.isInteger(r.partner)) r.partner = index(r.partner);
    if (closed !== null) closed = index(closed);
  }
  let k = 0;
  for (const p of portals) if (p.cells.length === 1 && k++ % 2 === 0) p.oneWay = true;
  return closed;
}

for (const name of ['u_room', 'stair_hall', 'courtyard', 'offset_holes', 'block_slot_leak', 'teleporter', 'MAP01']) {
  test(`doors authored closed and one-way portals, ${name}`, { skip: skip || (name === 'MAP01' && !existsSync(MAP01) ? `${MAP01} is not there: skipped` : false) }, (t) => {
    const glb = converted(name);
    assert.ok(glb, `${name} converts`);
    const { json, bin: chunk } = readGlb(glb);
    const closed = withFlags(json);
    const file = join(dir, `${name}.flags.glb`);
    writeGlb(file, json, chunk);
    const level = Level.fromBytes(readFileSync(file));
    const runs = [[]];
    if (closed !== null) runs.push(['--open', String(closed)]);
    const other = level.portalCount > 0 ? level.portalCount - 1 : null;
    if (other !== null && other !== closed && level.partner(other) !== closed) runs.push(['--closed', String(other)]);
    const { answers } = agree(t, file, runs, { random: name === 'MAP01' ? 600 : 200 });
    if (closed !== null) {
      assert.ok(hits(answers[0], 'closed_skipped') > 0, 'the closed door stops some views');
      assert.equal(hits(answers[1], 'closed_skipped'), 0, '--open opens it');
    }
  });
}

test('nested cells with room priorities (and a portal out of one)', { skip }, (t) => {
  const glb = converted('two_rooms');
  const { json, bin: chunk } = readGlb(glb);
  const ext = json.extensions.PORTCULLIS_portals;
  const box = (room, [x0, y0, z0], [x1, y1, z1], priority) => {
    const c = {
      room,
      planes: [[-1, 0, 0, -x0], [1, 0, 0, x1], [0, -1, 0, -y0], [0, 1, 0, y1], [0, 0, -1, -z0], [0, 0, 1, z1]],
      bounds: { min: [x0, y0, z0], max: [x1, y1, z1] },
    };
    if (priority !== 0) c.priority = priority;
    return c;
  };
  const first = ext.cells.length;
  ext.cells.push(
    box('pantry', [1, 0, 1], [3, 2, 3], 0), // inside the kitchen, smaller: wins there
    box('hall', [3, 0, 0], [5, 3, 4], 1), // across the doorway, the highest priority
    box('vault', [1.5, 0.5, 1.5], [2.5, 1.5, 2.5], -1), // inside the pantry, lower priority
    box('twin', [1, 0, 1], [3, 2, 3], 0), // the pantry again: ties go to the lower index
  );
  ext.portals.push({ polygon: [[3, 0.5, 1.5], [3, 0.5, 2.5], [3, 1.5, 2.5], [3, 1.5, 1.5]], cells: [first, 0] });
  const n = ext.cells.length;
  if (ext.visibility && ext.visibility.lists) {
    for (let c = first; c < n; c++) ext.visibility.lists.push(c === first ? [0, 1, c] : [c]);
  }
  const file = join(dir, 'two_rooms.nested.glb');
  writeGlb(file, json, chunk);
  const { level, answers } = agree(t, file, [[], ['--no-pvs']], { random: 400 });
  assert.ok([...level.overlapped].some((f) => f === 1), 'some cells overlap');
  const inside = new Set(answers[0].filter((a) => a.location === 'inside').map((a) => a.cell));
  assert.ok(inside.has(first) && inside.has(first + 1), 'the pantry (smaller) and the hall (priority 1) hold points');
  assert.ok(!inside.has(first + 2) && !inside.has(first + 3), 'the vault (priority -1) and the twin (a higher index) never do');
});

test('no stored PVS, and the depth and transform limits', { skip }, (t) => {
  const name = existsSync(MAP01) ? 'MAP01' : 'pillar_room';
  const glb = converted(name);
  const { json, bin: chunk } = readGlb(glb);
  delete json.extensions.PORTCULLIS_portals.visibility;
  const file = join(dir, `${name}.nopvs.glb`);
  writeGlb(file, json, chunk);
  const { answers } = agree(t, file, [[], ['--max-depth', '1']], { random: 300 });
  assert.equal(hits(answers[0], 'pvs_skipped'), 0, 'nothing to prefilter with');
  assert.ok(hits(answers[1], 'depth_limit_hits') > 0, 'the depth limit is reached');
  for (const s of ['mirror', 'teleporter']) {
    const r = agree(t, converted(s), [['--transform-depth', '0'], ['--transform-depth', '1'], ['--transform-depth', '6'], ['--max-depth', '2', '--transform-depth', '6']], { random: 200 });
    assert.ok(hits(r.answers[0], 'transform_limit_hits') > 0, `${s}: the transform limit is reached`);
  }
});

test('variants summary', { skip }, (t) => {
  t.diagnostic(`compared ${totals.cameras} camera answers on ${totals.levels} edited levels`);
  assert.ok(totals.levels > 0);
});
