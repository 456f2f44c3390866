#!/usr/bin/env node
// `node cli.js cull LEVEL --cameras FILE [--closed N]... [--open N]...`: what each camera sees,
// by the JavaScript runtime, printed as `portcullis cull LEVEL --cameras FILE --format jsonl`
// prints it (one JSON object per camera and line, the same fields in the same order).

import { readFileSync, realpathSync, statSync } from 'node:fs';
import { dirname, join } from 'node:path';
import { fileURLToPath } from 'node:url';

import { cellCost, cost, Meshes } from './cost.js';
import { DEFAULT_OPTIONS, Doors, Level, Trace, View, parseGltfBytes, report } from './runtime.js';

const USAGE = `usage: node cli.js cull LEVEL --cameras FILE [--closed PORTAL]... [--open PORTAL]...
       [--format jsonl|json] [--max-depth N] [--transform-depth N] [--no-pvs] [--stats]
       [--draw-lists] [--no-stats]

LEVEL is a .glb or .gltf written by \`portcullis convert\` (data: URIs and .bin files beside it are
read). FILE holds one camera per line: {"eye":[x,y,z], "look":[x,y,z], "up":[x,y,z], "fov_y":deg,
"aspect":w/h, "near":m}; up defaults to [0,1,0], fov_y to 60, aspect to 16/9, near to 0.05.
--stats adds what each view submits (as portcullis cull --stats); --draw-lists what each view
draws ("draw": {"nodes", "ranges": [[node, primitive, first, count]]}, on the answer for the cells
seen directly and on each entry seen through a mirror or teleporter); --no-stats leaves out the
trace's "stats" object.`;

class Usage extends Error {}

/** The command line, parsed. */
export function parseArgs(argv) {
  const a = { level: null, cameras: null, closed: [], open: [], format: 'jsonl', maxDepth: DEFAULT_OPTIONS.maxDepth, transformDepth: DEFAULT_OPTIONS.maxTransformDepth, usePvs: true, stats: true, submitted: false, drawLists: false };
  if (argv[0] !== 'cull') throw new Usage(argv.length === 0 ? 'no command given' : `unknown command \`${argv[0]}\``);
  const index = (flag, v) => {
    if (v === undefined || !/^\d+$/.test(v)) throw new Usage(`${flag} takes a non-negative integer, not \`${v ?? ''}\``);
    return Number(v);
  };
  for (let i = 1; i < argv.length; i++) {
    let arg = argv[i];
    let value;
    const eq = arg.indexOf('=');
    if (arg.startsWith('--') && eq > 0) {
      value = arg.slice(eq + 1);
      arg = arg.slice(0, eq);
    }
    const next = () => (value !== undefined ? value : argv[++i]);
    switch (arg) {
      case '--cameras': a.cameras = next(); break;
      case '--closed': a.closed.push(index('--closed', next())); break;
      case '--open': a.open.push(index('--open', next())); break;
      case '--max-depth': a.maxDepth = index('--max-depth', next()); break;
      case '--transform-depth': a.transformDepth = index('--transform-depth', next()); break;
      case '--no-pvs': a.usePvs = false; break;
      case '--no-stats': a.stats = false; break;
      case '--stats': a.submitted = true; break;
      case '--draw-lists': a.drawLists = true; break;
      case '--format': {
        a.format = next();
        if (a.format !== 'jsonl' && a.format !== 'json') throw new Usage(`--format is jsonl or json, not \`${a.format}\``);
        break;
      }
      case '-h':
      case '--help': throw new Usage('');
      default:
        if (arg.startsWith('-') && arg !== '-') throw new Usage(`unknown option \`${arg}\``);
        if (a.level !== null) throw new Usage(`unexpected argument \`${arg}\``);
        a.level = arg;
    }
  }
  if (a.level === null) throw new Usage('the level is missing');
  if (a.cameras === null || a.cameras === undefined) throw new Usage('--cameras FILE is missing');
  return a;
}

const CAMERA_FIELDS = new Set(['eye', 'look', 'up', 'fov_y', 'aspect', 'near']);

/** The camera of one line (null for a blank one); throws with what is wrong. */
export function parseCamera(line) {
  if (line.trim() === '') return null;
  let c;
  try {
    c = JSON.parse(line);
  } catch (e) {
    throw new Error(`not a camera: ${e.message}`);
  }
  if (c === null || typeof c !== 'object' || Array.isArray(c)) throw new Error('not a camera: expected a JSON object');
  for (const k of Object.keys(c)) if (!CAMERA_FIELDS.has(k)) throw new Error(`not a camera: unknown field \`${k}\``);
  const vec = (k) => {
    const v = c[k];
    if (!(Array.isArray(v) && v.length === 3 && v.every((x) => typeof x === 'number'))) throw new Error(`not a camera: \`${k}\` is not [x, y, z]`);
    return v;
  };
  const num = (k, d) => {
    if (c[k] === undefined) return d;
    if (typeof c[k] !== 'number') throw new Error(`not a camera: \`${k}\` is not a number`);
    return c[k];
  };
  if (c.eye === undefined) throw new Error('not a camera: missing field `eye`');
  if (c.look === undefined) throw new Error('not a camera: missing field `look`');
  const eye = vec('eye');
  const look = vec('look');
  const up = c.up === undefined ? [0, 1, 0] : vec('up');
  try {
    return new View(eye, look, up, num('fov_y', 60), num('aspect', 16 / 9), num('near', 0.05));
  } catch (e) {
    throw new Error(`not a usable camera: ${e.message}`);
  }
}

/** A number as serde_json writes an f64 (ryu's layout of the shortest digits: `1.0`,
 * `0.00001`, `7.879e-6`, `1e16`). */
export function f64(x) {
  if (!Number.isFinite(x)) return 'null';
  if (x === 0) return Object.is(x, -0) ? '-0.0' : '0.0';
  const sign = x < 0 ? '-' : '';
  const [mant, exp] = Math.abs(x).toExponential().split('e');
  const digits = mant.replace('.', '');
  const length = digits.length;
  const kk = Number(exp) + 1; // 10^(kk-1) <= |x| < 10^kk
  const k = kk - length;
  let s;
  if (k >= 0 && kk <= 16) s = digits + '0'.repeat(k) + '.0';
  else if (kk > 0 && kk <= 16) s = digits.slice(0, kk) + '.' + digits.slice(kk);
  else if (kk > -5 && kk <= 0) s = '0.' + '0'.repeat(-kk) + digits;
  else s = (length === 1 ? digits : digits[0] + '.' + digits.slice(1)) + 'e' + (kk - 1);
  return sign + s;
}

/** A draw list as `--draw-lists` prints it. */
function drawJson(list) {
  return `{"nodes":[${list.nodes.join(',')}],"ranges":[${list.ranges.map((r) => `[${r.node},${r.primitive},${r.first},${r.count}]`).join(',')}]}`;
}

/** One report as `cull --format jsonl` writes it: the same keys in the same order. */
export function formatReport(r, withStats = true) {
  const int = (v) => (v === null ? 'null' : String(v));
  const vis = r.visible.map((v) => {
    let s = `{"cell":${int(v.cell)},"rect":[${v.rect.map(f64).join(',')}],"depth":${v.depth},"via":[${v.via.join(',')}]`;
    if (v.transform !== undefined) s += `,"transform":[${v.transform.map(f64).join(',')}]`;
    s += `,"mirrored":${v.mirrored}`;
    if (v.draw !== undefined) s += `,"draw":${drawJson(v.draw)}`;
    if (v.triangles !== undefined) s += `,"triangles":${v.triangles}`;
    return s + '}';
  });
  let s = `{"cell":${int(r.cell)},"location":"${r.location}"`;
  if (r.location === 'outside') s += `,"nearest":${int(r.nearest)}`;
  s += `,"visible":[${vis.join(',')}]`;
  if (r.draw !== undefined) s += `,"draw":${drawJson(r.draw)}`;
  if (withStats) s += `,"stats":${JSON.stringify(r.stats)}`;
  if (r.submitted !== undefined) s += `,"submitted":${JSON.stringify(r.submitted)}`;
  return s + '}';
}

/** The level at `file`: a .glb, or a .gltf with data: URIs or buffer files beside it. */
export function loadLevel(file) {
  return loadDocument(file).level;
}

/** The level at `file` and its glTF JSON: `{level, json}`. */
export function loadDocument(file) {
  const bytes = readFileSync(file);
  const loadUri = (uri) => {
    const raw = join(dirname(file), uri);
    try {
      return readFileSync(raw);
    } catch (e) {
      let decoded = null;
      try {
        decoded = join(dirname(file), decodeURIComponent(uri));
      } catch {
        // not percent-encoded
      }
      if (decoded !== null && decoded !== raw) return readFileSync(decoded);
      throw new Error(`visibility: the buffer ${raw} cannot be read: ${e.message}`);
    }
  };
  const { json, bin } = parseGltfBytes(bytes);
  return { level: Level.fromGltf(json, { bin, loadUri }), json };
}

/** `--closed` and `--open` that repeat a portal or contradict each other: the message. */
function contradictoryDoors(a, level) {
  const seen = new Map();
  const given = [...a.closed.map((p) => [p, true]), ...a.open.map((p) => [p, false])];
  const flag = (c) => (c ? '--closed' : '--open');
  for (const [p, closed] of given) {
    const q0 = p < level.portalCount ? level.partner(p) : null;
    const door = q0 === null ? p : Math.min(q0, p);
    if (seen.has(door)) {
      const [q, was] = seen.get(door);
      if (q === p && was === closed) return `portal ${p} is given twice (${flag(closed)} ${p})`;
      if (q === p) return `portal ${p} is given with both --closed and --open`;
      return `portals ${q} and ${p} are the two sides of one door (${flag(was)} ${q}, ${flag(closed)} ${p}); give one of them`;
    }
    seen.set(door, [p, closed]);
  }
  return null;
}

/** Runs the command; returns the exit code (0, or 2 for anything wrong before output). */
export function main(argv, out = process.stdout, err = process.stderr) {
  let a;
  try {
    a = parseArgs(argv);
  } catch (e) {
    if (!(e instanceof Usage)) throw e;
    err.write((e.message ? `error: ${e.message}\n\n` : '') + USAGE + '\n');
    return e.message ? 2 : 0;
  }
  let text;
  try {
    text = a.cameras === '-' ? readFileSync(0, 'utf8') : readFileSync(a.cameras, 'utf8');
  } catch (e) {
    err.write(`error: ${a.cameras}: the cameras file cannot be read: ${e.message}\n`);
    return 2;
  }
  const lines = text.split('\n').map((l) => (l.endsWith('\r') ? l.slice(0, -1) : l));
  if (lines.length > 0 && lines[lines.length - 1] === '') lines.pop();
  const views = [];
  for (const [i, line] of lines.entries()) {
    try {
      const v = parseCamera(line);
      if (v !== null) views.push(v);
    } catch (e) {
      err.write(`error: ${a.cameras}:${i + 1}: ${e.message}\n`);
      return 2;
    }
  }
  let level;
  let json;
  try {
    if (statSync(a.level).size === 0) {
      err.write(`error: \`${a.level}\` is empty (0 bytes)\n`);
      return 2;
    }
    ({ level, json } = loadDocument(a.level));
  } catch (e) {
    err.write(`error: the level ${a.level} ${e.message} (run \`portcullis convert\` on the level and load the file it writes)\n`);
    return 2;
  }
  const contradiction = contradictoryDoors(a, level);
  if (contradiction !== null) {
    err.write(`error: ${contradiction}\n`);
    return 2;
  }
  const doors = new Doors(level);
  for (const [p, closed] of [...a.closed.map((p) => [p, true]), ...a.open.map((p) => [p, false])]) {
    if (p >= level.portalCount) {
      err.write(`error: portal ${p} does not exist: the level has ${level.portalCount} portals\n`);
      return 2;
    }
    doors.set(level, p, closed);
  }
  const opts = { maxDepth: a.maxDepth, maxTransformDepth: a.transformDepth, usePvs: a.usePvs };
  const trace = new Trace();
  const meshes = a.submitted ? new Meshes(json) : null;
  const chunks = [];
  if (a.format === 'json') chunks.push('[');
  views.forEach((view, n) => {
    level.trace(view, doors, opts, trace);
    const r = report(trace);
    if (a.drawLists) {
      r.visible.forEach((v, i) => {
        if (trace.visible[i].transform !== null) v.draw = level.drawList(v.cell === null ? [] : [v.cell]);
      });
      r.draw = level.drawList(trace.visible.filter((v) => v.transform === null && v.cell !== null).map((v) => v.cell));
    }
    if (meshes !== null) {
      r.submitted = cost(level, meshes, view, trace);
      for (const v of r.visible) if (v.cell !== null) v.triangles = cellCost(level, meshes, v.cell).triangles;
    }
    const line = formatReport(r, a.stats);
    if (a.format === 'json') chunks.push((n === 0 ? '\n  ' : ',\n  ') + line);
    else chunks.push(line + '\n');
  });
  if (a.format === 'json') chunks.push(views.length === 0 ? ']\n' : '\n]\n');
  out.write(chunks.join(''));
  return 0;
}

if (process.argv[1] && realpathSync(fileURLToPath(import.meta.url)) === realpathSync(process.argv[1])) {
  process.exitCode = main(process.argv.slice(2));
}
