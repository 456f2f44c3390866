// Shared by the tests: where the release binary and the levels are, converting, running both
// `cull`s, comparing their answers, and reading and writing .glb files.

import { spawnSync } from 'node:child_process';
import { copyFileSync, existsSync, mkdirSync, mkdtempSync, readFileSync, renameSync, rmSync, statSync, writeFileSync } from 'node:fs';
import { tmpdir } from 'node:os';
import { basename, dirname, join, resolve } from 'node:path';
import { fileURLToPath } from 'node:url';

export const PACKAGE = resolve(dirname(fileURLToPath(import.meta.url)), '..');
export const REPO = resolve(PACKAGE, '../..');
export const SAMPLES = join(REPO, 'samples');
export const MAP01 = resolve(REPO, '../shared/levels/freedoom/freedoom2_MAP01.glb');
export const CLI = join(PACKAGE, 'cli.js');

/**
 * The portcullis binary: $PORTCULLIS, else the newer of the repository's release and debug
 * builds (`cargo test` builds the debug one, so a fresh clone's test run has it), else null.
 */
export function binary() {
  if (process.env.PORTCULLIS) return existsSync(process.env.PORTCULLIS) ? process.env.PORTCULLIS : null;
  const builds = ['release', 'debug'].map((b) => join(REPO, 'target', b, 'portcullis')).filter((p) => existsSync(p));
  builds.sort((a, b) => statSync(b).mtimeMs - statSync(a).mtimeMs);
  return builds.length > 0 ? builds[0] : null;
}

/** A temporary folder, removed when the process exits. */
export function tempDir(prefix = 'portcullis-three-') {
  const d = mkdtempSync(join(tmpdir(), prefix));
  process.on('exit', () => rmSync(d, { recursive: true, force: true }));
  return d;
}

/**
 * Converts `input` to `output` with the binary; returns whether it succeeded. With
 * $PORTCULLIS_LEVEL_CACHE (scripts/test.sh sets it, fresh each run), a level converted once
 * with the same arguments is copied from there: the Bevy plugin's tests convert the same ones.
 */
export function convert(input, output, extra = []) {
  const cache = process.env.PORTCULLIS_LEVEL_CACHE;
  const kept = cache ? join(cache, [basename(input), ...extra].join('_').replace(/[^A-Za-z0-9_.]/g, '') + '.glb') : null;
  if (kept && existsSync(kept)) {
    copyFileSync(kept, output);
    return true;
  }
  const r = spawnSync(binary(), ['convert', input, '-o', output, '--color', 'never', ...extra], { encoding: 'utf8' });
  const ok = r.status === 0 && existsSync(output);
  if (ok && kept) {
    mkdirSync(cache, { recursive: true });
    copyFileSync(output, kept + '.part');
    renameSync(kept + '.part', kept);
  }
  return ok;
}

function run(cmd, args) {
  const r = spawnSync(cmd, args, { encoding: 'utf8', maxBuffer: 1 << 30 });
  if (r.status !== 0) throw new Error(`${cmd} ${args.join(' ')} exited ${r.status}: ${r.stderr}`);
  return r.stdout.split('\n').filter((l) => l !== '');
}

/** `portcullis cull LEVEL --cameras FILE --format jsonl ...extra`, one string per camera. */
export function rustCull(level, cameras, extra = []) {
  return run(binary(), ['cull', level, '--cameras', cameras, '--format', 'jsonl', ...extra]);
}

/** `node cli.js cull LEVEL --cameras FILE ...extra`, one string per camera. */
export function jsCull(level, cameras, extra = []) {
  return run(process.execPath, [CLI, 'cull', level, '--cameras', cameras, ...extra]);
}

/** The first place where two parsed answers differ (numbers within `eps`), or null. */
export function difference(a, b, eps = 1e-9, path = '') {
  if (typeof a === 'number' && typeof b === 'number') return Math.abs(a - b) <= eps ? null : `${path}: ${a} vs ${b}`;
  if (Array.isArray(a) && Array.isArray(b)) {
    if (a.length !== b.length) return `${path}: ${a.length} vs ${b.length} entries`;
    for (let i = 0; i < a.length; i++) {
      const d = difference(a[i], b[i], eps, `${path}[${i}]`);
      if (d !== null) return d;
    }
    return null;
  }
  if (a !== null && b !== null && typeof a === 'object' && typeof b === 'object') {
    const ka = Object.keys(a);
    const kb = Object.keys(b);
    if (ka.join() !== kb.join()) return `${path}: fields ${ka} vs ${kb}`;
    for (const k of ka) {
      const d = difference(a[k], b[k], eps, `${path}.${k}`);
      if (d !== null) return d;
    }
    return null;
  }
  return a === b ? null : `${path}: ${JSON.stringify(a)} vs ${JSON.stringify(b)}`;
}

/** Compares both answers line by line: `{cameras, identical, problems}`. */
export function compare(rust, js) {
  const problems = [];
  if (rust.length !== js.length) problems.push(`${rust.length} answers from portcullis, ${js.length} from cli.js`);
  let identical = 0;
  for (let i = 0; i < Math.min(rust.length, js.length); i++) {
    if (rust[i] === js[i]) {
      identical++;
      continue;
    }
    const d = difference(JSON.parse(rust[i]), JSON.parse(js[i]));
    if (d !== null) problems.push(`camera ${i + 1}${d}`);
  }
  return { cameras: rust.length, identical, problems };
}

/** The JSON and BIN chunk of a .glb file. */
export function readGlb(file) {
  const b = readFileSync(file);
  const jsonLen = b.readUInt32LE(12);
  const json = JSON.parse(b.subarray(20, 20 + jsonLen).toString('utf8'));
  const at = 20 + jsonLen;
  const bin = at + 8 <= b.length ? b.subarray(at + 8, at + 8 + b.readUInt32LE(at)) : null;
  return { json, bin };
}

/** Writes a .glb of `json` and `bin`. */
export function writeGlb(file, json, bin) {
  let text = Buffer.from(JSON.stringify(json), 'utf8');
  const pad = (n) => (4 - (n % 4)) % 4;
  text = Buffer.concat([text, Buffer.alloc(pad(text.length), 0x20)]);
  const parts = [Buffer.alloc(12), Buffer.alloc(8), text];
  parts[1].writeUInt32LE(text.length, 0);
  parts[1].write('JSON', 4, 'latin1');
  if (bin) {
    const body = Buffer.concat([bin, Buffer.alloc(pad(bin.length))]);
    const h = Buffer.alloc(8);
    h.writeUInt32LE(body.length, 0);
    h.write('BIN\0', 4, 'latin1');
    parts.push(h, body);
  }
  const all = Buffer.concat(parts);
  all.write('glTF', 0, 'latin1');
  all.writeUInt32LE(2, 4);
  all.writeUInt32LE(all.length, 8);
  writeFileSync(file, all);
}
