// cli.js against `portcullis cull --format jsonl` on every sample that converts and, when
// ../shared has them, on Freedoom's maps (doom preset) and the shared brush maps: the same answer per camera, field for field, the
// rectangles and transforms within 1e-9 (they come out byte-identical in practice).

import assert from 'node:assert/strict';
import { readdirSync, writeFileSync, existsSync } from 'node:fs';
import { basename, dirname, join } from 'node:path';
import { spawnSync } from 'node:child_process';
import { test } from 'node:test';

import { loadLevel } from '../cli.js';
import { cameras, camerasText } from './cameras.js';
import { MAP01, SAMPLES, binary, compare, convert, jsCull, rustCull, tempDir } from './helpers.js';

const bin = binary();
// `portcullis cull --draw-lists` (what each view draws) where the binary has it.
const drawLists = bin !== null && spawnSync(bin, ['cull', '--help'], { encoding: 'utf8' }).stdout.includes('--draw-lists');
const dir = bin ? tempDir() : null;
const totals = { levels: 0, runs: 0, cameras: 0, identical: 0, skipped: [] };

/** Converts, makes cameras, runs both with each of `runs` (extra arguments), and compares. */
function check(t, source, name, { extra = [], random = 240, seed = 1, runs = [[]] } = {}) {
  const out = join(dir, `${name}.glb`);
  if (!convert(source, out, extra)) {
    totals.skipped.push(name);
    t.skip(`${name} does not convert`);
    return;
  }
  const level = loadLevel(out);
  const camFile = join(dir, `${name}.cameras.jsonl`);
  const list = cameras(level, { seed, random });
  writeFileSync(camFile, camerasText(list));
  const all = drawLists ? [...runs, ['--draw-lists', '--stats']] : runs;
  for (const args of all) {
    const r = compare(rustCull(out, camFile, args), jsCull(out, camFile, args));
    totals.runs++;
    totals.cameras += r.cameras;
    totals.identical += r.identical;
    assert.deepEqual(r.problems.slice(0, 5), [], `${name} ${args.join(' ')}: ${r.problems.length} of ${r.cameras} cameras differ`);
    assert.ok(r.cameras >= list.length, 'every camera answered');
  }
  totals.levels++;
  t.diagnostic(`${name}: ${level.cellCount} cells, ${level.portalCount} portals, ${list.length} cameras x ${all.length} run(s)`);
}

/** The door runs of a level: each opening closed in turn (one side of it), then all of them. */
function doorRuns(level) {
  const flagged = [];
  const all = [];
  for (let p = 0; p < level.portalCount; p++) {
    const q = level.partner(p);
    if (q !== null && q < p) continue;
    all.push(p);
    if (level.annotation.portals[p].door) flagged.push(p);
  }
  const doors = flagged.length > 0 ? flagged : all;
  const runs = [[]];
  for (const p of doors) runs.push(['--closed', String(p)]);
  if (doors.length > 1) runs.push(doors.flatMap((p) => ['--closed', String(p)]));
  return runs;
}

const samples = existsSync(SAMPLES) ? readdirSync(SAMPLES).filter((f) => f.endsWith('.gltf')).sort() : [];

test('the portcullis binary is there', (t) => {
  if (bin === null) {
    const why = 'no portcullis binary in target/release or target/debug (cargo build --release, or set PORTCULLIS)';
    // Under CI a missing binary is a failure, elsewhere the comparisons are skipped.
    if (process.env.CI === 'true') assert.fail(why);
    t.skip(why);
    return;
  }
  t.diagnostic(`comparing with ${bin}`);
  assert.ok(samples.length > 0, 'samples/*.gltf');
});

for (const f of samples) {
  const name = basename(f, '.gltf');
  test(`cull agrees on ${f}`, { skip: bin ? false : 'no portcullis binary' }, (t) => {
    let runs = [[], ['--stats']];
    if (name === 'mirror' || name === 'teleporter') runs.push(['--transform-depth', '4']);
    if (name === 'door_window') {
      const probe = join(dir, 'door_window.probe.glb');
      assert.ok(convert(join(SAMPLES, f), probe), 'door_window converts');
      runs = [...doorRuns(loadLevel(probe)), ['--stats', '--closed', '0']];
      assert.ok(runs.length > 1, 'door_window has openings to close');
    }
    check(t, join(SAMPLES, f), name, { runs, seed: name.length * 7919 });
  });
}

test('cull agrees on Freedoom MAP01 (--tags doom)', { skip: !bin ? 'no portcullis binary' : existsSync(MAP01) ? false : `${MAP01} is not there: skipped` }, (t) => {
  check(t, MAP01, 'freedoom2_MAP01', { extra: ['--tags', 'doom'], random: 1500, seed: 2024, runs: [[], ['--stats'], ['--no-pvs'], ['--max-depth', '3']] });
});

// The other shared levels: Freedoom maps with the doom preset and the brush maps as `.map`,
// 500 random cameras each besides the cell centres (among them cameras with a 1 m near plane,
// which in a brush map's small cells reach many portals at once).
const SHARED = [
  ['freedoom/freedoom1_E1M2.glb', ['--tags', 'doom']],
  ['freedoom/freedoom1_E3M3.glb', ['--tags', 'doom']],
  ['ericw-tools/testmaps/E1M1-edited-ents.map', []],
  ['ericw-tools/testmaps/LibreQuake/lq1/maps/src/e3/e3m4.map', []],
  ['ericw-tools/testmaps/retrojam1_ericw.map', []],
];
for (const [rel, extra] of SHARED) {
  const source = join(dirname(MAP01), '..', rel);
  const name = basename(rel).replace(/\.[^.]+$/, '');
  const skip = !bin ? 'no portcullis binary' : existsSync(source) ? false : `${source} is not there: skipped`;
  test(`cull agrees on ${rel}`, { skip }, (t) => {
    check(t, source, name, { extra, random: 500, seed: name.length * 104729 });
  });
}

test('summary', { skip: bin ? false : 'no portcullis binary' }, (t) => {
  t.diagnostic(`compared ${totals.cameras} camera answers (${totals.runs} runs) on ${totals.levels} levels: all equal, ${totals.identical} byte-identical`);
  t.diagnostic(drawLists ? 'draw lists compared with portcullis cull --draw-lists' : 'this portcullis has no cull --draw-lists: draw lists compared through --stats (triangles and calls)');
  if (totals.skipped.length > 0) t.diagnostic(`did not convert: ${totals.skipped.join(', ')}`);
  assert.ok(totals.levels > 0);
});
