// The plugin in a real browser: Freedoom's MAP01, converted with `--tags doom`, loaded by three's
// GLTFLoader with PortcullisLoaderPlugin in headless Chromium (Debian's, driven by playwright-core
// as tests/viewer.rs does, WebGL through SwiftShader), and drawn from 20 fixed cameras twice:
// with everything the cells draw shown (no culling) and after `update(camera)`. The two frames
// must be identical pixel for pixel (culling hides nothing that is seen), and the triangles
// three.js submits with culling must be at most half of those without, over the 20 frames.
//
// Pixels seen behind the back of a surface are counted apart and explained (what shows there,
// which cells draw it, the surface it is seen behind): culling by portals takes every cell
// boundary that is not a portal as opaque, and a single-sided renderer does not draw a surface
// from behind, so a camera that sees the outside could see the level's surfaces from behind
// there. MAP01 has such a place (Doom's sky hack: a lower sky sector whose sky ceiling, single-
// sided and facing down, is seen from above through the opening over it); the doom preset
// reads the sky flat as the open sky (`sky` in the preset), so that ceiling is an opening the
// outside sees in through. Those pixels, too, must be the same.
//
// Served from a local http server (node:http) on 127.0.0.1: the page, the converted level, this
// package's modules and node_modules/three (through an import map). Without chromium,
// playwright-core (scripts/test.sh installs both) or the portcullis binary the tests are
// skipped, and fail under CI=true; without ../shared/levels/freedoom they are skipped.

import assert from 'node:assert/strict';
import { existsSync, readFileSync, statSync } from 'node:fs';
import { createServer } from 'node:http';
import { createRequire } from 'node:module';
import { extname, join, normalize, sep } from 'node:path';
import { test } from 'node:test';

import { MAP01, PACKAGE, REPO, binary, convert, tempDir } from './helpers.js';

const FRAMES = 20;
const WIDTH = 320;
const HEIGHT = 180;

const PLAYWRIGHT = join(REPO, 'tools/browser-test/node_modules/playwright-core');
const CHROMIUM = process.env.CHROMIUM || '/usr/bin/chromium';
const THREE = join(PACKAGE, 'node_modules/three');

/** Why the tests cannot run (a failure under CI), or null. */
function missing() {
  if (binary() === null) return 'no portcullis binary in target/release or target/debug (cargo build --release, or set PORTCULLIS)';
  if (!existsSync(PLAYWRIGHT)) return `no playwright-core in ${PLAYWRIGHT} (scripts/test.sh installs it)`;
  if (!existsSync(CHROMIUM)) return `no chromium at ${CHROMIUM} (scripts/test.sh installs Debian's; or set CHROMIUM)`;
  if (!existsSync(THREE)) return 'no three in node_modules (npm ci)';
  return null;
}

// The page. Each camera's frame is drawn with `showAll()` (every whole node shown, each split
// primitive's geometry given one group over its whole split range: everything the level's
// cells draw, as without the plugin), then after `update(camera)`, then with `showAll()` again
// (the same frame twice, or the renderer is not deterministic); each time the pixels are read
// back (gl.readPixels, preserveDrawingBuffer) and the triangles three.js drew are counted.
//
// Why identical pixels are the right requirement, not a tolerance. The material is one unlit
// ShaderMaterial (scene.overrideMaterial; the level's materials are all opaque and front-sided,
// as it is, which the test checks) whose colour is a function of the surface's world position
// and facing, so any change of which surface is seen at a pixel shows, and no light, texture
// filtering or blending enters. Both frames use the same geometries (the plugin's split
// geometries, also in the unculled frame), so culling only removes draws: three.js sorts opaque
// render items by groupOrder, renderOrder, material id, z (the distance to the object's
// bounding sphere, the same in both frames since the camera is) and id, all unchanged, and a
// split mesh draws its groups in order, the culled ones being increasing sub-ranges of the
// unculled one's single range (Level#drawList sorts and joins them). So the culled frame
// submits a subsequence, in the same order, of the unculled frame's triangles, each rasterized
// the same (same vertices, same matrices). With the depth test LESS the fragment kept at a
// pixel is the first drawn among those of least depth, so coplanar faces at a depth tie
// resolve the same in both frames: removing draws that are not the winner cannot change a
// pixel, and a pixel changes only if its winning fragment belongs to a draw culling removed,
// that is, something seen was hidden. (LESS-EQUAL, three's default, would keep the last drawn
// of a tie and the argument would hold as well; the depth function is set so as not to rest on
// a default.)
//
// The pixels seen behind a surface: a third draw of the unculled frame with a material drawn
// on both sides that writes only whether the nearest surface faces the camera. Where it does
// not, the frame shows what is behind that surface's back.
const PAGE = `<!doctype html>
<html><head><meta charset="utf-8"><title>portcullis-three browser test</title><link rel="icon" href="data:,">
<script type="importmap">
{ "imports": { "three": "/three/build/three.module.js", "three/addons/": "/three/examples/jsm/" } }
</script>
<style>html,body{margin:0;background:#000}canvas{display:block}</style></head>
<body><script type="module">
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { PortcullisLoaderPlugin } from '/pkg/index.js';

const W = ${WIDTH}, H = ${HEIGHT}, FRAMES = ${FRAMES};
try {
  const renderer = new THREE.WebGLRenderer({ antialias: false, preserveDrawingBuffer: true, alpha: false });
  renderer.setPixelRatio(1);
  renderer.setSize(W, H);
  renderer.setClearColor(0xff00ff, 1);
  document.body.appendChild(renderer.domElement);
  const gl = renderer.getContext();

  const loader = new GLTFLoader().register((parser) => new PortcullisLoaderPlugin(parser));
  const gltf = await loader.loadAsync('/level.glb');
  const scene = new THREE.Scene();
  scene.add(gltf.scene);
  scene.updateMatrixWorld(true);
  const p = gltf.userData.portcullis;
  const level = p.level;

  // The level's own materials, to check that one front-sided opaque override stands for them.
  const materials = new Set();
  gltf.scene.traverse((o) => { if (o.isMesh) for (const m of [].concat(o.material)) materials.add(m); });
  const kind = (m) => [m.transparent ? 'transparent' : 'opaque', m.side === THREE.FrontSide ? 'front' : 'side ' + m.side, m.alphaTest > 0 ? 'alphaTest' : '', m.visible ? '' : 'invisible'].filter(Boolean).join('/');
  const materialKinds = [...new Set([...materials].map(kind))].sort();

  const vertexShader = 'varying vec3 vWorld; void main() { vec4 w = modelMatrix * vec4(position, 1.0); vWorld = w.xyz; gl_Position = projectionMatrix * viewMatrix * w; }';
  const unlit = new THREE.ShaderMaterial({
    side: THREE.FrontSide,
    depthFunc: THREE.LessDepth,
    vertexShader,
    fragmentShader: 'varying vec3 vWorld; void main() { vec3 n = normalize(cross(dFdx(vWorld), dFdy(vWorld))); gl_FragColor = vec4(0.65 * fract(vWorld * vec3(0.29, 0.41, 0.37)) + 0.35 * (0.5 + 0.5 * n), 1.0); }',
  });
  const facing = new THREE.ShaderMaterial({
    side: THREE.DoubleSide,
    depthFunc: THREE.LessDepth,
    vertexShader,
    fragmentShader: 'void main() { gl_FragColor = gl_FrontFacing ? vec4(0.0, 0.0, 0.0, 1.0) : vec4(1.0, 1.0, 1.0, 1.0); }',
  });

  // 20 cameras: the centres of 20 cells spread evenly over the cells' indices, looking along
  // +X, +Z, -X, -Z in turn; 75 degrees x 16:9, near 0.05, far past the whole level.
  const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
  for (let c = 0; c < level.cellCount; c++) for (let a = 0; a < 3; a++) {
    lo[a] = Math.min(lo[a], level.cellMin[3 * c + a]);
    hi[a] = Math.max(hi[a], level.cellMax[3 * c + a]);
  }
  const far = 2 * Math.hypot(hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]) + 1;
  const looks = [[1, 0, 0], [0, 0, 1], [-1, 0, 0], [0, 0, -1]];
  const cameras = [];
  for (let i = 0; i < FRAMES; i++) {
    const cell = Math.floor(((i + 0.5) * level.cellCount) / FRAMES);
    const eye = [0, 1, 2].map((a) => (level.cellMin[3 * cell + a] + level.cellMax[3 * cell + a]) / 2);
    cameras.push({ cell, eye, look: looks[i % 4] });
  }
  const camera = new THREE.PerspectiveCamera(75, 16 / 9, 0.05, far);
  const place = (i) => {
    const { eye, look } = cameras[i];
    camera.position.set(eye[0], eye[1], eye[2]);
    camera.up.set(0, 1, 0);
    camera.lookAt(eye[0] + look[0], eye[1] + look[1], eye[2] + look[2]);
    camera.updateMatrixWorld();
  };

  const draw = (material) => {
    scene.overrideMaterial = material;
    renderer.render(scene, camera);
    const pixels = new Uint8Array(W * H * 4);
    gl.readPixels(0, 0, W, H, gl.RGBA, gl.UNSIGNED_BYTE, pixels);
    return { triangles: renderer.info.render.triangles, calls: renderer.info.render.calls, pixels };
  };
  const same = (a, b, k) => a[4 * k] === b[4 * k] && a[4 * k + 1] === b[4 * k + 1] && a[4 * k + 2] === b[4 * k + 2] && a[4 * k + 3] === b[4 * k + 3];
  // [x, y] from the top left of five pixels spread over the list (of readPixels indices).
  const spread = (list) => {
    const n = Math.min(5, list.length);
    return Array.from({ length: n }, (_, s) => list[Math.floor((s * list.length) / n)]).map((k) => [k % W, H - 1 - Math.floor(k / W)]);
  };

  window.frame = (i) => {
    place(i);
    p.showAll();
    const all = draw(unlit);
    const back = draw(facing).pixels;
    const trace = p.update(camera);
    const culled = draw(unlit);
    p.showAll();
    const again = draw(unlit);
    const differ = { front: [], back: [] };
    let repeatDiffer = 0, drawn = 0, behind = 0;
    for (let k = 0; k < W * H; k++) {
      const seenBehind = back[4 * k] === 255 && back[4 * k + 1] === 255;
      if (seenBehind) behind++;
      if (!(all.pixels[4 * k] === 255 && all.pixels[4 * k + 1] === 0 && all.pixels[4 * k + 2] === 255)) drawn++;
      if (!same(all.pixels, again.pixels, k)) repeatDiffer++;
      if (!same(all.pixels, culled.pixels, k)) differ[seenBehind ? 'back' : 'front'].push(k);
    }
    return {
      i, cell: cameras[i].cell, eye: cameras[i].eye, look: cameras[i].look, camera: p.lastCamera,
      location: trace.location,
      visibleCells: trace.visible.filter((v) => v.transform === null && v.cell !== null).length,
      outside: trace.visible.some((v) => v.cell === null),
      trianglesAll: all.triangles, trianglesCulled: culled.triangles, callsAll: all.calls, callsCulled: culled.calls,
      differFront: differ.front.length, differBack: differ.back.length,
      whereFront: spread(differ.front), whereBack: spread(differ.back),
      repeatDiffer, drawn, behind,
    };
  };

  // What pixels of camera i's unculled frame show, for the report: a ray through each pixel's
  // centre (three's Raycaster, which follows geometry groups and material sides) gives the
  // mesh, its glTF node, the triangle and the cells whose draw lists hold it (seen or not by
  // the trace, in the PVS row of the eye's cell or not); the same ray with every surface
  // two-sided gives the surface the pixel is seen behind, when it is.
  const nodeOf = new Map();
  for (const [n, list] of p.primitiveObjects) for (const { object } of list) nodeOf.set(object, n);
  const splitOf = new Map(p.splitObjects.map((s) => [s.object, s.key]));
  const raycaster = new THREE.Raycaster();
  const describe = (hit, seen, from) => {
    const node = nodeOf.get(hit.object);
    const key = splitOf.get(hit.object);
    const cells = [];
    if (key !== undefined) {
      const k = level.splitPrimitives.findIndex((q) => q.node + '/' + q.primitive === key);
      const at = 3 * hit.faceIndex;
      for (let c = 0; c < level.cellCount; c++) if (level.ranges[c].some(([j, first, count]) => j === k && first <= at && at < first + count)) cells.push(c);
    } else {
      for (let c = 0; c < level.cellCount; c++) if (level.whole[c].includes(node)) cells.push(c);
    }
    return {
      object: hit.object.name, node, triangle: hit.faceIndex, point: hit.point.toArray().map((v) => +v.toFixed(3)), distance: +hit.distance.toFixed(3),
      cells: cells.map((c) => ({ cell: c, room: level.room(c), seen: seen.has(c), pvs: from === null ? null : level.pvsSees(from, c) })),
    };
  };
  window.explain = (i, points) => {
    place(i);
    const trace = p.update(camera);
    const seen = new Set(trace.visible.filter((v) => v.transform === null && v.cell !== null).map((v) => v.cell));
    const from = trace.location.cell;
    p.showAll();
    const sides = new Map();
    return points.map(([x, y]) => {
      raycaster.setFromCamera(new THREE.Vector2(((x + 0.5) / W) * 2 - 1, 1 - ((y + 0.5) / H) * 2), camera);
      const hit = raycaster.intersectObject(scene, true).find((h) => h.object.visible);
      for (const m of materials) { sides.set(m, m.side); m.side = THREE.DoubleSide; }
      const near = raycaster.intersectObject(scene, true).find((h) => h.object.visible);
      for (const [m, s] of sides) m.side = s;
      const behind = near && hit && near.distance < hit.distance - 1e-6 ? describe(near, seen, from) : null;
      return { x, y, shows: hit ? describe(hit, seen, from) : null, behind };
    });
  };

  window.ready = {
    cells: level.cellCount, cameras: cameras.length, materials: materials.size, materialKinds,
    splitObjects: p.splitObjects.length, wholeObjects: p.wholeObjects.length,
    gl: gl.getParameter(gl.VERSION) + ', ' + (gl.getExtension('WEBGL_debug_renderer_info') ? gl.getParameter(gl.getExtension('WEBGL_debug_renderer_info').UNMASKED_RENDERER_WEBGL) : gl.getParameter(gl.RENDERER)),
  };
} catch (e) {
  window.failed = String((e && e.stack) || e);
}
</script></body></html>
`;

const TYPES = { '.js': 'text/javascript', '.glb': 'model/gltf-binary' };

/** Serves the page at /, the level at /level.glb, /pkg/NAME.js from this package and /three/
 * from node_modules/three; anything else is a 404 (and a failure). */
function serve(levelFile, misses) {
  const server = createServer((req, res) => {
    const path = decodeURIComponent(new URL(req.url, 'http://localhost').pathname);
    let file = null;
    if (path === '/level.glb') file = levelFile;
    else if (/^\/pkg\/[A-Za-z0-9_-]+\.js$/.test(path)) file = join(PACKAGE, path.slice(5));
    else if (path.startsWith('/three/')) {
      const f = normalize(join(THREE, path.slice(7)));
      if (f.startsWith(THREE + sep)) file = f;
    }
    if (path === '/') {
      res.writeHead(200, { 'content-type': 'text/html; charset=utf-8', 'cache-control': 'no-store' }).end(PAGE);
    } else if (file !== null && existsSync(file) && statSync(file).isFile()) {
      res.writeHead(200, { 'content-type': TYPES[extname(file)] || 'application/octet-stream', 'cache-control': 'no-store' }).end(readFileSync(file));
    } else {
      misses.push(path);
      res.writeHead(404).end();
    }
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

/** Converts MAP01, opens the page and draws every camera's frames (once, for both tests). */
async function render() {
  const dir = tempDir();
  const level = join(dir, 'map01.glb');
  assert.ok(convert(MAP01, level, ['--tags', 'doom']), 'MAP01 converts with --tags doom');
  const { chromium } = createRequire(join(PLAYWRIGHT, 'package.json'))('playwright-core');
  const misses = [];
  const errors = [];
  const server = await serve(level, misses);
  const browser = await chromium.launch({
    executablePath: CHROMIUM,
    headless: true,
    args: [
      '--no-sandbox', '--disable-gpu', '--use-angle=swiftshader', '--enable-unsafe-swiftshader',
      '--disable-quic', '--no-first-run', '--disable-background-networking',
      '--disable-component-update', '--disable-sync',
    ],
  });
  try {
    const page = await browser.newPage({ viewport: { width: WIDTH, height: HEIGHT }, deviceScaleFactor: 1 });
    page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    page.on('pageerror', (e) => errors.push(String(e)));
    await page.goto(`http://127.0.0.1:${server.address().port}/`);
    await page.waitForFunction(() => window.ready || window.failed, null, { timeout: 30000 });
    const failed = await page.evaluate(() => window.failed || null);
    assert.equal(failed, null, 'the page loads the level');
    const info = await page.evaluate(() => window.ready);
    const frames = [];
    for (let i = 0; i < info.cameras; i++) {
      const f = await page.evaluate((i) => window.frame(i), i);
      // Explain a differing frame by a few of its pixels of each kind.
      f.explained = f.differFront + f.differBack === 0 ? [] : await page.evaluate(([i, w]) => window.explain(i, w), [i, [...f.whereFront, ...f.whereBack.slice(0, 2)]]);
      frames.push(f);
    }
    return { info, frames, errors, misses };
  } finally {
    await browser.close();
    await new Promise((r) => server.close(r));
  }
}

let rendered = null;
const frames = () => (rendered ??= render());

const why = missing();
const skip = why !== null && process.env.CI !== 'true' ? why : !existsSync(MAP01) ? `${MAP01} is missing (../shared/levels/freedoom)` : false;
const options = { skip, timeout: 60000 };
const pixelsOf = (f) => `${f.differFront + f.differBack} pixels differ (${f.differBack} of them seen behind the back of a surface)`;

test('in Chromium, culling leaves MAP01 from 20 cameras pixel for pixel the same, with at most half the triangles', options, async (t) => {
  // Under CI a missing browser or binary is a failure, elsewhere the test is skipped (above).
  if (why !== null) assert.fail(`CI=true but the browser test cannot run: ${why}`);
  const { info, frames: list, errors, misses } = await frames();
  t.diagnostic(`${info.gl}; ${info.cells} cells, ${info.wholeObjects} whole-node meshes, ${info.splitObjects} split primitives, ${info.materials} materials (${info.materialKinds.join(', ')})`);
  assert.deepEqual(info.materialKinds, ['opaque/front'], "the level's materials are opaque and front-sided, as the override");
  let all = 0;
  let culled = 0;
  const bad = [];
  for (const f of list) {
    all += f.trianglesAll;
    culled += f.trianglesCulled;
    const at = f.location.kind === 'outside' ? 'outside the cells' : `${f.location.kind} cell ${f.location.cell}`;
    t.diagnostic(`camera ${f.i}: cell ${f.cell}'s centre [${f.eye.map((x) => +x.toFixed(3))}] looking [${f.look}], ${at}, ${f.visibleCells} cells seen${f.outside ? ' and the outside' : ''}: ` +
      `triangles ${f.trianglesAll} -> ${f.trianglesCulled}, draw calls ${f.callsAll} -> ${f.callsCulled}, ${pixelsOf(f)}; ${f.drawn} of ${WIDTH * HEIGHT} pixels drawn, ${f.behind} seen behind a surface`);
    for (const e of f.explained) t.diagnostic(`  camera ${f.i} pixel ${JSON.stringify(e)}`);
    if (f.repeatDiffer !== 0) bad.push(`camera ${f.i}: the unculled frame drawn twice differs in ${f.repeatDiffer} pixels (the renderer is not deterministic)`);
    // What is seen behind a surface is seen from outside the cells: say whether the trace saw it.
    if (f.differBack !== 0) bad.push(`camera ${f.i} ${JSON.stringify(f.camera)}: ${pixelsOf(f)}, e.g. [x, y] ${JSON.stringify(f.whereBack)}: culling hid something seen behind a surface${f.outside ? '' : ', and the trace does not see the outside'}`);
    if (f.differFront !== 0) bad.push(`camera ${f.i} ${JSON.stringify(f.camera)}: ${pixelsOf(f)}, e.g. [x, y] ${JSON.stringify(f.whereFront)}: culling hid something seen`);
    assert.ok(f.drawn > 0, `camera ${f.i} draws the level`);
  }
  const back = list.reduce((s, f) => s + f.differBack, 0);
  t.diagnostic(`${list.length} frames compared: ${list.filter((f) => f.differFront + f.differBack === 0).length} identical, ${back} pixels differ only behind the back of a surface; ` +
    `triangles without culling ${all}, with culling ${culled} (${((100 * culled) / all).toFixed(1)}%)`);
  assert.equal(list.length, FRAMES, 'frames compared');
  assert.deepEqual(bad, [], 'the culled frames are the unculled ones');
  assert.equal(list.filter((f) => f.differFront + f.differBack === 0).length, FRAMES, 'frames identical pixel for pixel');
  // Not trivially equal frames of nothing: the level covers most of the pixels.
  assert.ok(2 * list.reduce((s, f) => s + f.drawn, 0) > FRAMES * WIDTH * HEIGHT, 'the level covers most of the frames');
  assert.ok(culled * 2 <= all, `culling draws ${culled} of ${all} triangles, more than half`);
  assert.deepEqual(errors, [], 'no console errors');
  assert.deepEqual(misses, [], 'every request served');
});
