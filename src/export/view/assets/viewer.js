// portcullis view: draws the level data embedded in this page (script #portcullis-data) with
// three.js. Cells are translucent volumes coloured by room, portals outlines coloured by kind;
// picking a cell lights its PVS. Tests read `window.portcullis`.
(function () {
  'use strict';
  const data = JSON.parse(document.getElementById('portcullis-data').textContent);
  const api = {
    ready: false,
    cells: data.cells.length,
    portals: data.portals.length,
    selected: null,
    drawn: 0,
    select: null,
  };
  window.portcullis = api;

  const view = document.getElementById('view');
  const panel = document.getElementById('panel');
  const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  view.appendChild(renderer.domElement);
  const scene = new THREE.Scene();
  scene.background = new THREE.Color(0x1d2024);
  const camera = new THREE.PerspectiveCamera(60, 1, 0.01, 1e6);
  scene.add(new THREE.HemisphereLight(0xffffff, 0x404040, 2.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.2);
  sun.position.set(0.4, 1.0, 0.3);
  scene.add(sun);

  // --- the level's own geometry ---------------------------------------------------------
  const geometry = new THREE.BufferGeometry();
  geometry.setAttribute('position', new THREE.Float32BufferAttribute(data.geometry.positions, 3));
  geometry.setIndex(data.geometry.indices);
  geometry.computeVertexNormals();
  // Front faces only: a room's walls face into it, so from outside the view looks in through
  // them (a doll's house), and from inside it is the room as a player sees it.
  const level = new THREE.Mesh(geometry, new THREE.MeshLambertMaterial({
    color: 0x9aa0a6, side: THREE.FrontSide,
    polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
  }));
  scene.add(level);

  // --- cells ----------------------------------------------------------------------------
  const v3 = (a) => new THREE.Vector3(a[0], a[1], a[2]);
  const box = new THREE.Box3();
  const cellBoxes = data.cells.map((c) => new THREE.Box3(v3(c.min), v3(c.max)));
  cellBoxes.forEach((b) => box.union(b));
  if (box.isEmpty()) box.setFromObject(level);
  if (box.isEmpty()) box.set(new THREE.Vector3(-1, -1, -1), new THREE.Vector3(1, 1, 1));
  const cellMeshes = data.cells.map((c, i) => {
    const pos = [];
    for (const f of c.faces) {
      const n = f.length / 3;
      for (let k = 1; k + 1 < n; k++) {
        for (const j of [0, k, k + 1]) pos.push(f[3 * j], f[3 * j + 1], f[3 * j + 2]);
      }
    }
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
    const m = new THREE.Mesh(g, new THREE.MeshBasicMaterial({
      color: data.rooms[c.room].colour, transparent: true, opacity: 0.16,
      depthWrite: false, side: THREE.DoubleSide,
    }));
    m.userData.cell = i;
    scene.add(m);
    return m;
  });

  // --- portals, leaks, sightline rays -----------------------------------------------------
  const portalLines = data.portals.map((p) => {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(p.polygon, 3));
    const l = new THREE.LineLoop(g, new THREE.LineBasicMaterial({ color: p.colour }));
    scene.add(l);
    return l;
  });
  const polylines = (list, colour) => list.map((pts) => {
    const g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(pts, 3));
    const l = new THREE.Line(g, new THREE.LineBasicMaterial({ color: colour }));
    scene.add(l);
    return l;
  });
  const leakLines = polylines(data.leaks, 0xff3030);
  const rayLines = polylines(data.sightlines, 0xffe040);

  // --- camera: orbit about a target, pan, zoom, and WASD flight ---------------------------
  const target = box.getCenter(new THREE.Vector3());
  const size = box.getSize(new THREE.Vector3()).length() || 1;
  let yaw = Math.PI * 0.25, pitch = 0.7, distance = size * 1.2;
  camera.near = size * 1e-4;
  camera.far = size * 100;
  function placeCamera() {
    const dir = new THREE.Vector3(
      Math.cos(pitch) * Math.sin(yaw), Math.sin(pitch), Math.cos(pitch) * Math.cos(yaw));
    camera.position.copy(target).addScaledVector(dir, distance);
    camera.lookAt(target);
    camera.updateMatrixWorld();
  }

  // --- which cell holds a point, and what the view draws from there -----------------------
  function cellAt(p) {
    let best = -1, bestVolume = Infinity;
    data.cells.forEach((c, i) => {
      if (!cellBoxes[i].containsPoint(p)) return;
      for (const h of c.planes) {
        if (h[0] * p.x + h[1] * p.y + h[2] * p.z > h[3] + 1e-6) return;
      }
      const s = cellBoxes[i].getSize(new THREE.Vector3());
      const volume = s.x * s.y * s.z;
      if (volume < bestVolume) { best = i; bestVolume = volume; }
    });
    return best;
  }
  const frustum = new THREE.Frustum();
  const drawnBox = document.createElement('div');
  drawnBox.id = 'drawn';
  view.appendChild(drawnBox);
  function updateDrawn() {
    camera.updateMatrixWorld();
    frustum.setFromProjectionMatrix(new THREE.Matrix4().multiplyMatrices(
      camera.projectionMatrix, camera.matrixWorldInverse));
    const here = cellAt(camera.position);
    const candidates = here >= 0 ? data.pvs[here] || [here] : data.cells.map((_, i) => i);
    const drawn = candidates.filter((c) => frustum.intersectsBox(cellBoxes[c]));
    api.drawn = drawn.length;
    // Flying inside the level with nothing picked: the cells the camera's cell draws in view
    // are lit, so moving shows what the PVS and the frustum leave.
    if (api.selected === null) {
      const on = new Set(here >= 0 ? drawn : []);
      cellMeshes.forEach((m, i) => {
        m.material.opacity = here < 0 ? 0.16 : i === here ? 0.45 : on.has(i) ? 0.28 : 0.03;
      });
    }
    drawnBox.textContent = (here >= 0 ? 'camera in cell ' + here : 'camera outside') +
      ' · drawn ' + api.drawn + ' / ' + data.cells.length + ' cells';
  }

  // --- selection: a cell's PVS lit, the rest dimmed ---------------------------------------
  const listItems = [];
  function select(c) {
    const valid = Number.isInteger(c) && c >= 0 && c < data.cells.length;
    const lit = valid ? (data.pvs[c] || [c]).slice() : [];
    const on = new Set(lit);
    cellMeshes.forEach((m, i) => {
      m.material.opacity = !valid ? 0.16 : on.has(i) ? (i === c ? 0.55 : 0.32) : 0.03;
    });
    level.material.opacity = valid ? 0.5 : 1.0;
    level.material.transparent = valid;
    listItems.forEach((el, i) => el.classList.toggle('on', on.has(i)));
    api.selected = valid ? c : null;
    render();
    return lit;
  }
  api.select = select;

  // --- the panel --------------------------------------------------------------------------
  const el = (tag, text, parent) => {
    const e = document.createElement(tag);
    if (text != null) e.textContent = text;
    (parent || panel).appendChild(e);
    return e;
  };
  el('h1', data.title);
  const triangles = data.geometry.indices.length / 3;
  el('div', data.cells.length + ' cells · ' + data.portals.length + ' portals · ' +
    data.rooms.length + ' rooms · ' + triangles + ' triangles').className = 'counts';
  el('h2', 'Show');
  const toggle = (label, objects, on) => {
    const row = el('label', null);
    const box = el('input', null, row);
    box.type = 'checkbox';
    box.checked = on;
    row.appendChild(document.createTextNode(' ' + label));
    const apply = () => { objects.forEach((o) => { o.visible = box.checked; }); render(); };
    box.addEventListener('change', apply);
    objects.forEach((o) => { o.visible = on; });
  };
  toggle('level geometry', [level], true);
  toggle('cells (by room)', cellMeshes, true);
  toggle('portals', portalLines, true);
  if (leakLines.length) toggle('leaks (' + leakLines.length + ')', leakLines, true);
  if (rayLines.length) toggle('sightlines the PVS misses (' + rayLines.length + ')', rayLines, true);
  el('h2', 'Legend');
  const swatch = (colour, label) => {
    const row = el('div', null);
    const s = el('span', null, row);
    s.className = 'swatch';
    s.style.background = colour;
    row.appendChild(document.createTextNode(label));
  };
  const used = new Set(data.portals.map((p) => p.style));
  data.legend.filter((l) => used.has(l.label)).forEach((l) => swatch(l.colour, 'portal: ' + l.label));
  if (leakLines.length) swatch('#ff3030', 'leak path');
  if (rayLines.length) swatch('#ffe040', 'ray joining cells the PVS keeps apart');
  el('h2', 'Cells');
  const search = el('input', null);
  search.type = 'search';
  search.placeholder = 'search by cell number or room';
  const list = el('div', null);
  list.id = 'cells';
  data.cells.forEach((c, i) => {
    const row = el('div', '#' + i + ' ' + data.rooms[c.room].name, list);
    row.addEventListener('click', () => select(api.selected === i ? null : i));
    listItems.push(row);
  });
  search.addEventListener('input', () => {
    const q = search.value.trim().toLowerCase();
    listItems.forEach((row) => { row.style.display = row.textContent.toLowerCase().includes(q) ? '' : 'none'; });
  });
  if (data.diagnostics.length) {
    el('h2', 'Diagnostics (' + data.diagnostics.length + ')');
    // Errors first (the page's data is in that order); a filter per severity.
    const filter = el('div', null);
    filter.id = 'severity-filter';
    const shown = { error: true, warning: true, info: true };
    const rows = [];
    ['error', 'warning', 'info'].forEach((sev) => {
      const n = data.diagnostics.filter((d) => d.severity === sev).length;
      if (!n) return;
      const label = el('label', null, filter);
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.checked = true;
      box.dataset.severity = sev;
      label.appendChild(box);
      label.appendChild(document.createTextNode(' ' + sev + 's (' + n + ') '));
      box.addEventListener('change', () => {
        shown[sev] = box.checked;
        rows.forEach((r) => { r.style.display = shown[r.dataset.severity] ? '' : 'none'; });
      });
    });
    const box = el('div', null);
    box.id = 'diagnostics';
    data.diagnostics.forEach((d) => {
      const row = el('div', null, box);
      row.dataset.severity = d.severity;
      rows.push(row);
      const head = el('span', d.severity + '[' + d.code + ']', row);
      head.className = 'code sev-' + d.severity;
      row.appendChild(document.createTextNode(' ' + d.message));
      row.title = d.where + (d.hint ? '\nhint: ' + d.hint : '');
      if (d.position) row.addEventListener('click', () => flyTo(v3(d.position)));
    });
  }
  const help = document.createElement('div');
  help.id = 'help';
  help.textContent = 'drag: turn · right drag: pan · wheel: zoom · W A S D Q E: fly · click: pick a cell';
  view.appendChild(help);

  function flyTo(p) {
    target.copy(p);
    distance = Math.max(size * 0.08, 2);
    render();
  }

  // --- input ------------------------------------------------------------------------------
  let drag = null;
  renderer.domElement.addEventListener('contextmenu', (e) => e.preventDefault());
  renderer.domElement.addEventListener('pointerdown', (e) => {
    drag = { x: e.clientX, y: e.clientY, button: e.button, moved: false };
  });
  window.addEventListener('pointerup', (e) => {
    if (drag && !drag.moved && drag.button === 0) pick(e);
    drag = null;
  });
  window.addEventListener('pointermove', (e) => {
    if (!drag) return;
    const dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    if (Math.abs(dx) + Math.abs(dy) > 2) drag.moved = true;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (drag.button === 0) {
      yaw -= dx * 0.005;
      pitch = Math.max(-1.5, Math.min(1.5, pitch + dy * 0.005));
    } else {
      const right = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 0);
      const up = new THREE.Vector3().setFromMatrixColumn(camera.matrixWorld, 1);
      const k = distance * 0.0015;
      target.addScaledVector(right, -dx * k).addScaledVector(up, dy * k);
    }
    render();
  });
  renderer.domElement.addEventListener('wheel', (e) => {
    e.preventDefault();
    distance = Math.max(size * 1e-3, distance * Math.exp(e.deltaY * 0.001));
    render();
  }, { passive: false });
  window.addEventListener('keydown', (e) => {
    if (e.target && e.target.tagName === 'INPUT') return;
    const forward = new THREE.Vector3();
    camera.getWorldDirection(forward);
    const right = new THREE.Vector3().crossVectors(forward, camera.up).normalize();
    const step = size * 0.02;
    const moves = {
      w: forward, s: forward.clone().negate(), d: right, a: right.clone().negate(),
      e: new THREE.Vector3(0, 1, 0), q: new THREE.Vector3(0, -1, 0),
    };
    const m = moves[e.key.toLowerCase()];
    if (!m) return;
    target.addScaledVector(m, step);
    render();
  });
  const raycaster = new THREE.Raycaster();
  function pick(e) {
    const r = renderer.domElement.getBoundingClientRect();
    const ndc = new THREE.Vector2(
      ((e.clientX - r.left) / r.width) * 2 - 1, -((e.clientY - r.top) / r.height) * 2 + 1);
    raycaster.setFromCamera(ndc, camera);
    const hit = raycaster.intersectObjects(cellMeshes.filter((m) => m.visible), false)[0];
    select(hit ? hit.object.userData.cell : null);
  }

  // --- drawing ----------------------------------------------------------------------------
  function resize() {
    const w = Math.max(1, view.clientWidth), h = Math.max(1, view.clientHeight);
    renderer.setSize(w, h);
    camera.aspect = w / h;
    camera.updateProjectionMatrix();
  }
  let pending = false;
  function render() {
    if (pending) return;
    pending = true;
    requestAnimationFrame(() => {
      pending = false;
      placeCamera();
      updateDrawn();
      renderer.render(scene, camera);
      api.ready = true;
    });
  }
  window.addEventListener('resize', () => { resize(); render(); });
  resize();
  placeCamera();
  updateDrawn();
  renderer.render(scene, camera);
  api.ready = true;
})();
