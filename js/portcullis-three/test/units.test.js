// Small checks that need no portcullis binary: number formatting and rounding as serde_json and
// Rust do them, the PVS encodings, draw-list joining, and a hand-made level's trace.

import assert from 'node:assert/strict';
import { test } from 'node:test';

import { f64 } from '../cli.js';
import { Doors, Level, Trace, View, decodeVisibility, report, round9, roundHalfAway, zeroRunDecode } from '../runtime.js';

test('numbers print as serde_json prints an f64', () => {
  const cases = [[1, '1.0'], [-1, '-1.0'], [8, '8.0'], [0, '0.0'], [0.5, '0.5'], [7.879e-6, '7.879e-6'], [1e-5, '0.00001'], [-6.183e-6, '-6.183e-6'], [0.186721134, '0.186721134'], [1e-9, '1e-9'], [1e16, '1e16'], [1.5e16, '1.5e16'], [123456789.5, '123456789.5']];
  for (const [x, s] of cases) assert.equal(f64(x), s, String(x));
});

test('rounding as Rust rounds: halves away from zero, no negative zero', () => {
  assert.equal(roundHalfAway(2.5), 3);
  assert.equal(roundHalfAway(-2.5), -3);
  assert.equal(roundHalfAway(-0.4), -0);
  assert.ok(Object.is(round9(-1e-12), 0));
  assert.equal(round9(0.1234567895), 0.12345679);
  assert.equal(round9(-0.1234567885), -0.123456789);
});

test('the PVS encodings decode', () => {
  // Quake's zero runs: 600 zeros are [0, 255, 0, 255, 0, 90].
  assert.deepEqual([...zeroRunDecode(new Uint8Array([0, 255, 0, 255, 0, 90]), 600)], new Array(600).fill(0));
  assert.equal(zeroRunDecode(new Uint8Array([0]), 1), null, 'cut short');
  assert.equal(zeroRunDecode(new Uint8Array([0, 0]), 1), null, 'a zero count');
  const lists = decodeVisibility({ encoding: 'lists', lists: [[0, 1], [1], [0, 2]] }, 3, null);
  assert.deepEqual([lists.visible(0), lists.visible(1), lists.visible(2)], [[0, 1], [1], [0, 2]]);
  const bits = decodeVisibility({ encoding: 'bits', rowBytes: 2, bufferView: 0 }, 9, new Uint8Array([3, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 1]));
  assert.deepEqual(bits.visible(0), [0, 1, 8]);
  assert.deepEqual(bits.visible(8), [8]);
  const zr = decodeVisibility({ encoding: 'bitsZeroRun', rowBytes: 1, bufferView: 0 }, 3, new Uint8Array([5, 0, 1, 4]));
  assert.deepEqual([zr.visible(0), zr.visible(1), zr.visible(2)], [[0, 2], [], [2]]);
  assert.throws(() => decodeVisibility({ encoding: 'bits', rowBytes: 1 }, 3, new Uint8Array([1])), /fewer rows/);
  assert.throws(() => decodeVisibility({ encoding: 'zip' }, 3, null), /unknown encoding/);
});

/** Two 4 m rooms side by side (x 0..4 and 4..8), a doorway between them, one split floor. */
function twoRooms() {
  const box = (room, x0, x1, nodes, draws) => ({
    room,
    planes: [[-1, 0, 0, -x0], [1, 0, 0, x1], [0, -1, 0, 0], [0, 1, 0, 3], [0, 0, -1, 0], [0, 0, 1, 4]],
    bounds: { min: [x0, 0, 0], max: [x1, 3, 4] },
    nodes,
    draws,
  });
  return {
    version: 1,
    generator: 'test',
    inputHash: 'xxh3v2:0000000000000000',
    tolerance: 1e-5,
    cells: [box('a', 0, 4, [1, 2, 9], [[0, 0, 6], [0, 6, 6], [1, 0, 3]]), box('b', 4, 8, [3, 9], [[0, 9, 6], [1, 3, 6]])],
    portals: [
      { polygon: [[4, 0, 1.5], [4, 0, 2.5], [4, 2, 2.5], [4, 2, 1.5]], cells: [0, 1], partner: 1 },
      { polygon: [[4, 2, 1.5], [4, 2, 2.5], [4, 0, 2.5], [4, 0, 1.5]], cells: [1, 0], partner: 0 },
    ],
    split: { indices: 7, primitives: [{ node: 9, primitive: 0, first: 0, count: 18 }, { node: 9, primitive: 1, first: 0, count: 9 }] },
    visibility: { method: 'full', encoding: 'lists', lists: [[0, 1], [0, 1]] },
  };
}

test('draw lists join ranges that overlap or meet, per split primitive', () => {
  const level = Level.fromAnnotation(twoRooms(), decodeVisibility(twoRooms().visibility, 2, null));
  assert.deepEqual(level.drawList([0]), {
    nodes: [1, 2],
    ranges: [{ node: 9, primitive: 0, first: 0, count: 12 }, { node: 9, primitive: 1, first: 0, count: 3 }],
  });
  assert.deepEqual(level.drawList([1, 0, 7]), {
    nodes: [1, 2, 3],
    ranges: [{ node: 9, primitive: 0, first: 0, count: 15 }, { node: 9, primitive: 1, first: 0, count: 9 }],
  });
  assert.deepEqual(level.drawList([]), { nodes: [], ranges: [] });
});

test('a hand-made level: locate, trace through the doorway, doors', () => {
  const a = twoRooms();
  const level = Level.fromAnnotation(a, decodeVisibility(a.visibility, 2, null));
  assert.deepEqual(level.locate([1, 1, 1]), { kind: 'inside', cell: 0 });
  assert.deepEqual(level.locate([4, 1, 2]), { kind: 'boundary', cell: 0 });
  assert.deepEqual(level.locate([4, 1, 2], 1), { kind: 'boundary', cell: 1 });
  assert.deepEqual(level.locate([9, 1, 2]), { kind: 'outside', cell: null, nearest: 1 });
  const trace = new Trace();
  const view = new View([1, 1.5, 2], [1, 0, 0], [0, 1, 0], 60, 16 / 9, 0.05);
  const doors = new Doors(level);
  level.trace(view, doors, undefined, trace);
  const r = report(trace);
  assert.deepEqual(r.visible.map((v) => [v.cell, v.depth, v.via]), [[0, 0, []], [1, 1, [0]]]);
  const [x0, y0, x1, y1] = r.visible[1].rect;
  // The doorway seen from 3 m: x within ±0.5 / (3 tan 30° · 16/9), y from -1.5 to 0.5 over 3 tan 30°.
  const tx = Math.tan(Math.PI / 6) * (16 / 9);
  const ty = Math.tan(Math.PI / 6);
  assert.ok(Math.abs(x1 - 0.5 / (3 * tx)) < 1e-9 && Math.abs(x0 + 0.5 / (3 * tx)) < 1e-9);
  assert.ok(Math.abs(y0 + 1.5 / (3 * ty)) < 1e-9 && Math.abs(y1 - 0.5 / (3 * ty)) < 1e-9);
  doors.set(level, 1, true); // the partner closes the door both ways
  level.trace(view, doors, undefined, trace);
  assert.deepEqual(trace.visible.map((v) => v.cell), [0]);
  assert.equal(trace.stats.closed_skipped, 1);
  assert.throws(() => new View([0, 0, 0], [0, 1, 0], [0, 1, 0]), /up has no direction/);
});
