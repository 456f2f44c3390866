// Camera sets for comparing the JavaScript runtime with `portcullis cull`: every cell's centre
// with four looks, random eyes from a seeded PRNG, eyes on and beside portal planes (on their
// corners and edges too), on cell walls, just outside walls, and outside every cell.

/** mulberry32: a small seeded PRNG, uniform in [0, 1). */
export function prng(seed) {
  let a = seed >>> 0;
  return () => {
    a = (a + 0x6d2b79f5) >>> 0;
    let t = a;
    t = Math.imul(t ^ (t >>> 15), t | 1);
    t ^= t + Math.imul(t ^ (t >>> 7), t | 61);
    return ((t ^ (t >>> 14)) >>> 0) / 4294967296;
  };
}

const LOOKS = [
  [1, 0, 0],
  [0, 0, 1],
  [-1, 0, 0],
  [0, -0.3, -1],
];

function unitRandom(rand) {
  for (;;) {
    const v = [rand() * 2 - 1, rand() * 2 - 1, rand() * 2 - 1];
    const l = Math.hypot(...v);
    if (l > 0.05 && l <= 1 && Math.abs(v[1] / l) < 0.98) return v.map((x) => x / l);
  }
}

function camera(rand, eye, look, random = true) {
  const c = { eye, look };
  if (random) {
    // Mostly the defaults; sometimes another lens.
    const r = rand();
    if (r < 0.25) c.fov_y = 20 + rand() * 130;
    if (r > 0.5 && r < 0.75) c.aspect = 0.4 + rand() * 2.6;
    if (r > 0.6 && r < 0.9) c.near = [0.001, 0.01, 0.1, 0.3, 1][Math.floor(rand() * 5)];
    if (r > 0.95) c.up = unitRandom(rand);
  }
  return c;
}

/**
 * Cameras for `level` (a runtime Level): `count` random eyes on top of the cell centres.
 * Returns objects for a cameras file.
 */
export function cameras(level, { seed = 1, random = 200 } = {}) {
  const rand = prng(seed);
  const out = [];
  const n = level.cellCount;
  const lo = [Infinity, Infinity, Infinity];
  const hi = [-Infinity, -Infinity, -Infinity];
  for (let c = 0; c < n; c++) {
    for (let a = 0; a < 3; a++) {
      lo[a] = Math.min(lo[a], level.cellMin[3 * c + a]);
      hi[a] = Math.max(hi[a], level.cellMax[3 * c + a]);
    }
  }
  const size = Math.max(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2], 1e-3);
  // Cell centres (of their bounds), four looks each, the default lens.
  for (let c = 0; c < n; c++) {
    const eye = [0, 1, 2].map((a) => (level.cellMin[3 * c + a] + level.cellMax[3 * c + a]) / 2);
    for (const look of LOOKS) out.push({ eye, look });
  }
  const pick = (k) => Math.floor(rand() * k);
  for (let i = 0; i < random; i++) {
    const kind = i % 8;
    let eye;
    let look = unitRandom(rand);
    if (kind <= 1 || level.portalCount === 0) {
      // Anywhere in (or a little beyond) the level's bounds.
      eye = [0, 1, 2].map((a) => lo[a] - 0.1 * size + rand() * (hi[a] - lo[a] + 0.2 * size));
    } else if (kind <= 4) {
      // On or beside a portal's plane: inside the polygon, on an edge or a corner.
      const p = pick(level.portalCount);
      const s = level.cornerStart[p];
      const m = level.cornerStart[p + 1] - s;
      const corner = (k) => [0, 1, 2].map((a) => level.corners[3 * (s + (k % m)) + a]);
      const how = rand();
      let at;
      if (how < 0.5) {
        const w = Array.from({ length: m }, () => rand());
        const t = w.reduce((x, y) => x + y, 0);
        at = [0, 1, 2].map((a) => w.reduce((acc, wk, k) => acc + (wk / t) * corner(k)[a], 0));
      } else if (how < 0.8) {
        const k = pick(m);
        const t = rand();
        at = [0, 1, 2].map((a) => corner(k)[a] + (corner(k + 1)[a] - corner(k)[a]) * t);
      } else {
        at = corner(pick(m));
      }
      const nrm = [0, 1, 2].map((a) => level.portalPlane[4 * p + a]);
      const off = [0, 0, 0, 1e-7, -1e-7, 1e-3, -1e-3, 0.025, -0.025, 0.1, -0.1, level.tolerance, -level.tolerance][pick(13)];
      eye = at.map((v, a) => v + nrm[a] * off);
      const r = rand();
      if (r < 0.35) look = nrm.map((v) => -v + (rand() - 0.5) * 0.4);
      else if (r < 0.5) look = nrm.map((v) => v + (rand() - 0.5) * 0.4);
      if (Math.hypot(...look) < 1e-3 || Math.abs(look[1]) / Math.hypot(...look) > 0.98) look = unitRandom(rand);
    } else if (kind <= 6) {
      // On a cell's wall, or just beyond it (in the wall, or outside every cell).
      const c = pick(n);
      const ps = level.planeStart[c];
      const k = ps + pick(level.planeStart[c + 1] - ps);
      const centre = [0, 1, 2].map((a) => (level.cellMin[3 * c + a] + level.cellMax[3 * c + a]) / 2);
      const nrm = [0, 1, 2].map((a) => level.planes[4 * k + a]);
      const dist = nrm[0] * centre[0] + nrm[1] * centre[1] + nrm[2] * centre[2] - level.planes[4 * k + 3];
      const jitter = [0, 1, 2].map((a) => (rand() - 0.5) * 0.5 * (level.cellMax[3 * c + a] - level.cellMin[3 * c + a]));
      const onPlane = centre.map((v, a) => v + jitter[a] - nrm[a] * (dist + (nrm[0] * jitter[0] + nrm[1] * jitter[1] + nrm[2] * jitter[2])));
      const off = [0, 0, 1e-6, 1e-3, 0.02, 0.06, 0.2, -1e-3][pick(8)];
      eye = onPlane.map((v, a) => v + nrm[a] * off);
      if (rand() < 0.5) look = nrm.map((v) => -v + (rand() - 0.5));
      if (Math.hypot(...look) < 1e-3 || Math.abs(look[1]) / Math.hypot(...look) > 0.98) look = unitRandom(rand);
    } else {
      // Far outside every cell, looking back at the level.
      const dir = unitRandom(rand);
      const mid = [0, 1, 2].map((a) => (lo[a] + hi[a]) / 2);
      eye = mid.map((v, a) => v + dir[a] * size * (0.8 + rand()));
      look = mid.map((v, a) => v - eye[a] + (rand() - 0.5) * size * 0.3);
      if (Math.abs(look[1]) / Math.hypot(...look) > 0.98) look = unitRandom(rand);
    }
    out.push(camera(rand, eye, look));
  }
  return out;
}

export function camerasText(list) {
  return list.map((c) => JSON.stringify(c)).join('\n') + '\n';
}
