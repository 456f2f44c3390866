// The portcullis runtime in JavaScript: a converted level's cells and portals read from the
// `PORTCULLIS_portals` glTF extension alone, and the frame-time queries an engine runs on them:
// `Level#locate` finds the camera's cell, `Level#trace` walks the portals it can see, and
// `Level#drawList` says what the visible cells draw.
//
// A port of crates/portcullis-runtime/src/runtime/*.rs (load, locate, trace, clip, draw) rule for rule: the same
// operations in the same order on f64 numbers, so a trace gives what `portcullis cull` prints.
// Vectors are plain numbers (x, y, z) or flat arrays; matrices are column-major arrays of 16
// numbers, as glTF and glam store them. No dependency: it runs in Node and in browsers.

// ---------------------------------------------------------------------------------------------
// Numbers as Rust has them.

/** Rust's `f64::min`: NaN gives way to the other operand. */
function fmin(a, b) {
  if (a !== a) return b;
  if (b !== b) return a;
  return b < a ? b : a;
}

/** Rust's `f64::max`: NaN gives way to the other operand. */
function fmax(a, b) {
  if (a !== a) return b;
  if (b !== b) return a;
  return b > a ? b : a;
}

/** Rust's `f64::signum`: 1 for +0, -1 for -0. */
function signum(x) {
  if (x !== x) return NaN;
  return x > 0 || Object.is(x, 0) ? 1 : -1;
}

/** Rust's `f64::clamp` (NaN stays NaN). */
function clamp(x, lo, hi) {
  let v = x;
  if (v < lo) v = lo;
  if (v > hi) v = hi;
  return v;
}

/** Rust's `f64 as usize`: NaN and negatives to 0, saturating above. */
function asUsize(x) {
  if (!(x > 0)) return 0;
  if (x >= Number.MAX_SAFE_INTEGER) return Number.MAX_SAFE_INTEGER;
  return Math.trunc(x);
}

/** Rust's `f64::round`: halves away from zero. */
export function roundHalfAway(x) {
  return x < 0 ? -Math.round(-x) : Math.round(x);
}

/** As `portcullis cull` rounds its numbers: to 1e-9, without a negative zero. */
export function round9(x) {
  const r = roundHalfAway(x * 1e9) / 1e9;
  return r === 0 ? 0 : r;
}

const finite = Number.isFinite;

// ---------------------------------------------------------------------------------------------
// Matrices (column-major, glam's DMat4 algorithms).

const IDENTITY = Object.freeze([1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]);

/** glam's `DMat4::determinant`. */
export function determinant(m) {
  const [m00, m01, m02, m03, m10, m11, m12, m13, m20, m21, m22, m23, m30, m31, m32, m33] = m;
  const a2323 = m22 * m33 - m23 * m32;
  const a1323 = m21 * m33 - m23 * m31;
  const a1223 = m21 * m32 - m22 * m31;
  const a0323 = m20 * m33 - m23 * m30;
  const a0223 = m20 * m32 - m22 * m30;
  const a0123 = m20 * m31 - m21 * m30;
  return (
    m00 * (m11 * a2323 - m12 * a1323 + m13 * a1223) -
    m01 * (m10 * a2323 - m12 * a0323 + m13 * a0223) +
    m02 * (m10 * a1323 - m11 * a0323 + m13 * a0123) -
    m03 * (m10 * a1223 - m11 * a0223 + m12 * a0123)
  );
}

/** glam's `DMat4::inverse` (unchecked). */
export function inverse(m) {
  const [m00, m01, m02, m03, m10, m11, m12, m13, m20, m21, m22, m23, m30, m31, m32, m33] = m;
  const coef00 = m22 * m33 - m32 * m23;
  const coef02 = m12 * m33 - m32 * m13;
  const coef03 = m12 * m23 - m22 * m13;
  const coef04 = m21 * m33 - m31 * m23;
  const coef06 = m11 * m33 - m31 * m13;
  const coef07 = m11 * m23 - m21 * m13;
  const coef08 = m21 * m32 - m31 * m22;
  const coef10 = m11 * m32 - m31 * m12;
  const coef11 = m11 * m22 - m21 * m12;
  const coef12 = m20 * m33 - m30 * m23;
  const coef14 = m10 * m33 - m30 * m13;
  const coef15 = m10 * m23 - m20 * m13;
  const coef16 = m20 * m32 - m30 * m22;
  const coef18 = m10 * m32 - m30 * m12;
  const coef19 = m10 * m22 - m20 * m12;
  const coef20 = m20 * m31 - m30 * m21;
  const coef22 = m10 * m31 - m30 * m11;
  const coef23 = m10 * m21 - m20 * m11;
  const fac0 = [coef00, coef00, coef02, coef03];
  const fac1 = [coef04, coef04, coef06, coef07];
  const fac2 = [coef08, coef08, coef10, coef11];
  const fac3 = [coef12, coef12, coef14, coef15];
  const fac4 = [coef16, coef16, coef18, coef19];
  const fac5 = [coef20, coef20, coef22, coef23];
  const vec0 = [m10, m00, m00, m00];
  const vec1 = [m11, m01, m01, m01];
  const vec2 = [m12, m02, m02, m02];
  const vec3 = [m13, m03, m03, m03];
  const comb = (a, fa, b, fb, c, fc) => [0, 1, 2, 3].map((i) => a[i] * fa[i] - b[i] * fb[i] + c[i] * fc[i]);
  const inv0 = comb(vec1, fac0, vec2, fac1, vec3, fac2);
  const inv1 = comb(vec0, fac0, vec2, fac3, vec3, fac4);
  const inv2 = comb(vec0, fac1, vec1, fac3, vec3, fac5);
  const inv3 = comb(vec0, fac2, vec1, fac4, vec2, fac5);
  const signA = [1, -1, 1, -1];
  const signB = [-1, 1, -1, 1];
  const out = [
    ...inv0.map((v, i) => v * signA[i]),
    ...inv1.map((v, i) => v * signB[i]),
    ...inv2.map((v, i) => v * signA[i]),
    ...inv3.map((v, i) => v * signB[i]),
  ];
  // col0 = the first row of the inverse; dot with the first column of m.
  const d0 = m00 * out[0];
  const d1 = m01 * out[4];
  const d2 = m02 * out[8];
  const d3 = m03 * out[12];
  const dot1 = d0 + d1 + d2 + d3;
  const r = 1.0 / dot1;
  return out.map((v) => v * r);
}

/** glam's `DMat4 * DMat4`. */
export function mulMat(a, b) {
  const out = new Array(16);
  for (let j = 0; j < 4; j++) {
    const x = b[j * 4], y = b[j * 4 + 1], z = b[j * 4 + 2], w = b[j * 4 + 3];
    for (let r = 0; r < 4; r++) {
      let res = a[r] * x;
      res = res + a[4 + r] * y;
      res = res + a[8 + r] * z;
      res = res + a[12 + r] * w;
      out[j * 4 + r] = res;
    }
  }
  return out;
}

/** glam's `DMat4::transform_point3`, into `out` at `o`. */
function transformPoint(m, x, y, z, out, o) {
  for (let r = 0; r < 3; r++) {
    let res = m[r] * x;
    res = m[4 + r] * y + res;
    res = m[8 + r] * z + res;
    res = m[12 + r] + res;
    out[o + r] = res;
  }
}

/** glam's `DMat4::abs_diff_eq`. */
function absDiffEq(a, b, tol) {
  for (let i = 0; i < 16; i++) {
    if (!(Math.abs(a[i] - b[i]) <= tol)) return false;
  }
  return true;
}

// ---------------------------------------------------------------------------------------------
// Geometry (crates/portcullis-runtime/src/runtime/clip.rs). Points are flat arrays, three numbers each; screen points two.

/** Clips the convex polygon `inp` (`n` points) to the half-space `n·x <= d` keeping what lies
 * within `eps` of the inside, into `out`; returns the points written. */
function clip3(inp, n, nx, ny, nz, d, eps, out) {
  if (n === 0) return 0;
  let k = 0;
  let ax = inp[3 * n - 3], ay = inp[3 * n - 2], az = inp[3 * n - 1];
  let da = nx * ax + ny * ay + nz * az - d;
  for (let i = 0; i < n; i++) {
    const bx = inp[3 * i], by = inp[3 * i + 1], bz = inp[3 * i + 2];
    const db = nx * bx + ny * by + nz * bz - d;
    if (da <= eps) {
      out[3 * k] = ax; out[3 * k + 1] = ay; out[3 * k + 2] = az;
      k++;
    }
    if ((da <= eps) !== (db <= eps)) {
      const t = clamp((da - eps) / (da - db), 0.0, 1.0);
      out[3 * k] = ax + (bx - ax) * t;
      out[3 * k + 1] = ay + (by - ay) * t;
      out[3 * k + 2] = az + (bz - az) * t;
      k++;
    }
    ax = bx; ay = by; az = bz;
    da = db;
  }
  return k;
}

function cross2(ox, oy, ax, ay, bx, by) {
  return (ax - ox) * (by - oy) - (ay - oy) * (bx - ox);
}

/** Twice the signed area of a screen polygon. */
function area2(p, n) {
  let s = 0;
  for (let i = 0; i < n; i++) {
    const j = (i + 1) % n;
    s += p[2 * i] * p[2 * j + 1] - p[2 * i + 1] * p[2 * j];
  }
  return s;
}

function perimeter2(p, n) {
  let s = 0;
  for (let i = 0; i < n; i++) {
    const j = (i + 1) % n;
    s += Math.hypot(p[2 * j] - p[2 * i], p[2 * j + 1] - p[2 * i + 1]);
  }
  return s;
}

/** Clips a screen polygon to the left of `a`-`b` within `eps`, into `out`; returns the count. */
function clip2(inp, n, ax, ay, bx, by, eps, out) {
  if (n === 0) return 0;
  let k = 0;
  const len = Math.sqrt((bx - ax) * (bx - ax) + (by - ay) * (by - ay));
  const slack = eps * len;
  let px = inp[2 * n - 2], py = inp[2 * n - 1];
  let sp = cross2(ax, ay, bx, by, px, py) + slack;
  for (let i = 0; i < n; i++) {
    const qx = inp[2 * i], qy = inp[2 * i + 1];
    const sq = cross2(ax, ay, bx, by, qx, qy) + slack;
    if (sp >= 0.0) {
      out[2 * k] = px; out[2 * k + 1] = py;
      k++;
    }
    if ((sp >= 0.0) !== (sq >= 0.0)) {
      const t = clamp(sp / (sp - sq), 0.0, 1.0);
      out[2 * k] = px + (qx - px) * t;
      out[2 * k + 1] = py + (qy - py) * t;
      k++;
    }
    px = qx; py = qy;
    sp = sq;
  }
  return k;
}

/** The Newell normal of `n` points of `p` from point `o` (not normalised). */
function newell(p, o, n) {
  let x = 0, y = 0, z = 0;
  if (n === 0) return [0, 0, 0];
  const fx = p[3 * o], fy = p[3 * o + 1], fz = p[3 * o + 2];
  for (let i = 0; i < n; i++) {
    const a = 3 * (o + i), b = 3 * (o + ((i + 1) % n));
    const ux = p[a] - fx, uy = p[a + 1] - fy, uz = p[a + 2] - fz;
    const vx = p[b] - fx, vy = p[b + 1] - fy, vz = p[b + 2] - fz;
    x = x + (uy * vz - vy * uz);
    y = y + (uz * vx - vz * ux);
    z = z + (ux * vy - vx * uy);
  }
  return [x, y, z];
}

/** glam's `try_normalize`: the unit vector, or null. */
function tryNormalize(x, y, z) {
  const rcp = 1.0 / Math.sqrt(x * x + y * y + z * z);
  if (finite(rcp) && rcp > 0.0) return [x * rcp, y * rcp, z * rcp];
  return null;
}

/** `Half::through`: the plane through `p` with normal `n` made unit, as [nx, ny, nz, d]. */
function through(px, py, pz, n) {
  const u = tryNormalize(n[0], n[1], n[2]);
  if (u === null) return null;
  return [u[0], u[1], u[2], u[0] * px + u[1] * py + u[2] * pz];
}

function segmentDistance(px, py, pz, ax, ay, az, bx, by, bz) {
  const abx = bx - ax, aby = by - ay, abz = bz - az;
  const len2 = abx * abx + aby * aby + abz * abz;
  const t = len2 > 0.0 ? clamp(((px - ax) * abx + (py - ay) * aby + (pz - az) * abz) / len2, 0.0, 1.0) : 0.0;
  const cx = ax + abx * t, cy = ay + aby * t, cz = az + abz * t;
  const dx = px - cx, dy = py - cy, dz = pz - cz;
  return Math.sqrt(dx * dx + dy * dy + dz * dz);
}

/** Distance from p to the convex planar polygon (`n` points of `poly` from `o`) with unit
 * normal (nx, ny, nz). */
function distanceToPolygon(px, py, pz, poly, o, n, nx, ny, nz) {
  if (n === 0) return Infinity;
  const fx = poly[3 * o], fy = poly[3 * o + 1], fz = poly[3 * o + 2];
  const height = (px - fx) * nx + (py - fy) * ny + (pz - fz) * nz;
  const qx = px - nx * height, qy = py - ny * height, qz = pz - nz * height;
  let inside = n >= 3;
  let edge = Infinity;
  const nw = newell(poly, o, n);
  const orient = signum(nw[0] * nx + nw[1] * ny + nw[2] * nz);
  for (let i = 0; i < n; i++) {
    const a = 3 * (o + i), b = 3 * (o + ((i + 1) % n));
    const ax = poly[a], ay = poly[a + 1], az = poly[a + 2];
    const bx = poly[b], by = poly[b + 1], bz = poly[b + 2];
    const ux = bx - ax, uy = by - ay, uz = bz - az;
    const vx = qx - ax, vy = qy - ay, vz = qz - az;
    const cx = uy * vz - vy * uz, cy = uz * vx - vz * ux, cz = ux * vy - vx * uy;
    if ((cx * nx + cy * ny + cz * nz) * orient < 0.0) inside = false;
    edge = fmin(edge, segmentDistance(px, py, pz, ax, ay, az, bx, by, bz));
  }
  return inside ? Math.abs(height) : edge;
}

/** A square of half-size `size` on plane `h` about `centre` projected onto it (flat, 12). */
function planeSquare(h, cx, cy, cz, size) {
  const [nx, ny, nz] = h;
  const dist = nx * cx + ny * cy + nz * cz - h[3];
  const ox = cx - nx * dist, oy = cy - ny * dist, oz = cz - nz * dist;
  const [hx, hy, hz] = Math.abs(nx) < 0.6 ? [1, 0, 0] : [0, 1, 0];
  // n × helper, normalised (times the reciprocal of its length), times size.
  let ux = ny * hz - hy * nz, uy = nz * hx - hz * nx, uz = nx * hy - hx * ny;
  const rcp = 1.0 / Math.sqrt(ux * ux + uy * uy + uz * uz);
  ux = ux * rcp * size; uy = uy * rcp * size; uz = uz * rcp * size;
  const vx = ny * uz - uy * nz, vy = nz * ux - uz * nx, vz = nx * uy - ux * ny;
  return [
    ox - ux - vx, oy - uy - vy, oz - uz - vz,
    ox + ux - vx, oy + uy - vy, oz + uz - vz,
    ox + ux + vx, oy + uy + vy, oz + uz + vz,
    ox - ux + vx, oy - uy + vy, oz - uz + vz,
  ];
}

// ---------------------------------------------------------------------------------------------
// Errors.

/** Why a level cannot be used; `message` names the record as the Rust runtime does. */
export class LevelError extends Error {
  constructor(message) {
    super(message);
    this.name = 'LevelError';
  }
}

/** Why a camera cannot be used. */
export class ViewError extends Error {
  constructor(message) {
    super(message);
    this.name = 'ViewError';
  }
}

// ---------------------------------------------------------------------------------------------
// The glTF container and the PVS encodings (crates/portcullis-runtime/src/format/glb.rs, visibility.rs).

const textDecoder = new TextDecoder();

/** Whether `bytes` (Uint8Array) are a .glb. */
export function isGlb(bytes) {
  return bytes.length >= 4 && bytes[0] === 0x67 && bytes[1] === 0x6c && bytes[2] === 0x54 && bytes[3] === 0x46;
}

function asBytes(data) {
  if (data instanceof Uint8Array) return data;
  if (ArrayBuffer.isView(data)) return new Uint8Array(data.buffer, data.byteOffset, data.byteLength);
  return new Uint8Array(data);
}

/** Splits a .glb into its parsed JSON and its BIN chunk (a Uint8Array, or null); a .gltf's
 * bytes are parsed as JSON text. */
export function parseGltfBytes(data) {
  const bytes = asBytes(data);
  if (!isGlb(bytes)) return { json: JSON.parse(textDecoder.decode(bytes)), bin: null };
  if (bytes.length < 12) throw new LevelError(`is not a readable .glb: truncated GLB: ${bytes.length} bytes, shorter than the 12-byte header`);
  const dv = new DataView(bytes.buffer, bytes.byteOffset, bytes.byteLength);
  const version = dv.getUint32(4, true);
  if (version !== 2) throw new LevelError(`is not a readable .glb: GLB container version ${version}; only version 2 (glTF 2.0) is read`);
  const length = dv.getUint32(8, true);
  if (length < 20) throw new LevelError(`is not a readable .glb: the GLB header claims a total length of ${length} bytes, too short to hold a JSON chunk`);
  if (length > bytes.length) throw new LevelError(`is not a readable .glb: truncated GLB: the header says ${length} bytes but the file has ${bytes.length}`);
  let at = 12;
  let json = null;
  let bin = null;
  while (at + 8 <= length) {
    const len = dv.getUint32(at, true);
    const type = dv.getUint32(at + 4, true);
    const start = at + 8;
    if (start + len > length) throw new LevelError('is not a readable .glb: truncated GLB: a chunk claims more bytes than follow');
    const chunk = bytes.subarray(start, start + len);
    if (json === null) {
      if (type !== 0x4e4f534a) throw new LevelError('is not a readable .glb: unexpected chunk (the first chunk must be JSON, the second BIN)');
      json = JSON.parse(textDecoder.decode(chunk));
    } else if (type === 0x004e4942 && bin === null) {
      bin = chunk;
    }
    at = start + len;
  }
  if (json === null) throw new LevelError('is not a readable .glb: no JSON chunk');
  return { json, bin };
}

/** The bytes of a base64 `data:` URI, or null when it is not one. */
export function dataUriBytes(uri) {
  const i = uri.indexOf(';base64,');
  if (!uri.startsWith('data:') || i < 0) return null;
  let s;
  try {
    s = atob(uri.slice(i + 8));
  } catch {
    return null;
  }
  const out = new Uint8Array(s.length);
  for (let k = 0; k < s.length; k++) out[k] = s.charCodeAt(k);
  return out;
}

/** The bytes of buffer view `i` of a glTF document. `bin`: a .glb's BIN chunk;
 * `loadUri(uri)`: the bytes of an external buffer (synchronous), for .gltf files with .bin
 * files. */
export function bufferViewBytes(json, i, { bin = null, loadUri = null } = {}) {
  const view = (json.bufferViews || [])[i];
  if (view === undefined) throw new LevelError(`visibility: buffer view ${i} does not exist`);
  if (!Number.isInteger(view.buffer)) throw new LevelError(`visibility: buffer view ${i} names no buffer`);
  if (!Number.isInteger(view.byteLength)) throw new LevelError(`visibility: buffer view ${i} has no byteLength`);
  const buffer = (json.buffers || [])[view.buffer];
  if (buffer === undefined) throw new LevelError(`visibility: buffer view ${i} names a buffer that does not exist`);
  const off = Number.isInteger(view.byteOffset) ? view.byteOffset : 0;
  const len = view.byteLength;
  let data;
  if (typeof buffer.uri !== 'string') {
    if (!bin) throw new LevelError(`visibility: buffer view ${i} lies in a BIN chunk the file does not have`);
    data = bin;
  } else if (buffer.uri.startsWith('data:')) {
    data = dataUriBytes(buffer.uri);
    if (data === null) throw new LevelError(`visibility: buffer view ${i} lies in a data URI that is not base64`);
  } else {
    if (!loadUri) throw new LevelError(`visibility: buffer view ${i} lies in ${buffer.uri}, which cannot be read here`);
    data = asBytes(loadUri(buffer.uri));
  }
  if (off + len > data.length) throw new LevelError(`visibility: buffer view ${i} lies beyond its buffer`);
  return data.subarray(off, off + len);
}

/** A decoded PVS: per cell a row of bits (cell `j` in bit `j % 8` of byte `j / 8`). */
export class Pvs {
  constructor(cells) {
    this.cells = cells;
    this.rowBytes = Math.ceil(cells / 8);
    this.bits = new Uint8Array(cells * this.rowBytes);
  }
  set(from, to) {
    this.bits[from * this.rowBytes + (to >> 3)] |= 1 << (to & 7);
  }
  /** Whether `to` may be seen from somewhere in `from`. */
  sees(from, to) {
    return ((this.bits[from * this.rowBytes + (to >> 3)] >> (to & 7)) & 1) === 1;
  }
  /** The cells `from` may see, ascending. */
  visible(from) {
    const out = [];
    for (let v = 0; v < this.cells; v++) if (this.sees(from, v)) out.push(v);
    return out;
  }
}

/** Undoes Quake's zero-run compression; null if the data is cut short. */
export function zeroRunDecode(data, expected) {
  const out = new Uint8Array(expected);
  let n = 0;
  let i = 0;
  while (i < data.length && n < expected) {
    if (data[i] !== 0) {
      out[n++] = data[i];
      i += 1;
    } else {
      if (i + 1 >= data.length) return null;
      const run = data[i + 1];
      if (run === 0) return null;
      if (n + run > expected) return null;
      n += run; // already zero
      i += 2;
    }
  }
  return n === expected ? out : null;
}

/** Decodes the extension's `visibility` (`blob`: its buffer view's bytes). */
export function decodeVisibility(vis, cells, blob) {
  const enc = typeof vis.encoding === 'string' ? vis.encoding : '';
  const pvs = new Pvs(cells);
  if (enc === 'lists') {
    const lists = vis.lists;
    if (!Array.isArray(lists)) throw new LevelError('visibility: `lists` is missing');
    if (lists.length !== cells) throw new LevelError(`visibility: ${lists.length} lists for ${cells} cells`);
    lists.forEach((l, c) => {
      if (!Array.isArray(l)) throw new LevelError('visibility: a list is not an array');
      for (const v of l) {
        if (!Number.isInteger(v) || v < 0) throw new LevelError('visibility: a list holds something that is not a cell index');
        if (v >= cells) throw new LevelError(`visibility: row ${c} names cell ${v}, which does not exist`);
        pvs.set(c, v);
      }
    });
  } else if (enc === 'bits' || enc === 'bitsZeroRun') {
    const rb = Math.ceil(cells / 8);
    if (vis.rowBytes !== rb) throw new LevelError(`visibility: rowBytes is not ${rb} for ${cells} cells`);
    if (!blob) throw new LevelError('visibility: the buffer view is missing');
    let raw;
    if (enc === 'bits') raw = blob.length >= rb * cells ? blob.subarray(0, rb * cells) : null;
    else raw = zeroRunDecode(blob, rb * cells);
    if (raw === null) throw new LevelError('visibility: fewer rows than cells');
    pvs.bits.set(raw);
  } else {
    throw new LevelError(`visibility: unknown encoding \`${enc}\``);
  }
  return pvs;
}

// ---------------------------------------------------------------------------------------------
// Views (crates/portcullis-runtime/src/runtime/trace.rs `View`).

/** A perspective camera. NDC: x right, y up, both -1..1. */
export class View {
  /**
   * @param {number[]} eye the eye's position
   * @param {number[]} look the direction of view
   * @param {number[]} up any direction not along `look`
   * @param {number} fovY the vertical field of view in degrees
   * @param {number} aspect width / height
   * @param {number} near the near plane's distance
   */
  constructor(eye, look, up = [0, 1, 0], fovY = 60, aspect = 16 / 9, near = 0.05) {
    if (!(finite(eye[0]) && finite(eye[1]) && finite(eye[2]))) throw new ViewError('eye is not a finite point');
    const forward = tryNormalize(look[0], look[1], look[2]);
    if (forward === null) throw new ViewError('look has no direction');
    const [fx, fy, fz] = forward;
    const right = tryNormalize(fy * up[2] - up[1] * fz, fz * up[0] - up[2] * fx, fx * up[1] - up[0] * fy);
    if (right === null) throw new ViewError('up has no direction across look (parallel or zero)');
    if (!(fovY > 0.0 && fovY < 180.0)) throw new ViewError('fov_y must lie strictly between 0 and 180 degrees');
    if (!(finite(aspect) && aspect > 0.0)) throw new ViewError('aspect must be a positive width / height');
    if (!(finite(near) && near > 0.0)) throw new ViewError('near must be a positive distance');
    const tanY = Math.tan((fovY * (Math.PI / 180.0)) / 2.0);
    const [rx, ry, rz] = right;
    this.eye = [eye[0], eye[1], eye[2]];
    this.forward = forward;
    this.right = right;
    this.up = [ry * fz - fy * rz, rz * fx - fz * rx, rx * fy - fx * ry];
    this.tanX = tanY * aspect;
    this.tanY = tanY;
    this.near = near;
  }

  /** The distance from the eye to the near plane's corners. */
  nearRadius() {
    return this.near * Math.sqrt(1.0 + this.tanX * this.tanX + this.tanY * this.tanY);
  }

  /** Whether any of the box `min..max` may lie in the view's frustum: false only when one of
   * its planes has all eight corners outside (`View::sees_box`). An unbounded box is seen. */
  seesBox(min, max) {
    if (![...min, ...max].every(finite)) return true;
    const [fx, fy, fz] = this.forward;
    const [rx, ry, rz] = this.right;
    const [ux, uy, uz] = this.up;
    const tx = this.tanX, ty = this.tanY;
    const sides = [
      [rx - fx * tx, ry - fy * tx, rz - fz * tx],
      [-rx - fx * tx, -ry - fy * tx, -rz - fz * tx],
      [ux - fx * ty, uy - fy * ty, uz - fz * ty],
      [-ux - fx * ty, -uy - fy * ty, -uz - fz * ty],
    ];
    const [ex, ey, ez] = this.eye;
    const nearestDot = (n) => {
      const cx = n[0] > 0.0 ? min[0] : max[0];
      const cy = n[1] > 0.0 ? min[1] : max[1];
      const cz = n[2] > 0.0 ? min[2] : max[2];
      return n[0] * (cx - ex) + n[1] * (cy - ey) + n[2] * (cz - ez);
    };
    if (sides.some((n) => nearestDot(n) > 0.0)) return false;
    return nearestDot([-fx, -fy, -fz]) <= -this.near;
  }

  /** The NDC of p, or null behind the near plane. */
  ndc(p) {
    const vx = p[0] - this.eye[0], vy = p[1] - this.eye[1], vz = p[2] - this.eye[2];
    const f = this.forward;
    const z = vx * f[0] + vy * f[1] + vz * f[2];
    if (!(z >= this.near)) return null;
    const r = this.right, u = this.up;
    return [(vx * r[0] + vy * r[1] + vz * r[2]) / (z * this.tanX), (vx * u[0] + vy * u[1] + vz * u[2]) / (z * this.tanY)];
  }
}

// ---------------------------------------------------------------------------------------------
// Doors.

/** Which portals are closed: the extension's initially-closed doors, changed at run time.
 * Closing a portal closes its partner too. */
export class Doors {
  constructor(level) {
    this.closed = Uint8Array.from(level.portalClosed);
  }
  /** Opens or closes portal `p` and its partner; out-of-range indices are ignored. */
  set(level, p, closed) {
    if (!(p >= 0 && p < level.portalCount)) return;
    this.closed[p] = closed ? 1 : 0;
    const q = level.portalPartner[p];
    if (q >= 0) this.closed[q] = closed ? 1 : 0;
  }
  isClosed(p) {
    return this.closed[p] === 1;
  }
}

/** The limits of a trace, as `TraceOptions::default()`. */
export const DEFAULT_OPTIONS = Object.freeze({ maxDepth: 32, maxTransformDepth: 2, usePvs: true });

function newStats() {
  return {
    entered: 0,
    portals_tested: 0,
    portals_culled: 0,
    pvs_skipped: 0,
    closed_skipped: 0,
    on_path_skipped: 0,
    passed_through: 0,
    depth_limit_hits: 0,
    transform_limit_hits: 0,
    deepest: 0,
  };
}

/** Where the eye was found: `{kind: 'inside'|'boundary', cell}` or `{kind: 'outside', cell:
 * null, nearest}`. */
function located(kind, cell, nearest = null) {
  return kind === 'outside' ? { kind, cell: null, nearest } : { kind, cell };
}

const NONE = -1;

/** The result of `Level#trace` and the buffers it reuses: keep one per camera (its last
 * location is the next trace's hint). */
export class Trace {
  constructor() {
    this.location = located('outside', null, null);
    this.stats = newStats();
    /** `{cell, rect, depth, transform, mirrored, via}` per cell (and transform) seen. */
    this.visible = [];
    this.views = []; // 5 per view: screen start, end, clips start, end, next (viewsLen used)
    this.planes = []; // 4 per plane (planesLen used)
    this.screen = []; // 2 per point (screenLen used)
    this.viewsLen = 0;
    this.planesLen = 0;
    this.screenLen = 0;
    this.camera = null;
    this.pathPortal = [];
    this.pathTransformed = [];
    this.stamp = new Uint32Array(0);
    this.entry = new Uint32Array(0);
    this.generation = 0;
    this.polyA = [];
    this.polyB = [];
    this.flatA = [];
    this.flatB = [];
    this.outsideLinks = [];
    this.onPathCells = new Uint16Array(0);
    // Per region: generation, view and depth of its last walk entered by passing through.
    this.passedGen = new Uint32Array(0);
    this.passedView = new Uint32Array(0);
    this.passedDepth = new Uint32Array(0);
  }

  reset(regions) {
    this.stats = newStats();
    this.visible = [];
    this.viewsLen = 0;
    this.planesLen = 0;
    this.screenLen = 0;
    this.pathPortal.length = 0;
    this.pathTransformed.length = 0;
    if (this.onPathCells.length !== regions) this.onPathCells = new Uint16Array(regions);
    if (this.stamp.length !== regions) {
      this.stamp = new Uint32Array(regions);
      this.entry = new Uint32Array(regions);
      this.passedGen = new Uint32Array(regions);
      this.passedView = new Uint32Array(regions);
      this.passedDepth = new Uint32Array(regions);
      this.generation = 0;
    }
    this.generation = (this.generation + 1) >>> 0;
    if (this.generation === 0) {
      this.stamp.fill(0);
      this.passedGen.fill(0);
      this.generation = 1;
    }
  }

  visit(f) {
    const region = f.region;
    let found = -1;
    if (f.draw === null) {
      if (this.stamp[region] === this.generation) found = this.entry[region];
    } else {
      const d = f.draw[0];
      const tol = 1e-9 * (1.0 + maxAbsW(d));
      for (let i = 0; i < this.visible.length; i++) {
        const v = this.visible[i];
        if (v.cell === f.cell && v.transform !== null && absDiffEq(v.transform, d, tol)) {
          found = i;
          break;
        }
      }
    }
    const view = this.viewsLen / 5;
    const depth = f.depth;
    let i;
    if (found >= 0) {
      i = found;
      const v = this.visible[i];
      v.rect = [fmin(v.rect[0], f.rect[0]), fmin(v.rect[1], f.rect[1]), fmax(v.rect[2], f.rect[2]), fmax(v.rect[3], f.rect[3])];
      if (depth < v.depth) {
        v.depth = depth;
        v.via = this.pathPortal.slice();
      }
    } else {
      this.visible.push({
        cell: f.cell,
        rect: f.rect,
        depth,
        transform: f.draw === null ? null : f.draw[0],
        mirrored: f.mirrored,
        via: this.pathPortal.slice(),
        firstView: NONE,
      });
      i = this.visible.length - 1;
      if (f.draw === null) {
        this.stamp[region] = this.generation;
        this.entry[region] = i;
      }
    }
    const w = this.views;
    let k = this.viewsLen;
    w[k++] = f.viewStart;
    w[k++] = f.viewEnd;
    w[k++] = f.clipStart;
    w[k++] = f.clipEnd;
    w[k++] = this.visible[i].firstView;
    this.viewsLen = k;
    this.visible[i].firstView = view;
    this.stats.entered += 1;
    this.stats.deepest = Math.max(this.stats.deepest, f.depth);
  }

  onPath(portal) {
    for (let k = this.pathPortal.length - 1; k >= 0; k--) {
      if (this.pathPortal[k] === portal) return true;
      if (this.pathTransformed[k]) return false;
    }
    return false;
  }

  /** Whether a moving object with world bounds `min`..`max`, drawn with visible entry
   * `entry`, can be seen (`Trace::box_visible`). */
  boxVisible(entry, min, max) {
    const v = this.visible[entry];
    const camera = this.camera;
    if (v === undefined || camera === null) return false;
    const corners = [];
    for (let i = 0; i < 8; i++) {
      const c = [i & 1 ? max[0] : min[0], i & 2 ? max[1] : min[1], i & 4 ? max[2] : min[2]];
      if (v.transform !== null) transformPoint(v.transform, c[0], c[1], c[2], c, 0);
      corners.push(c);
    }
    let at = v.firstView;
    while (at !== NONE) {
      const b = at * 5;
      const [vs, ve, cs, ce, next] = this.views.slice(b, b + 5);
      at = next;
      let culled = false;
      for (let k = cs; k < ce && !culled; k++) {
        const p = this.planes;
        culled = corners.every((c) => p[4 * k] * c[0] + p[4 * k + 1] * c[1] + p[4 * k + 2] * c[2] - p[4 * k + 3] > 0.0);
      }
      if (culled) continue;
      const flat = [];
      for (const c of corners) {
        const q = camera.ndc(c);
        if (q === null) return true;
        flat.push(q);
      }
      const s = this.screen;
      const n = ve - vs;
      let apart = false;
      for (let k = 0; k < n && !apart; k++) {
        const a = vs + k, bb = vs + ((k + 1) % n);
        apart = flat.every((q) => cross2(s[2 * a], s[2 * a + 1], s[2 * bb], s[2 * bb + 1], q[0], q[1]) < 0.0);
      }
      if (!apart) return true;
    }
    return false;
  }
}

function maxAbsW(d) {
  const max = (a, b) => (a > b ? a : b);
  return max(Math.abs(d[12]), max(Math.abs(d[13]), max(Math.abs(d[14]), Math.abs(d[15]))));
}

// ---------------------------------------------------------------------------------------------
// The level.

const KIND = { plain: 0, mirror: 1, teleporter: 2 };
const KIND_NAMES = ['plain', 'mirror', 'teleporter'];

const isIndex = (v) => Number.isInteger(v) && v >= 0;

/** What the schema cannot check (`format::read::consistency`, with any node index allowed):
 * the first problem, or null. */
function consistency(a) {
  const cells = a.cells.length;
  for (const [i, r] of a.rooms.entries()) {
    for (const c of r.cells || []) if (c >= cells) return `/rooms/${i}: cell ${c} does not exist (${cells} cells)`;
  }
  for (const [i, p] of a.portals.entries()) {
    for (const c of p.cells) if (c >= cells) return `/portals/${i}: cell ${c} does not exist (${cells} cells)`;
    if (p.partner !== undefined && p.partner !== null) {
      const j = p.partner;
      const q = a.portals[j];
      const from = (x) => (x.cells.length > 0 ? x.cells[0] : 0);
      const to = (x) => (x.cells.length > 1 ? x.cells[1] : null);
      if (q === undefined) return `/portals/${i}: partner ${j} does not exist`;
      if (q.partner !== i) return `/portals/${i}: partner ${j} does not name it back`;
      if (j !== i && (from(q) !== (to(p) === null ? -1 : to(p)) || to(q) !== from(p))) return `/portals/${i}: partner ${j} does not join the same cells the other way`;
    }
  }
  if (a.visibility && a.visibility.encoding === 'lists') {
    try {
      decodeVisibility(a.visibility, cells, null);
    } catch (e) {
      return `/visibility: ${e.message.replace(/^visibility: /, '')}`;
    }
  }
  return null;
}

/** Checks the shape of the extension object enough to read it (the Rust reader's serde
 * types); returns it with defaults filled in. */
function readAnnotation(ext) {
  if (ext === null || typeof ext !== 'object') throw new LevelError('has no PORTCULLIS_portals extension');
  const fail = (m) => {
    throw new LevelError(m);
  };
  const num = (v, what) => (typeof v === 'number' ? v : fail(`${what} is not a number`));
  const cells = (ext.cells || []).map((c, i) => {
    if (typeof c.room !== 'string') fail(`/cells/${i}: room is not a string`);
    if (!Array.isArray(c.planes)) fail(`/cells/${i}: planes is not an array`);
    const planes = c.planes.map((p) => {
      if (!Array.isArray(p) || p.length !== 4) fail(`/cells/${i}: a plane is not [nx, ny, nz, d]`);
      return p.map((x) => num(x, `/cells/${i}/planes`));
    });
    const b = c.bounds || fail(`/cells/${i}: bounds are missing`);
    const vec = (v, what) => (Array.isArray(v) && v.length === 3 ? v.map((x) => num(x, what)) : fail(`/cells/${i}: ${what} is not [x, y, z]`));
    const nodes = c.nodes || [];
    const draws = c.draws || [];
    for (const n of nodes) if (!isIndex(n)) fail(`/cells/${i}: nodes holds something that is not an index`);
    for (const d of draws) if (!Array.isArray(d) || d.length !== 3 || !d.every(isIndex)) fail(`/cells/${i}: draws holds something that is not [primitive, first, count]`);
    return {
      room: c.room,
      priority: c.priority === undefined ? 0 : num(c.priority, `/cells/${i}/priority`),
      planes,
      min: vec(b.min, 'bounds.min'),
      max: vec(b.max, 'bounds.max'),
      nodes,
      draws,
    };
  });
  const portals = (ext.portals || []).map((p, i) => {
    if (!Array.isArray(p.polygon)) fail(`/portals/${i}: polygon is not an array`);
    if (!Array.isArray(p.cells) || !p.cells.every(isIndex)) fail(`/portals/${i}: cells is not a list of indices`);
    if (p.transform !== undefined && p.transform !== null && !(Array.isArray(p.transform) && p.transform.length === 16)) fail(`/portals/${i}: transform is not 16 numbers`);
    return {
      polygon: p.polygon.map((v) => (Array.isArray(v) && v.length === 3 ? v.map((x) => num(x, `/portals/${i}/polygon`)) : fail(`/portals/${i}: a corner is not [x, y, z]`))),
      cells: p.cells,
      kind: typeof p.kind === 'string' ? p.kind : null,
      oneWay: p.oneWay === true,
      closed: p.closed === true,
      door: p.door === true,
      transform: Array.isArray(p.transform) ? p.transform.map((x) => num(x, `/portals/${i}/transform`)) : null,
      partner: isIndex(p.partner) ? p.partner : null,
      node: isIndex(p.node) ? p.node : null,
    };
  });
  return {
    tolerance: num(ext.tolerance, 'tolerance'),
    rooms: ext.rooms || [],
    cells,
    portals,
    split: ext.split || null,
    visibility: ext.visibility === undefined ? null : ext.visibility,
  };
}

/** A level's culling data, read from its extension. Build it with `Level.fromGltf` (a parsed
 * glTF document) or `Level.fromAnnotation` (the extension object and a decoded PVS). */
export class Level {
  /**
   * The level of a parsed glTF document.
   * @param {object} json the glTF JSON
   * @param {{bin?: Uint8Array, loadUri?: (uri: string) => Uint8Array, visibilityBytes?:
   *   Uint8Array|ArrayBuffer}} [opts] a .glb's BIN chunk; a reader of external buffers (only
   *   the PVS's buffer view is read); or the bytes of the PVS's buffer view, already loaded
   */
  static fromGltf(json, opts = {}) {
    const ext = json && json.extensions && json.extensions.PORTCULLIS_portals;
    if (!ext) throw new LevelError('has no PORTCULLIS_portals extension');
    const a = readAnnotation(ext);
    let pvs = null;
    if (a.visibility !== null) {
      const vis = a.visibility;
      let blob = null;
      if (opts.visibilityBytes) blob = asBytes(opts.visibilityBytes);
      else if (isIndex(vis.bufferView)) blob = bufferViewBytes(json, vis.bufferView, opts);
      pvs = decodeVisibility(vis, a.cells.length, blob);
    }
    return Level.fromAnnotation(ext, pvs, a);
  }

  /** The level of the bytes of a .glb, or of a .gltf (its data: URIs and `loadUri`). */
  static fromBytes(data, opts = {}) {
    const { json, bin } = parseGltfBytes(data);
    return Level.fromGltf(json, { ...opts, bin });
  }

  /** The level of an extension object and its decoded PVS (null: none stored). */
  static fromAnnotation(ext, pvs, read = null) {
    const a = read || readAnnotation(ext);
    const problem = consistency(a);
    if (problem !== null) throw new LevelError(problem);
    if (!(finite(a.tolerance) && a.tolerance > 0.0)) throw new LevelError(`tolerance ${a.tolerance} is not a positive number`);
    return new Level(a, pvs);
  }

  constructor(a, pvs) {
    this.tolerance = a.tolerance;
    this.annotation = a;
    const n = a.cells.length;
    this.cellCount = n;
    this.rooms = a.cells.map((c) => c.room);
    this.priority = a.cells.map((c) => c.priority);
    this.planeStart = new Int32Array(n + 1);
    this.planes = []; // 4 per plane
    this.faceStart = new Int32Array(n + 1);
    this.facePlane = []; // index into planes
    this.facePoints = [0]; // start per face, then the end
    this.points = []; // 3 per point
    this.cellMin = new Float64Array(3 * n);
    this.cellMax = new Float64Array(3 * n);
    this.volume = new Float64Array(n);
    this.overlapped = new Uint8Array(n);
    this.pvs = pvs;
    this.readDraws(a);
    for (let i = 0; i < n; i++) this.addCell(i, a.cells[i]);
    const np = a.portals.length;
    this.portalCount = np;
    this.portalFrom = new Int32Array(np);
    this.portalTo = new Int32Array(np);
    this.cornerStart = new Int32Array(np + 1);
    this.corners = [];
    this.portalPlane = new Float64Array(4 * np);
    this.portalKind = new Uint8Array(np);
    this.portalOneWay = new Uint8Array(np);
    this.portalClosed = new Uint8Array(np);
    this.portalTransform = new Int32Array(np);
    this.portalPartner = new Int32Array(np);
    this.transforms = [];
    for (let i = 0; i < np; i++) this.addPortal(i, a.portals[i]);
    // Per cell, whether it may see the outside.
    const vis = a.visibility;
    this.outsideFlags = new Uint8Array(n);
    if (vis === null) this.outsideFlags.fill(1);
    else if (vis.outside !== undefined) {
      for (const c of Array.isArray(vis.outside) ? vis.outside : []) {
        if (!(isIndex(c) && c < n)) throw new LevelError(`visibility: outside names ${JSON.stringify(c)}, which is no cell`);
        this.outsideFlags[c] = 1;
      }
    }
    this.linkRegions();
    if (pvs !== null && pvs.cells !== n) throw new LevelError('the visibility does not have one row per cell');
    this.buildGrid();
    this.markOverlaps();
  }

  readDraws(a) {
    const prims = a.split ? a.split.primitives || [] : [];
    const splitNodes = new Set(prims.map((p) => p.node));
    this.splitPrimitives = prims.map((p) => ({ node: p.node, primitive: p.primitive, first: p.first, count: p.count }));
    this.splitIndices = a.split && isIndex(a.split.indices) ? a.split.indices : null;
    this.listed = [];
    this.whole = [];
    this.ranges = [];
    a.cells.forEach((cell, c) => {
      this.listed.push(cell.nodes.slice());
      this.whole.push(cell.nodes.filter((n) => !splitNodes.has(n)));
      const ranges = cell.draws.map(([k, first, count], i) => {
        const bad = `/cells/${c}/draws/${i}: the range is not within split primitive ${k}'s indices`;
        const p = prims[k];
        if (p === undefined) throw new LevelError(bad);
        const end = first + count;
        if (first < p.first || end > p.first + p.count || end > 0xffffffff) throw new LevelError(bad);
        return [k, first, count];
      });
      this.ranges.push(ranges);
    });
    this.named = [...new Set(this.listed.flat())].sort((x, y) => x - y);
  }

  addCell(i, c) {
    const tol = this.tolerance;
    const start = this.planes.length / 4;
    this.planeStart[i] = start;
    for (const p of c.planes) {
      const len = Math.sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]);
      if (!(finite(len) && len > 0.5 && finite(p[3]))) throw new LevelError(`/cells/${i}: plane [${p.join(', ')}] has no unit normal`);
      this.planes.push(p[0] / len, p[1] / len, p[2] / len, p[3] / len);
    }
    const end = this.planes.length / 4;
    this.planeStart[i + 1] = end;
    const [x0, y0, z0] = c.min;
    const [x1, y1, z1] = c.max;
    if (!([x0, y0, z0, x1, y1, z1].every(finite) && x0 <= x1 && y0 <= y1 && z0 <= z1)) throw new LevelError(`/cells/${i}: bounds are not a box`);
    this.cellMin.set([x0, y0, z0], 3 * i);
    this.cellMax.set([x1, y1, z1], 3 * i);
    const ex = x1 - x0, ey = y1 - y0, ez = z1 - z0;
    const size = fmax(Math.sqrt(ex * ex + ey * ey + ez * ez), tol) * 2.0;
    const cx = (x0 + x1) / 2.0, cy = (y0 + y1) / 2.0, cz = (z0 + z1) / 2.0;
    const faceStart = this.facePlane.length;
    this.faceStart[i] = faceStart;
    const P = this.planes;
    let sx = 0, sy = 0, sz = 0;
    let count = 0.0;
    let a = [], b = [];
    for (let k = start; k < end; k++) {
      const h = [P[4 * k], P[4 * k + 1], P[4 * k + 2], P[4 * k + 3]];
      a = planeSquare(h, cx, cy, cz, size);
      let na = 4;
      for (let j = start; j < end; j++) {
        if (j !== k) {
          const nb = clip3(a, na, P[4 * j], P[4 * j + 1], P[4 * j + 2], P[4 * j + 3], tol, b);
          const sw = a; a = b; b = sw;
          na = nb;
        }
      }
      if (na >= 3) {
        for (let q = 0; q < 3 * na; q++) this.points.push(a[q]);
        this.facePlane.push(k);
        this.facePoints.push(this.points.length / 3);
        let fx = 0, fy = 0, fz = 0;
        for (let q = 0; q < na; q++) {
          fx = fx + a[3 * q];
          fy = fy + a[3 * q + 1];
          fz = fz + a[3 * q + 2];
        }
        sx = sx + fx; sy = sy + fy; sz = sz + fz;
        count += na;
      }
    }
    this.faceStart[i + 1] = this.facePlane.length;
    if (count === 0.0) throw new LevelError(`/cells/${i}: its planes enclose nothing`);
    const ix = sx / count, iy = sy / count, iz = sz / count;
    let volume = 0.0;
    for (let f = faceStart; f < this.facePlane.length; f++) {
      const k = this.facePlane[f];
      const nx = P[4 * k], ny = P[4 * k + 1], nz = P[4 * k + 2], d = P[4 * k + 3];
      const from = this.facePoints[f], to = this.facePoints[f + 1];
      const nw = newell(this.points, from, to - from);
      const dist = nx * ix + ny * iy + nz * iz - d;
      volume += ((Math.abs(nw[0] * nx + nw[1] * ny + nw[2] * nz) / 2.0) * -dist) / 3.0;
    }
    this.volume[i] = Math.abs(volume);
  }

  addPortal(i, p) {
    const start = this.corners.length / 3;
    this.cornerStart[i] = start;
    for (const v of p.polygon) this.corners.push(v[0], v[1], v[2]);
    const n = this.corners.length / 3 - start;
    this.cornerStart[i + 1] = start + n;
    if (n < 3 || !p.polygon.every((v) => v.every(finite))) throw new LevelError(`/portals/${i}: the polygon is not a polygon`);
    const C = this.corners;
    let sx = 0, sy = 0, sz = 0;
    for (let k = start; k < start + n; k++) {
      sx = sx + C[3 * k]; sy = sy + C[3 * k + 1]; sz = sz + C[3 * k + 2];
    }
    const cx = sx / n, cy = sy / n, cz = sz / n;
    const nw = newell(C, start, n);
    const plane = through(cx, cy, cz, [-nw[0], -nw[1], -nw[2]]);
    if (plane === null) throw new LevelError(`/portals/${i}: the polygon has no area`);
    let transform = -1;
    if (p.transform !== null) {
      const m = p.transform.slice();
      const det = determinant(m);
      if (!(finite(det) && Math.abs(det) > 1e-12)) throw new LevelError(`/portals/${i}: the transform cannot be inverted`);
      this.transforms.push([m, inverse(m)]);
      transform = this.transforms.length - 1;
    }
    this.portalFrom[i] = p.cells.length > 0 ? p.cells[0] : 0;
    this.portalTo[i] = p.cells.length > 1 ? p.cells[1] : -1;
    this.portalPlane.set(plane, 4 * i);
    this.portalKind[i] = p.kind === 'mirror' ? KIND.mirror : p.kind === 'teleporter' ? KIND.teleporter : KIND.plain;
    this.portalOneWay[i] = p.oneWay ? 1 : 0;
    this.portalClosed[i] = p.closed ? 1 : 0;
    this.portalTransform[i] = transform;
    this.portalPartner[i] = p.partner === null ? -1 : p.partner;
  }

  /** Links per region, in portal order: forward for every portal, and from the outside back
   * through each exterior opening that sight may cross both ways. */
  linkRegions() {
    const cells = this.cellCount;
    const byRegion = Array.from({ length: cells + 1 }, () => []);
    for (let i = 0; i < this.portalCount; i++) {
      const to = this.portalTo[i];
      byRegion[this.portalFrom[i]].push([i, to < 0 ? cells : to, 0]);
      if (to < 0 && !this.portalOneWay[i]) byRegion[cells].push([i, this.portalFrom[i], 1]);
    }
    const total = byRegion.reduce((s, r) => s + r.length, 0);
    this.linkPortal = new Int32Array(total);
    this.linkTo = new Int32Array(total);
    this.linkReversed = new Uint8Array(total);
    this.linkStart = new Int32Array(cells + 2);
    let k = 0;
    byRegion.forEach((region, r) => {
      this.linkStart[r] = k;
      for (const [p, to, rev] of region) {
        this.linkPortal[k] = p;
        this.linkTo[k] = to;
        this.linkReversed[k] = rev;
        k++;
      }
    });
    this.linkStart[cells + 1] = k;
  }

  // ---- locate.rs

  buildGrid() {
    const tol = this.tolerance;
    const n = this.cellCount;
    if (n === 0) {
      this.grid = { min: [0, 0, 0], size: [1, 1, 1], dims: [1, 1, 1], start: new Int32Array([0, 0]), items: new Int32Array(0) };
      return;
    }
    let min = [Infinity, Infinity, Infinity];
    let max = [-Infinity, -Infinity, -Infinity];
    for (let c = 0; c < n; c++) {
      for (let a = 0; a < 3; a++) {
        const lo = this.cellMin[3 * c + a], hi = this.cellMax[3 * c + a];
        min[a] = min[a] < lo ? min[a] : lo;
        max[a] = max[a] > hi ? max[a] : hi;
      }
    }
    min = min.map((v) => v - tol);
    max = max.map((v) => v + tol);
    const extent = [0, 1, 2].map((a) => {
      const e = max[a] - min[a];
      return e > tol ? e : tol;
    });
    const k = Math.cbrt(n / (extent[0] * extent[1] * extent[2]));
    const dim = (e) => Math.min(Math.max(asUsize(Math.ceil(e * k)), 1), 256);
    const dims = [dim(extent[0]), dim(extent[1]), dim(extent[2])];
    const size = [extent[0] / dims[0], extent[1] / dims[1], extent[2] / dims[2]];
    this.grid = { min, size, dims, start: null, items: null };
    const buckets = dims[0] * dims[1] * dims[2];
    const lists = Array.from({ length: buckets }, () => []);
    for (let i = 0; i < n; i++) {
      const lo = this.bucket(this.cellMin[3 * i] - tol, this.cellMin[3 * i + 1] - tol, this.cellMin[3 * i + 2] - tol);
      const hi = this.bucket(this.cellMax[3 * i] + tol, this.cellMax[3 * i + 1] + tol, this.cellMax[3 * i + 2] + tol);
      for (let x = lo[0]; x <= hi[0]; x++) for (let y = lo[1]; y <= hi[1]; y++) for (let z = lo[2]; z <= hi[2]; z++) lists[this.bucketIndex(x, y, z)].push(i);
    }
    const start = new Int32Array(buckets + 1);
    const items = [];
    lists.forEach((l, b) => {
      start[b] = items.length;
      for (const c of l) items.push(c);
    });
    start[buckets] = items.length;
    this.grid.start = start;
    this.grid.items = Int32Array.from(items);
  }

  bucket(px, py, pz) {
    const g = this.grid;
    const at = (v, d) => Math.min(asUsize(fmax(Math.floor(v), 0.0)), d - 1);
    return [at((px - g.min[0]) / g.size[0], g.dims[0]), at((py - g.min[1]) / g.size[1], g.dims[1]), at((pz - g.min[2]) / g.size[2], g.dims[2])];
  }

  bucketIndex(x, y, z) {
    const d = this.grid.dims;
    return (x * d[1] + y) * d[2] + z;
  }

  markOverlaps() {
    const tol = this.tolerance;
    const g = this.grid;
    const flags = new Uint8Array(this.cellCount);
    for (let i = 0; i < this.cellCount; i++) {
      const lo = this.bucket(this.cellMin[3 * i], this.cellMin[3 * i + 1], this.cellMin[3 * i + 2]);
      const hi = this.bucket(this.cellMax[3 * i], this.cellMax[3 * i + 1], this.cellMax[3 * i + 2]);
      search: for (let x = lo[0]; x <= hi[0]; x++) {
        for (let y = lo[1]; y <= hi[1]; y++) {
          for (let z = lo[2]; z <= hi[2]; z++) {
            const b = this.bucketIndex(x, y, z);
            for (let t = g.start[b]; t < g.start[b + 1]; t++) {
              const j = g.items[t];
              let overlap = Infinity;
              const o = [0, 1, 2].map((a) => {
                const mx = this.cellMax[3 * i + a] < this.cellMax[3 * j + a] ? this.cellMax[3 * i + a] : this.cellMax[3 * j + a];
                const mn = this.cellMin[3 * i + a] > this.cellMin[3 * j + a] ? this.cellMin[3 * i + a] : this.cellMin[3 * j + a];
                return mx - mn;
              });
              overlap = o[0] < (o[1] < o[2] ? o[1] : o[2]) ? o[0] : o[1] < o[2] ? o[1] : o[2];
              if (j !== i && overlap > tol) {
                flags[i] = 1;
                break search;
              }
            }
          }
        }
      }
    }
    this.overlapped = flags;
  }

  /** How far p lies inside cell c: the least distance to its planes (negative outside). */
  margin(c, px, py, pz) {
    const P = this.planes;
    let m = Infinity;
    for (let k = this.planeStart[c]; k < this.planeStart[c + 1]; k++) {
      m = fmin(m, -(P[4 * k] * px + P[4 * k + 1] * py + P[4 * k + 2] * pz - P[4 * k + 3]));
    }
    return m;
  }

  /**
   * The cell holding `p`: `{kind: 'inside'|'boundary', cell}` or `{kind: 'outside', cell:
   * null, nearest}`. `hint` (last frame's cell) is tried first and wins ties on a boundary.
   */
  locate(p, hint = null) {
    const tol = this.tolerance;
    const [px, py, pz] = p;
    if (!(isIndex(hint) && hint < this.cellCount)) hint = null;
    if (hint !== null && !this.overlapped[hint] && this.margin(hint, px, py, pz) > tol) return located('inside', hint);
    let inside = null;
    let boundary = null;
    if (finite(px) && finite(py) && finite(pz)) {
      const g = this.grid;
      const [bx, by, bz] = this.bucket(px, py, pz);
      const b = this.bucketIndex(bx, by, bz);
      for (let t = g.start[b]; t < g.start[b + 1]; t++) {
        const c = g.items[t];
        const m = this.margin(c, px, py, pz);
        if (m > tol) {
          let smaller = inside === null;
          if (!smaller) {
            const pc = this.priority[c], pb = this.priority[inside];
            const vc = this.volume[c], vb = this.volume[inside];
            smaller = pc > pb || (pc === pb && (vc < vb || (vc === vb && c < inside)));
          }
          if (smaller) inside = c;
        } else if (m >= -tol) {
          const better = boundary === null || (boundary !== hint && (c === hint || c < boundary));
          if (better) boundary = c;
        }
      }
    }
    if (inside !== null) return located('inside', inside);
    if (boundary !== null) return located('boundary', boundary);
    const near = this.nearest(px, py, pz);
    return located('outside', null, near === null ? null : near[0]);
  }

  /** The cell nearest to p (exact distance to its faces) and that distance, ties to the lower
   * index: `[cell, distance]` or null. */
  nearest(px, py, pz) {
    if (!(finite(px) && finite(py) && finite(pz))) return null;
    let best = null;
    const P = this.planes;
    for (let i = 0; i < this.cellCount; i++) {
      let b2 = 0;
      for (let a = 0; a < 3; a++) {
        const p = [px, py, pz][a];
        const lo = this.cellMin[3 * i + a] - p, hi = p - this.cellMax[3 * i + a];
        let v = lo > hi ? lo : hi;
        v = v > 0.0 ? v : 0.0;
        b2 = a === 0 ? v * v : b2 + v * v;
      }
      const bound = Math.sqrt(b2);
      if (best !== null && bound >= best[1]) continue;
      let d = Infinity;
      for (let f = this.faceStart[i]; f < this.faceStart[i + 1]; f++) {
        const k = this.facePlane[f];
        const nx = P[4 * k], ny = P[4 * k + 1], nz = P[4 * k + 2];
        if (nx * px + ny * py + nz * pz - P[4 * k + 3] > 0.0) {
          const from = this.facePoints[f];
          d = fmin(d, distanceToPolygon(px, py, pz, this.points, from, this.facePoints[f + 1] - from, nx, ny, nz));
        }
      }
      if (d === Infinity) d = 0.0;
      if (best === null || d < best[1]) best = [i, d];
    }
    return best;
  }

  /** The cells a box `min`..`max` may reach into, ascending (`Level::cells_touching`). */
  cellsTouching(min, max) {
    const out = [];
    const tol = this.tolerance;
    if (![...min, ...max].every(finite)) return out;
    const lo = this.bucket(min[0] - tol, min[1] - tol, min[2] - tol);
    const hi = this.bucket(max[0] + tol, max[1] + tol, max[2] + tol);
    const g = this.grid;
    const P = this.planes;
    for (let x = lo[0]; x <= hi[0]; x++) {
      for (let y = lo[1]; y <= hi[1]; y++) {
        for (let z = lo[2]; z <= hi[2]; z++) {
          const b = this.bucketIndex(x, y, z);
          for (let t = g.start[b]; t < g.start[b + 1]; t++) {
            const c = g.items[t];
            let apart = false;
            for (let a = 0; a < 3; a++) {
              if (this.cellMin[3 * c + a] - tol > max[a] || this.cellMax[3 * c + a] + tol < min[a]) apart = true;
            }
            if (apart) continue;
            let touches = true;
            for (let k = this.planeStart[c]; k < this.planeStart[c + 1] && touches; k++) {
              const n = [P[4 * k], P[4 * k + 1], P[4 * k + 2]];
              const q = n.map((v, a) => (v >= 0.0 ? min[a] : max[a]));
              touches = n[0] * q[0] + n[1] * q[1] + n[2] * q[2] - P[4 * k + 3] <= tol;
            }
            if (touches) out.push(c);
          }
        }
      }
    }
    return [...new Set(out)].sort((p, q) => p - q);
  }

  // ---- accessors

  /** The name of the room cell `c` belongs to. */
  room(c) {
    return this.rooms[c];
  }

  /** The portal of the same opening seen from the other side, or null. */
  partner(p) {
    const q = this.portalPartner[p];
    return q === undefined || q < 0 ? null : q;
  }

  /** `[from, to]` of portal p (`to` null: the outside). */
  portalCells(p) {
    return [this.portalFrom[p], this.portalTo[p] < 0 ? null : this.portalTo[p]];
  }

  /** `plain`, `mirror` or `teleporter`. */
  kindOf(p) {
    return KIND_NAMES[this.portalKind[p]];
  }

  /** Whether cell c may see the outside (true when the file stores no PVS). */
  seesOutside(c) {
    return c >= 0 && c < this.cellCount ? this.outsideFlags[c] === 1 : true;
  }

  /** Whether the stored PVS lets cell `from` see cell `to` (true when none is stored). */
  pvsSees(from, to) {
    return this.pvs === null || this.pvs.sees(from, to);
  }

  // ---- trace.rs

  /**
   * Walks the portals from the camera's cell into `out` (whose last location is the hint for
   * this one). Doors closed in `doors` stop the walk.
   * @param {View} view
   * @param {Doors} [doors]
   * @param {{maxDepth?: number, maxTransformDepth?: number, usePvs?: boolean}} [opts]
   * @param {Trace} [out]
   * @returns {Trace}
   */
  trace(view, doors = new Doors(this), opts = DEFAULT_OPTIONS, out = new Trace()) {
    const o = { ...DEFAULT_OPTIONS, ...opts };
    const hint = out.location.cell;
    const outside = this.cellCount;
    out.reset(outside + 1);
    out.location = this.locate(view.eye, hint);
    const loc = out.location;
    const region = loc.kind === 'outside' ? outside : loc.cell;
    const cell = loc.kind === 'outside' ? null : loc.cell;
    const pvsRow = loc.kind === 'inside' && o.usePvs && this.pvs !== null ? loc.cell : null;
    out.camera = view;
    const [fx, fy, fz] = view.forward;
    const [ex, ey, ez] = view.eye;
    const P = out.planes;
    P[0] = -fx; P[1] = -fy; P[2] = -fz; P[3] = -(fx * ex + fy * ey + fz * ez) - view.near;
    out.planesLen = 4;
    const S = out.screen;
    S[0] = -1.0; S[1] = -1.0; S[2] = 1.0; S[3] = -1.0; S[4] = 1.0; S[5] = 1.0; S[6] = -1.0; S[7] = 1.0;
    out.screenLen = 8;
    const nearRadius = view.nearRadius();
    const reach = nearRadius + this.tolerance;
    out.outsideLinks.length = 0;
    for (let l = this.linkStart[outside]; l < this.linkStart[outside + 1]; l++) {
      const q = 4 * this.linkPortal[l];
      const s = this.linkReversed[l] ? -1 : 1;
      const PP = this.portalPlane;
      // -plane.dist(eye), the plane flipped when reversed.
      const dist = -((s * PP[q]) * ex + (s * PP[q + 1]) * ey + (s * PP[q + 2]) * ez - s * PP[q + 3]);
      if (dist >= -reach) out.outsideLinks.push(l);
    }
    const ctx = { view, doors, opts: o, pvsRow, nearRadius, tol: this.tolerance };
    this.walk(ctx, rootFrame(region, cell), out);
    if (loc.kind === 'outside') this.walkFromNearbyCells(ctx, loc.nearest, out);
    else if (loc.kind === 'boundary') this.walkFromOtherSides(ctx, loc.cell, out);
    return out;
  }

  /**
   * An eye on its cell's boundary stands on every cell whose boundary holds it (within the
   * tolerance): each is walked too, with the whole view, in the grid bucket's order (rule 15).
   */
  walkFromOtherSides(ctx, c, out) {
    const [ex, ey, ez] = ctx.view.eye;
    const tol = this.tolerance;
    const roots = [c];
    const g = this.grid;
    const [bx, by, bz] = this.bucket(ex, ey, ez);
    const b = this.bucketIndex(bx, by, bz);
    for (let t = g.start[b]; t < g.start[b + 1]; t++) {
      const k = g.items[t];
      if (roots.includes(k) || this.margin(k, ex, ey, ez) < -tol) continue;
      roots.push(k);
      this.walk(ctx, rootFrame(k, k), out);
    }
  }

  walkFromNearbyCells(ctx, nearest, out) {
    const [ex, ey, ez] = ctx.view.eye;
    const reach = ctx.nearRadius + ctx.tol;
    // The cells walked with the whole view: each once, though it may have been reached
    // already through a narrower opening (a window in the same wall, seen from outside).
    const roots = [];
    if (nearest !== null) {
      const nd = this.nearest(ex, ey, ez);
      if (nd !== null && nd[1] <= reach) {
        roots.push(nd[0]);
        this.walk(ctx, rootFrame(nd[0], nd[0]), out);
      }
    }
    const PP = this.portalPlane;
    for (let i = 0; i < this.portalCount; i++) {
      const to = this.portalTo[i];
      if (to < 0) continue;
      if (this.portalTransform[i] >= 0 || ctx.doors.isClosed(i)) continue;
      const partner = this.portalPartner[i];
      const back = partner >= 0 ? partner : i;
      const pn = [PP[4 * i], PP[4 * i + 1], PP[4 * i + 2]];
      const pd = PP[4 * i + 3];
      const depth = PP[4 * back] * ex + PP[4 * back + 1] * ey + PP[4 * back + 2] * ez - PP[4 * back + 3];
      const here = pn[0] * ex + pn[1] * ey + pn[2] * ez - pd;
      const doorway = partner >= 0 ? Math.abs(pd + PP[4 * back + 3]) : 0.0;
      const across = here >= -reach && depth >= -reach && fmax(here, depth) <= doorway + reach;
      if (!across) continue;
      const from = this.cornerStart[i];
      const d = distanceToPolygon(ex - pn[0] * here, ey - pn[1] * here, ez - pn[2] * here, this.corners, from, this.cornerStart[i + 1] - from, pn[0], pn[1], pn[2]);
      if (d <= reach) {
        for (const c of [this.portalFrom[i], to]) {
          if (!roots.includes(c)) {
            roots.push(c);
            this.walk(ctx, rootFrame(c, c), out);
          }
        }
      }
    }
  }

  walk(ctx, frame, out) {
    out.visit(frame);
    const convex = frame.draw === null && frame.cell !== null;
    if (convex) out.onPathCells[frame.region] += 1;
    const eye = ctx.view.eye;
    let eyeHere = eye;
    if (frame.draw !== null) {
      eyeHere = [0, 0, 0];
      transformPoint(frame.draw[1], eye[0], eye[1], eye[2], eyeHere, 0);
    }
    const region = frame.region;
    const kept = frame.draw === null && region === this.cellCount;
    if (kept) {
      // The list may not change while walked (it is only written by `trace`).
      const links = out.outsideLinks;
      for (let k = 0; k < links.length; k++) this.cross(ctx, frame, links[k], eyeHere, out);
    } else {
      const end = this.linkStart[region + 1];
      for (let l = this.linkStart[region]; l < end; l++) this.cross(ctx, frame, l, eyeHere, out);
    }
    if (convex) out.onPathCells[frame.region] -= 1;
  }

  cross(ctx, frame, link, eyeHere, out) {
    out.stats.portals_tested += 1;
    const portal = this.linkPortal[link];
    const reversed = this.linkReversed[link] === 1;
    if (ctx.doors.isClosed(portal)) {
      out.stats.closed_skipped += 1;
      return;
    }
    const PP = this.portalPlane;
    const s = reversed ? -1 : 1;
    const nx = PP[4 * portal] * s, ny = PP[4 * portal + 1] * s, nz = PP[4 * portal + 2] * s, pd = PP[4 * portal + 3] * s;
    const dist = -(nx * eyeHere[0] + ny * eyeHere[1] + nz * eyeHere[2] - pd);
    const reach = ctx.nearRadius + ctx.tol;
    if (dist < -reach) {
      out.stats.portals_culled += 1;
      return;
    }
    const from = this.cornerStart[portal];
    const count = this.cornerStart[portal + 1] - from;
    const standingIn = dist <= reach && distanceToPolygon(eyeHere[0], eyeHere[1], eyeHere[2], this.corners, from, count, nx, ny, nz) <= reach;
    if (dist < -ctx.tol && !standingIn) {
      out.stats.portals_culled += 1;
      return;
    }
    const t = this.portalTransform[portal];
    const transform = t >= 0 && !reversed ? this.transforms[t] : null;
    if (this.passedOver(ctx, frame, link, transform !== null, out)) return;
    let seen;
    if (standingIn) {
      out.stats.passed_through += 1;
      // A region already walked with this very view, untransformed and no deeper, is not
      // walked again (rule 11): passing through keeps the view.
      if (frame.draw === null && transform === null) {
        const t = this.linkTo[link];
        if (out.passedGen[t] === out.generation && out.passedView[t] === frame.viewStart && out.passedDepth[t] <= frame.depth) return;
        out.passedGen[t] = out.generation;
        out.passedView[t] = frame.viewStart;
        out.passedDepth[t] = frame.depth;
      }
      seen = [frame.viewStart, frame.viewEnd, frame.clipStart, frame.clipEnd, frame.rect];
    } else if (dist <= ctx.tol) {
      out.stats.portals_culled += 1;
      return;
    } else {
      seen = this.narrow(ctx, frame, from, count, transform !== null, out);
      if (seen === null) {
        out.stats.portals_culled += 1;
        return;
      }
    }
    this.descend(ctx, frame, link, transform, seen, out);
  }

  passedOver(ctx, frame, link, transformed, out) {
    const portal = this.linkPortal[link];
    const target = this.linkTo[link];
    const again = frame.draw === null && !transformed && target < out.onPathCells.length && out.onPathCells[target] > 0;
    if (!transformed && (again || out.onPath(portal))) {
      out.stats.on_path_skipped += 1;
      return true;
    }
    if (ctx.pvsRow !== null) {
      const untransformed = frame.draw === null && !transformed;
      if (untransformed && target < this.cellCount && !this.pvsSees(ctx.pvsRow, target)) {
        out.stats.pvs_skipped += 1;
        return true;
      }
    }
    if (frame.depth >= ctx.opts.maxDepth) {
      out.stats.depth_limit_hits += 1;
      return true;
    }
    if (transformed && frame.transforms >= ctx.opts.maxTransformDepth) {
      out.stats.transform_limit_hits += 1;
      return true;
    }
    return false;
  }

  descend(ctx, frame, link, transform, seen, out) {
    const target = this.linkTo[link];
    let draw = frame.draw;
    let mirrored = frame.mirrored;
    let transforms = frame.transforms;
    if (transform !== null) {
      const [m, inv] = transform;
      const [d, dInv] = frame.draw === null ? [IDENTITY, IDENTITY] : frame.draw;
      draw = [mulMat(d, inv), mulMat(m, dInv)];
      mirrored = frame.mirrored !== (determinant(m) < 0.0);
      transforms = frame.transforms + 1;
    }
    out.pathPortal.push(this.linkPortal[link]);
    out.pathTransformed.push(transform !== null);
    const child = {
      region: target,
      cell: target < this.cellCount ? target : null,
      viewStart: seen[0],
      viewEnd: seen[1],
      clipStart: seen[2],
      clipEnd: seen[3],
      rect: seen[4],
      depth: frame.depth + 1,
      transforms,
      draw,
      mirrored,
    };
    this.walk(ctx, child, out);
    out.pathPortal.pop();
    out.pathTransformed.pop();
  }

  /** The view through the portal's polygon (corners `from`.. of `count`), or null. */
  narrow(ctx, frame, from, count, transformed, out) {
    const view = ctx.view;
    const [ex, ey, ez] = view.eye;
    const tol = ctx.tol;
    let a = out.polyA;
    let b = out.polyB;
    const C = this.corners;
    if (frame.draw === null) {
      for (let k = 0; k < 3 * count; k++) a[k] = C[3 * from + k];
    } else {
      const d = frame.draw[0];
      for (let k = 0; k < count; k++) transformPoint(d, C[3 * (from + k)], C[3 * (from + k) + 1], C[3 * (from + k) + 2], a, 3 * k);
    }
    let na = count;
    let surface = null;
    if (transformed) {
      let sx = 0, sy = 0, sz = 0;
      for (let k = 0; k < na; k++) {
        sx = sx + a[3 * k]; sy = sy + a[3 * k + 1]; sz = sz + a[3 * k + 2];
      }
      const h = through(sx / na, sy / na, sz / na, newell(a, 0, na));
      if (h !== null) surface = h[0] * ex + h[1] * ey + h[2] * ez - h[3] < 0.0 ? [-h[0], -h[1], -h[2], -h[3]] : h;
    }
    const P = out.planes;
    for (let i = frame.clipStart; i < frame.clipEnd; i++) {
      const hx = P[4 * i], hy = P[4 * i + 1], hz = P[4 * i + 2], hd = P[4 * i + 3];
      let cuts = false;
      for (let k = 0; k < na; k++) {
        if (!(hx * a[3 * k] + hy * a[3 * k + 1] + hz * a[3 * k + 2] - hd <= tol)) {
          cuts = true;
          break;
        }
      }
      if (!cuts) continue;
      na = clip3(a, na, hx, hy, hz, hd, tol, b);
      const sw = a; a = b; b = sw;
      if (na < 3) break;
    }
    let result = null;
    if (na >= 3) {
      let f = out.flatA;
      let g = out.flatB;
      const [fx, fy, fz] = view.forward;
      const [rx, ry, rz] = view.right;
      const [ux, uy, uz] = view.up;
      const halfNear = view.near * 0.5;
      for (let k = 0; k < na; k++) {
        const vx = a[3 * k] - ex, vy = a[3 * k + 1] - ey, vz = a[3 * k + 2] - ez;
        const z = fmax(vx * fx + vy * fy + vz * fz, halfNear);
        f[2 * k] = (vx * rx + vy * ry + vz * rz) / (z * view.tanX);
        f[2 * k + 1] = (vx * ux + vy * uy + vz * uz) / (z * view.tanY);
      }
      const clipped = this.clipScreen(frame, f, g, na, out);
      if (clipped !== null) {
        const [poly, n, rect] = clipped;
        const S = out.screen;
        let at = out.screenLen;
        const start = at / 2;
        for (let k = 0; k < 2 * n; k++) S[at++] = poly[k];
        out.screenLen = at;
        const end = at / 2;
        let cs = frame.clipStart, ce = frame.clipEnd;
        if (surface !== null) {
          let at4 = out.planesLen;
          cs = at4 / 4;
          for (let i = 4 * frame.clipStart; i < 4 * frame.clipEnd; i++) P[at4++] = P[i];
          for (let k = 0; k < 4; k++) P[at4++] = surface[k];
          out.planesLen = at4;
          ce = at4 / 4;
        }
        result = [start, end, cs, ce, rect];
      }
    }
    return result;
  }

  /** The projected portal (`n` points of `f`; scratch `g`) cut to the frame's screen polygon,
   * counter-clockwise, with its rectangle: `[points, count, rect]` or null. */
  clipScreen(frame, f, g, n, out) {
    const EPS = 1e-9;
    const p = frame.rect;
    let lo0 = Infinity, lo1 = Infinity, hi0 = -Infinity, hi1 = -Infinity;
    for (let k = 0; k < n; k++) {
      // As f64::min and max: a NaN never replaces the bound (nor does it here).
      const x = f[2 * k], y = f[2 * k + 1];
      if (x < lo0) lo0 = x;
      if (y < lo1) lo1 = y;
      if (x > hi0) hi0 = x;
      if (y > hi1) hi1 = y;
    }
    if (lo0 > p[2] + EPS || hi0 < p[0] - EPS || lo1 > p[3] + EPS || hi1 < p[1] - EPS) return null;
    if (area2(f, n) < 0.0) {
      for (let i = 0, j = n - 1; i < j; i++, j--) {
        const x = f[2 * i], y = f[2 * i + 1];
        f[2 * i] = f[2 * j]; f[2 * i + 1] = f[2 * j + 1];
        f[2 * j] = x; f[2 * j + 1] = y;
      }
    }
    const S = out.screen;
    const ps = frame.viewStart;
    const pn = frame.viewEnd - ps;
    for (let k = 0; k < pn; k++) {
      const ia = ps + k, ib = ps + ((k + 1) % pn);
      const ax = S[2 * ia], ay = S[2 * ia + 1], bx = S[2 * ib], by = S[2 * ib + 1];
      let inside = true;
      for (let q = 0; q < n; q++) {
        if (!(cross2(ax, ay, bx, by, f[2 * q], f[2 * q + 1]) >= -EPS)) {
          inside = false;
          break;
        }
      }
      if (inside) continue;
      n = clip2(f, n, ax, ay, bx, by, EPS, g);
      const sw = f; f = g; g = sw;
      if (n < 3) return null;
    }
    const PINCH = 1e-6;
    if (area2(f, n) <= PINCH * perimeter2(f, n)) return null;
    lo0 = Infinity; lo1 = Infinity; hi0 = -Infinity; hi1 = -Infinity;
    for (let k = 0; k < n; k++) {
      // As f64::min and max: a NaN never replaces the bound (nor does it here).
      const x = f[2 * k], y = f[2 * k + 1];
      if (x < lo0) lo0 = x;
      if (y < lo1) lo1 = y;
      if (x > hi0) hi0 = x;
      if (y > hi1) hi1 = y;
    }
    const rect = [fmax(lo0, p[0]), fmax(lo1, p[1]), fmin(hi0, p[2]), fmin(hi1, p[3])];
    return rect[0] <= rect[2] && rect[1] <= rect[3] ? [f, n, rect] : null;
  }

  // ---- draw.rs

  /**
   * What cells `cells` draw: `{nodes, ranges}`, the glTF nodes drawn whole (ascending, each
   * once) and the ranges `{node, primitive, first, count}` of the split primitives (indices of
   * the accessor `splitIndices`), ranges that overlap or meet joined. Cells out of range are
   * skipped.
   */
  drawList(cells) {
    const nodes = new Set();
    const scratch = [];
    for (const c of cells) {
      const w = this.whole[c];
      const r = this.ranges[c];
      if (w !== undefined && r !== undefined) {
        for (const n of w) nodes.add(n);
        for (const x of r) scratch.push(x);
      }
    }
    scratch.sort((x, y) => x[0] - y[0] || x[1] - y[1] || x[2] - y[2]);
    const ranges = [];
    const push = (j) => {
      const p = this.splitPrimitives[j[0]];
      ranges.push({ node: p.node, primitive: p.primitive, first: j[1], count: j[2] });
    };
    let joined = null;
    for (const [k, first, count] of scratch) {
      if (joined !== null && joined[0] === k && first <= joined[1] + joined[2]) {
        joined[2] = Math.max(joined[2], first + count - joined[1]);
      } else {
        if (joined !== null) push(joined);
        joined = [k, first, count];
      }
    }
    if (joined !== null) push(joined);
    return { nodes: [...nodes].sort((x, y) => x - y), ranges };
  }

  /** Cell c's `nodes` as the file lists them. */
  nodesOf(c) {
    return this.listed[c] || [];
  }
}

function rootFrame(region, cell) {
  return {
    region,
    cell,
    viewStart: 0,
    viewEnd: 4,
    clipStart: 0,
    clipEnd: 1,
    rect: [-1.0, -1.0, 1.0, 1.0],
    depth: 0,
    transforms: 0,
    draw: null,
    mirrored: false,
  };
}

/** One traced camera as `portcullis cull --format json` prints it. */
export function report(trace) {
  const visible = trace.visible.map((v) => {
    const o = { cell: v.cell, rect: v.rect.map(round9), depth: v.depth, via: v.via.slice() };
    if (v.transform !== null) o.transform = v.transform.map(round9);
    o.mirrored = v.mirrored;
    return o;
  });
  const loc = trace.location;
  const o = { cell: loc.cell, location: loc.kind };
  if (loc.kind === 'outside') o.nearest = loc.nearest;
  o.visible = visible;
  o.stats = { ...trace.stats };
  return o;
}
