// The replay page: recorded runs in 3-D (three.js), a timeline, per-step plots, the selected
// step's convergence history and contact table. Two runs are shown side by side, synchronised.
// Joints, when the runs have them, are drawn as a diamond at each anchor joined by a segment
// (the drift, or a distance joint's rod), coloured by their error.
'use strict';
const RUNS = DATA.runs;
const STATUS = [
  { name: 'separating', color: '#8a94a6' },
  { name: 'sticking', color: '#2f9e44' },
  { name: 'sliding', color: '#f08c00' },
  { name: 'complementarity violated', color: '#e03131' },
];
const CF = 20; // numbers per contact in a frame (see recording.rs)
const JF = 10; // numbers per joint in a frame (see recording.rs)
const JOINT_KINDS = ['ball', 'hinge', 'fixed', 'distance'];
// Joint colours by error: linear (m) and angular (rad) against the same bounds.
const JOINT_LEVELS = [
  { bound: 1e-3, name: 'joint error < 1 mm, 1 mrad', color: '#2f9e44' },
  { bound: 1e-2, name: '< 1 cm, 10 mrad', color: '#f08c00' },
  { bound: Infinity, name: 'above', color: '#e03131' },
];
const HAS_JOINTS = RUNS.some((r) => r.frames.some((f) => f.joints));
const Z_UP = new THREE.Vector3(0, 0, 1);

// ---- timeline: index into the longest run's per-step series ----------------------------------
const NSTEPS = Math.max(...RUNS.map((r) => r.series.step.length));
const ui = { index: 0, playing: false, speed: 1, selected: -1, detailRun: 0,
  showNormals: true, showImpulses: true, showContacts: true, showJoints: true };
// `#hide=joints,normals` starts with those layers off (as their toggles would).
const hashHide = /hide=([a-z,]+)/.exec(location.hash);
if (hashHide) {
  for (const layer of hashHide[1].split(',')) {
    const key = 'show' + layer.charAt(0).toUpperCase() + layer.slice(1);
    if (key in ui) ui[key] = false;
  }
}

/** The frame a run draws at timeline index i: the last frame at or before that step. */
function frameAt(run, i) {
  const s = run.series.step[Math.min(i, run.series.step.length - 1)];
  const frames = run.frames;
  let lo = 0, hi = frames.length - 1, best = 0;
  while (lo <= hi) {
    const mid = (lo + hi) >> 1;
    if (frames[mid].step <= s) { best = mid; lo = mid + 1; } else hi = mid - 1;
  }
  return frames[best];
}

function stepNumber(i) {
  const r = RUNS.find((r) => i < r.series.step.length) || RUNS[0];
  return r.series.step[Math.min(i, r.series.step.length - 1)];
}

// ---- geometry -------------------------------------------------------------------------------
/**
 * A time step for people: `1/60 s (16.67 ms)` when 1/dt is a whole number of steps per second,
 * else `16.67 ms` (as `lcpbench simulate` prints it).
 */
function formatStep(dt) {
  if (!(dt > 0) || !Number.isFinite(dt)) return `${dt} s`;
  if (dt >= 1) return `${Number(dt.toPrecision(4))} s`;
  const ms = `${Number((dt * 1e3).toPrecision(4))} ms`;
  const rate = 1 / dt;
  return Math.abs(rate - Math.round(rate)) <= 1e-9 * rate && Math.round(rate) > 1 ? `1/${Math.round(rate)} s (${ms})` : ms;
}

/** A body's size: the radius of a sphere or capsule, the largest half extent of a box or mesh. */
function geometrySize(g) {
  if (!g) return null;
  if (g.radius) return g.radius + (g.half_height || 0);
  const h = g.half_extents || g.half_extent;
  if (Array.isArray(h)) return Math.max(...h);
  if (Array.isArray(g.vertices) && g.vertices.length >= 3) {
    let m = 0;
    for (const v of g.vertices) m = Math.max(m, Math.abs(v));
    return m;
  }
  return null;
}

/**
 * Contact marker radius scaled to the scene: a fixed share of the viewing distance (so markers
 * stay visible from the default camera), but at most a sixth of the median body size (so they do
 * not hide small bodies).
 */
function markerRadius(run, bounds) {
  const view = bounds.size * 1.9 + 1;
  const sizes = run.bodies.map((b) => run.geometries[b.geometry])
    .filter((g) => g && g.type !== 'plane').map(geometrySize).filter((x) => x > 0).sort((a, b) => a - b);
  const median = sizes.length ? sizes[Math.floor(sizes.length / 2)] : Infinity;
  return Math.max(view * 0.002, Math.min(view * 0.009, median / 6));
}

function sceneBounds(run) {
  const f = run.frames[0];
  const min = [Infinity, Infinity, Infinity], max = [-Infinity, -Infinity, -Infinity];
  const ids = f.ids || run.bodies.map((_, k) => k);
  ids.forEach((id, k) => {
    const b = run.bodies[id];
    if (!b || run.geometries[b.geometry].type === 'plane') return;
    for (let a = 0; a < 3; a++) {
      min[a] = Math.min(min[a], f.pose[7 * k + a]);
      max[a] = Math.max(max[a], f.pose[7 * k + a]);
    }
  });
  if (!Number.isFinite(min[0])) return { center: new THREE.Vector3(), size: 2 };
  const c = new THREE.Vector3((min[0] + max[0]) / 2, (min[1] + max[1]) / 2, (min[2] + max[2]) / 2);
  const size = Math.max(1, Math.hypot(max[0] - min[0], max[1] - min[1], max[2] - min[2]));
  return { center: c, size };
}

function makeGeometry(g, planeSize) {
  switch (g.type) {
    case 'sphere': return new THREE.SphereGeometry(g.radius, 20, 14);
    case 'box': return new THREE.BoxGeometry(2 * g.half_extents[0], 2 * g.half_extents[1], 2 * g.half_extents[2]);
    case 'capsule': {
      const geo = new THREE.CapsuleGeometry(g.radius, 2 * g.half_height, 6, 16);
      geo.rotateX(Math.PI / 2); // three's capsule runs along y, the body's along z
      return geo;
    }
    case 'plane': {
      const geo = new THREE.PlaneGeometry(planeSize, planeSize);
      const q = new THREE.Quaternion().setFromUnitVectors(Z_UP, new THREE.Vector3(...g.normal).normalize());
      geo.applyQuaternion(q);
      return geo;
    }
    case 'mesh': {
      const geo = new THREE.BufferGeometry();
      geo.setAttribute('position', new THREE.Float32BufferAttribute(g.vertices, 3));
      geo.setIndex(g.indices);
      const flat = geo.toNonIndexed();
      flat.computeVertexNormals();
      return flat;
    }
    default: throw new Error('unknown shape ' + g.type);
  }
}

/** Index into JOINT_LEVELS of a joint's linear (m) and angular (rad) error. */
function jointLevel(linear, angular) {
  const worst = Math.max(linear, angular);
  const level = JOINT_LEVELS.findIndex((l) => worst < l.bound);
  return level < 0 ? JOINT_LEVELS.length - 1 : level;
}

function bodyColor(k, isStatic) {
  if (isStatic) return new THREE.Color('#b8bec6');
  return new THREE.Color().setHSL((k * 0.618034) % 1, 0.55, 0.58);
}

// ---- one 3-D view per run -------------------------------------------------------------------
class RunView {
  constructor(run, index, container, camera, bounds) {
    this.run = run;
    this.index = index;
    this.camera = camera;
    this.scene = new THREE.Scene();
    this.scene.background = new THREE.Color('#ffffff');
    this.scene.add(new THREE.HemisphereLight(0xffffff, 0x8090a0, 1.6));
    const sun = new THREE.DirectionalLight(0xffffff, 1.6);
    sun.position.set(0.6, -0.8, 1.5);
    this.scene.add(sun);
    this.container = container;
    this.renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    this.renderer.setPixelRatio(window.devicePixelRatio || 1);
    container.append(this.renderer.domElement);
    this.label = el('div', { class: 'label', text: iso(run.label) });
    this.stats = el('div', { class: 'stats' });
    container.append(this.label, this.stats);
    this.buildBodies(bounds);
    this.buildContacts(bounds);
    this.buildJoints();
  }

  buildBodies(bounds) {
    const run = this.run;
    const byGeometry = new Map();
    run.bodies.forEach((b, k) => {
      if (!byGeometry.has(b.geometry)) byGeometry.set(b.geometry, []);
      byGeometry.get(b.geometry).push(k);
    });
    this.slot = new Array(run.bodies.length); // body -> [mesh, instance]
    this.meshes = [];
    const planeSize = 4 * bounds.size + 10;
    for (const [gi, bodies] of byGeometry) {
      const g = run.geometries[gi];
      const geo = makeGeometry(g, planeSize);
      const mat = new THREE.MeshStandardMaterial({
        roughness: 0.75, metalness: 0.0, side: g.type === 'plane' ? THREE.DoubleSide : undefined,
        transparent: g.type === 'plane', opacity: g.type === 'plane' ? 0.55 : 1,
      });
      const mesh = new THREE.InstancedMesh(geo, mat, bodies.length);
      mesh.instanceMatrix.setUsage(THREE.DynamicDrawUsage);
      bodies.forEach((k, inst) => {
        this.slot[k] = [mesh, inst];
        mesh.setColorAt(inst, bodyColor(k, run.bodies[k].static));
      });
      mesh.frustumCulled = false;
      this.scene.add(mesh);
      this.meshes.push(mesh);
    }
    if (run.geometries.some((g) => g.type === 'plane')) {
      const grid = new THREE.GridHelper(planeSize, 40, 0xc0c6cc, 0xdde1e5);
      grid.rotateX(Math.PI / 2);
      grid.position.z = 0.0005;
      this.grid = grid;
      this.scene.add(grid);
    }
  }

  buildContacts(bounds) {
    const run = this.run;
    let most = 1, fmax = 0;
    for (const f of run.frames) {
      most = Math.max(most, f.contacts.length / CF);
      for (let c = 0; c < f.contacts.length; c += CF) {
        const fn = f.contacts[c + 8];
        const ft = Math.hypot(f.contacts[c + 9], f.contacts[c + 10], f.contacts[c + 11]);
        fmax = Math.max(fmax, Math.hypot(fn, ft));
      }
    }
    this.capacity = most;
    this.fmax = fmax > 0 ? fmax : 1;
    this.markerRadius = markerRadius(run, bounds);
    this.arrowLength = bounds.size * 0.25;
    const markerGeo = new THREE.SphereGeometry(this.markerRadius, 10, 8);
    this.markers = new THREE.InstancedMesh(markerGeo, new THREE.MeshBasicMaterial({ depthTest: false, transparent: true }), most);
    this.markers.renderOrder = 2;
    this.markers.count = 0;
    this.markers.frustumCulled = false;
    this.scene.add(this.markers);
    this.selectedMarker = new THREE.Mesh(new THREE.SphereGeometry(this.markerRadius * 2.4, 16, 12),
      new THREE.MeshBasicMaterial({ color: 0x1c7ed6, wireframe: true, depthTest: false, transparent: true }));
    this.selectedMarker.renderOrder = 3;
    this.selectedMarker.visible = false;
    this.scene.add(this.selectedMarker);
    const lines = (color) => {
      const geo = new THREE.BufferGeometry();
      geo.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6 * most), 3).setUsage(THREE.DynamicDrawUsage));
      geo.setAttribute('color', new THREE.BufferAttribute(new Float32Array(6 * most), 3).setUsage(THREE.DynamicDrawUsage));
      geo.setDrawRange(0, 0);
      const seg = new THREE.LineSegments(geo, new THREE.LineBasicMaterial({ vertexColors: true, depthTest: false, transparent: true }));
      seg.renderOrder = 1;
      seg.frustumCulled = false;
      this.scene.add(seg);
      return seg;
    };
    this.normals = lines();
    this.impulses = lines();
  }

  buildJoints() {
    const most = Math.max(1, ...this.run.frames.map((f) => (f.joints ? f.joints.length / JF : 0)));
    // A sphere of 4 × 2 segments: an octahedron (the vendored three.js has no OctahedronGeometry).
    const geo = new THREE.SphereGeometry(this.markerRadius * 1.4, 4, 2);
    this.jointMarkers = new THREE.InstancedMesh(geo, new THREE.MeshBasicMaterial({ depthTest: false, transparent: true }), 2 * most);
    this.jointMarkers.renderOrder = 2;
    this.jointMarkers.count = 0;
    this.jointMarkers.frustumCulled = false;
    this.scene.add(this.jointMarkers);
    const lines = new THREE.BufferGeometry();
    lines.setAttribute('position', new THREE.BufferAttribute(new Float32Array(6 * most), 3).setUsage(THREE.DynamicDrawUsage));
    lines.setAttribute('color', new THREE.BufferAttribute(new Float32Array(6 * most), 3).setUsage(THREE.DynamicDrawUsage));
    lines.setDrawRange(0, 0);
    this.jointLinks = new THREE.LineSegments(lines, new THREE.LineBasicMaterial({ vertexColors: true, depthTest: false, transparent: true }));
    this.jointLinks.renderOrder = 1;
    this.jointLinks.frustumCulled = false;
    this.scene.add(this.jointLinks);
  }

  show(frame) {
    const run = this.run;
    const m = new THREE.Matrix4(), q = new THREE.Quaternion(), p = new THREE.Vector3(), one = new THREE.Vector3(1, 1, 1);
    const zero = new THREE.Vector3(0, 0, 0);
    const ids = frame.ids || null;
    const shown = new Set();
    const n = frame.pose.length / 7;
    for (let k = 0; k < n; k++) {
      const body = ids ? ids[k] : k;
      if (body < 0 || !this.slot[body]) continue;
      const o = 7 * k;
      p.set(frame.pose[o], frame.pose[o + 1], frame.pose[o + 2]);
      q.set(frame.pose[o + 4], frame.pose[o + 5], frame.pose[o + 6], frame.pose[o + 3]);
      m.compose(p, q, one);
      const [mesh, inst] = this.slot[body];
      mesh.setMatrixAt(inst, m);
      shown.add(body);
    }
    // Removed bodies (scene events) collapse to nothing.
    m.compose(zero, new THREE.Quaternion(), new THREE.Vector3(0, 0, 0));
    this.slot.forEach((s, body) => { if (s && !shown.has(body)) s[0].setMatrixAt(s[1], m); });
    for (const mesh of this.meshes) mesh.instanceMatrix.needsUpdate = true;
    this.showContacts(frame);
    this.showJoints(frame);
    this.stats.textContent = `step ${frame.step} · ${this.contactCount} contacts` +
      (frame.joints ? ` · ${this.jointCount} joints` : '');
  }

  showJoints(frame) {
    const j = frame.joints || [];
    const count = j.length / JF;
    const m = new THREE.Matrix4(), color = new THREE.Color();
    const lp = this.jointLinks.geometry.attributes.position.array, lc = this.jointLinks.geometry.attributes.color.array;
    for (let k = 0; k < count; k++) {
      const o = JF * k;
      color.set(JOINT_LEVELS[jointLevel(j[o + 6], j[o + 7])].color);
      for (let side = 0; side < 2; side++) {
        m.makeTranslation(j[o + 3 * side], j[o + 3 * side + 1], j[o + 3 * side + 2]);
        this.jointMarkers.setMatrixAt(2 * k + side, m);
        this.jointMarkers.setColorAt(2 * k + side, color);
      }
      lp.set(j.slice(o, o + 6), 6 * k);
      lc.set([color.r, color.g, color.b, color.r, color.g, color.b], 6 * k);
    }
    this.jointMarkers.count = ui.showJoints ? 2 * count : 0;
    this.jointMarkers.instanceMatrix.needsUpdate = true;
    if (this.jointMarkers.instanceColor) this.jointMarkers.instanceColor.needsUpdate = true;
    const links = this.jointLinks.geometry;
    links.setDrawRange(0, ui.showJoints ? 2 * count : 0);
    links.attributes.position.needsUpdate = true;
    links.attributes.color.needsUpdate = true;
    this.jointCount = count;
  }

  showContacts(frame) {
    const c = frame.contacts;
    const count = c.length / CF;
    const m = new THREE.Matrix4(), color = new THREE.Color();
    const np = this.normals.geometry.attributes.position.array, nc = this.normals.geometry.attributes.color.array;
    const ip = this.impulses.geometry.attributes.position.array, ic = this.impulses.geometry.attributes.color.array;
    const normalLength = this.markerRadius * 8;
    for (let k = 0; k < count; k++) {
      const o = CF * k;
      const [px, py, pz, nx, ny, nz] = [c[o + 2], c[o + 3], c[o + 4], c[o + 5], c[o + 6], c[o + 7]];
      const fn = c[o + 8];
      const fx = nx * fn + c[o + 9], fy = ny * fn + c[o + 10], fz = nz * fn + c[o + 11];
      const status = c[o + 19];
      color.set(STATUS[status] ? STATUS[status].color : '#000');
      m.makeTranslation(px, py, pz);
      if (status === 3) m.scale(new THREE.Vector3(1.8, 1.8, 1.8));
      this.markers.setMatrixAt(k, m);
      this.markers.setColorAt(k, color);
      np.set([px, py, pz, px + nx * normalLength, py + ny * normalLength, pz + nz * normalLength], 6 * k);
      nc.set([0.1, 0.4, 0.85, 0.1, 0.4, 0.85], 6 * k);
      const s = this.arrowLength / this.fmax;
      ip.set([px, py, pz, px + fx * s, py + fy * s, pz + fz * s], 6 * k);
      ic.set([color.r, color.g, color.b, color.r, color.g, color.b], 6 * k);
    }
    this.markers.count = ui.showContacts ? count : 0;
    this.markers.instanceMatrix.needsUpdate = true;
    if (this.markers.instanceColor) this.markers.instanceColor.needsUpdate = true;
    for (const [seg, on] of [[this.normals, ui.showNormals], [this.impulses, ui.showImpulses]]) {
      seg.geometry.setDrawRange(0, on ? 2 * count : 0);
      seg.geometry.attributes.position.needsUpdate = true;
      seg.geometry.attributes.color.needsUpdate = true;
    }
    const sel = ui.selected;
    this.selectedMarker.visible = this.index === ui.detailRun && sel >= 0 && sel < count;
    if (this.selectedMarker.visible) this.selectedMarker.position.set(c[CF * sel + 2], c[CF * sel + 3], c[CF * sel + 4]);
    this.contactCount = count;
  }

  resize(width, height) {
    this.renderer.setSize(width, height, false);
  }

  render() {
    this.renderer.render(this.scene, this.camera);
  }
}

// ---- page layout ----------------------------------------------------------------------------
const notes = [];
RUNS.forEach((r) => {
  if (r.stride > 1) {
    notes.push(`${iso(r.label)}: the 3-D view shows every ${ordinal(r.stride)} of ${r.steps_total} steps (decimated to keep this file under ` +
      `${(DATA.max_bytes / 1e6).toFixed(1)} MB); the plots show every step.`);
  }
});
document.getElementById('note').textContent =
  `${iso(RUNS[0].scene)} · ${RUNS.map((r) => iso(r.solver)).join(' vs ')} · ${NSTEPS} steps of ${formatStep(RUNS[0].dt)} · ` +
  `${RUNS[0].bodies.length} bodies. ${notes.join(' ')} Drag to orbit, right-drag to pan, wheel to zoom; click a contact or a plot.`;

const viewsEl = el('div', { class: 'views' });
APP.append(viewsEl);
const bounds = sceneBounds(RUNS[0]);
const camera = new THREE.PerspectiveCamera(45, 1, Math.max(1e-3, bounds.size / 500), bounds.size * 200);
camera.up.copy(Z_UP);
camera.position.copy(bounds.center).add(new THREE.Vector3(1, -1.6, 0.9).normalize().multiplyScalar(bounds.size * 1.9 + 1));
const views = RUNS.map((run, i) => {
  const box = el('div', { class: 'view' });
  viewsEl.append(box);
  return new RunView(run, i, box, camera, bounds);
});
const controls = views.map((v) => {
  const c = new THREE.OrbitControls(camera, v.renderer.domElement);
  c.target.copy(bounds.center);
  c.update();
  return c;
});
controls.forEach((c, i) => c.addEventListener('change', () => {
  controls.forEach((o, j) => { if (j !== i) o.target.copy(c.target); });
  renderAll();
}));

// Controls: buttons, slider, toggles, legend.
const slider = el('input', { type: 'range', min: '0', max: String(Math.max(0, NSTEPS - 1)), value: '0' });
const stepLabel = el('span', { class: 'muted' });
const playButton = el('button', { title: 'play / pause (space)', text: '▶' });
const button = (text, title, f) => el('button', { title, text, onclick: f });
const toggle = (label, key) => el('label', {}, [
  el('input', Object.assign({ type: 'checkbox', onchange: (e) => { ui[key] = e.target.checked; update(false); } }, ui[key] ? { checked: '' } : {})),
  ' ' + label]);
const speed = el('select', { onchange: (e) => { ui.speed = Number(e.target.value); } },
  [1, 2, 5, 10].map((s) => el('option', { value: String(s), text: s + '×' })));
APP.append(el('div', { class: 'controls' }, [
  button('«', 'first step', () => setIndex(0)),
  button('◀', 'previous step (←)', () => setIndex(ui.index - 1)),
  playButton,
  button('▶|', 'next step (→)', () => setIndex(ui.index + 1)),
  button('»', 'last step', () => setIndex(NSTEPS - 1)),
  slider, stepLabel, speed,
  toggle('contacts', 'showContacts'), toggle('normals', 'showNormals'), toggle('impulses', 'showImpulses'),
].concat(HAS_JOINTS ? [toggle('joints', 'showJoints')] : [])));
const legendItem = (color, name, shape) => el('span', {}, [el('i', { class: shape || '', style: 'background:' + color }), name]);
APP.append(el('div', { class: 'legend muted' }, STATUS.map((s) => legendItem(s.color, s.name))
  .concat([el('span', {}, ['impulse arrows scaled by magnitude (longest = largest impulse of the run); blue: normals'])])));
if (HAS_JOINTS) {
  APP.append(el('div', { class: 'legend muted' }, JOINT_LEVELS.map((l) => legendItem(l.color, l.name, 'diamond'))
    .concat([el('span', {}, ['joints: a diamond at each anchor, joined by the drift between them (a distance joint: its rod)'])])));
}
slider.addEventListener('input', () => setIndex(Number(slider.value)));
playButton.addEventListener('click', () => setPlaying(!ui.playing));
document.addEventListener('keydown', (e) => {
  if (e.target.tagName === 'INPUT' && e.target.type !== 'range') return;
  if (e.key === ' ') { setPlaying(!ui.playing); e.preventDefault(); }
  if (e.key === 'ArrowRight') setIndex(ui.index + 1);
  if (e.key === 'ArrowLeft') setIndex(ui.index - 1);
});

// Per-step plots.
APP.append(el('h2', { text: 'Per step' }));
const plotsEl = el('div', { class: 'plots' });
APP.append(plotsEl);
const xs = Array.from({ length: NSTEPS }, (_, i) => i);
const pad = (a) => xs.map((i) => (i < a.length ? a[i] : null));
const METRICS = [
  ['relative residual', 'residual', true, 1],
  ['iterations', 'iterations', false, 1],
  ['solve time (ms)', 'solve_time', false, 1e3],
  ['energy (J)', 'energy', false, 1],
  ['max penetration (m)', 'penetration', false, 1],
  ['contacts', 'contacts', false, 1],
].concat(HAS_JOINTS ? [['joint drift (max, m)', 'joint_drift', true, 1]] : []);
const plots = METRICS.map(([title, key, log, scale]) => linePlot(plotsEl, title,
  xs, RUNS.map((r) => ({ label: r.label, values: pad((r.series[key] || []).map((v) => (v === null ? null : v * scale))) })),
  { log, marker: () => ui.index, onPick: (i) => { setPlaying(false); setIndex(i); }, xLabel: 'step', legend: RUNS.length > 1,
    tolerance: key === 'residual' ? RUNS[0].tolerance : null }));

// Detail of the selected step.
APP.append(el('h2', { text: 'Selected step' }));
const detailEl = el('div', { class: 'detail' });
const historyPanel = el('div', { class: 'panel' });
const contactPanel = el('div', { class: 'panel' });
detailEl.append(historyPanel, contactPanel);
APP.append(detailEl);

function renderHistory() {
  historyPanel.replaceChildren(el('div', { class: 'title' }, [el('b', { text: 'Convergence history of the step' })]));
  const curves = [];
  const parts = [];
  RUNS.forEach((r, k) => {
    const f = frameAt(r, ui.index);
    const h = f.history;
    if (!h) {
      parts.push(el('p', { class: 'muted', text: `${iso(r.label)}: no history recorded (body-level solvers record none; matrix solvers do with --html or simulate --history).` }));
      return;
    }
    curves.push({ label: r.label, xs: h.it, ys: h.res, color: PALETTE[k] });
    if (h.thinned_from) parts.push(el('p', { class: 'muted', text: `${iso(r.label)}: ${h.res.length} of ${h.thinned_from} points shown.` }));
    if (h.extra) {
      const rows = h.extra.slice(0, 200).map((a, i) => el('tr', {}, [el('td', { text: String(h.it[i]) }), el('td', { text: fmt(h.res[i]) }),
        el('td', { class: 'l', text: Array.isArray(a) ? a.join(' ') : JSON.stringify(a) })]));
      parts.push(el('p', {}, [el('b', { text: `${r.label}: ${h.extra_key.replace(/_/g, ' ')} per pivot` })]),
        el('table', {}, [el('thead', {}, [el('tr', {}, [el('th', { text: 'pivot' }), el('th', { text: 'residual' }), el('th', { class: 'l', text: h.extra_key })])]), el('tbody', {}, rows)]));
    } else {
      parts.push(el('p', { class: 'muted', text: `${r.label}: active set not recorded.` }));
    }
  });
  if (curves.length) joinedPlot(historyPanel, 'relative residual per iteration', curves, { log: true, xLabel: 'iteration', height: 180, legend: true, tolerance: RUNS[0].tolerance });
  historyPanel.append(...parts);
}

function renderContacts() {
  const run = RUNS[ui.detailRun];
  const f = frameAt(run, ui.index);
  const c = f.contacts;
  const count = c.length / CF;
  const name = (id) => (id >= 0 && run.bodies[id] ? iso(run.bodies[id].name) : '?');
  const runPick = RUNS.length > 1 ? el('select', { onchange: (e) => { ui.detailRun = Number(e.target.value); ui.selected = -1; update(true); } },
    RUNS.map((r, i) => { const o = el('option', { value: String(i), text: r.label }); if (i === ui.detailRun) o.selected = true; return o; })) : '';
  const head = ['#', 'bodies', 'status', 'f_n', '|f_t|', 'gap', 'v_n', '|v_t|', 'min(f_n, w_n/A_nn)'];
  const rows = [];
  for (let k = 0; k < Math.min(count, 300); k++) {
    const o = CF * k;
    const [nx, ny, nz] = [c[o + 5], c[o + 6], c[o + 7]];
    const [vx, vy, vz] = [c[o + 12], c[o + 13], c[o + 14]];
    const vn = nx * vx + ny * vy + nz * vz;
    const vt = Math.hypot(vx - vn * nx, vy - vn * ny, vz - vn * nz);
    const status = c[o + 19];
    const tr = el('tr', { class: k === ui.selected ? 'sel' : '', onclick: () => { ui.selected = k; update(true); } }, [
      el('td', { text: String(k) }), el('td', { class: 'l', text: name(c[o]) + ' – ' + name(c[o + 1]) }),
      el('td', { class: 'l' + (status === 3 ? ' bad' : ''), text: STATUS[status].name }),
      el('td', { text: fmt(c[o + 8]) }), el('td', { text: fmt(Math.hypot(c[o + 9], c[o + 10], c[o + 11])) }),
      el('td', { text: fmt(c[o + 15]) }), el('td', { text: fmt(vn) }), el('td', { text: fmt(vt) }), el('td', { text: fmt(c[o + 18]) }),
    ]);
    rows.push(tr);
  }
  const children = [el('div', {}, [el('b', { text: `Contacts at step ${f.step}` }), ' ', runPick, ` ${count} contacts` + (count > 300 ? ' (first 300 listed)' : '')])];
  if (ui.selected >= 0 && ui.selected < count) {
    const o = CF * ui.selected;
    const v3 = (a) => '(' + a.map(fmt).join(', ') + ')';
    const kv = [['bodies', name(c[o]) + ' – ' + name(c[o + 1])], ['point', v3([c[o + 2], c[o + 3], c[o + 4]])], ['normal', v3([c[o + 5], c[o + 6], c[o + 7]])],
      ['normal impulse f_n', fmt(c[o + 8])], ['tangential impulse', v3([c[o + 9], c[o + 10], c[o + 11]])], ['gap', fmt(c[o + 15]) + ' m'],
      ['relative velocity', v3([c[o + 12], c[o + 13], c[o + 14]]) + ' m/s'], ['mu', fmt(c[o + 16])], ['w_n', fmt(c[o + 17])],
      ['min(f_n, w_n/A_nn)', fmt(c[o + 18])], ['status', STATUS[c[o + 19]].name]];
    children.push(el('table', { class: 'selected-contact' }, [el('tbody', {}, kv.map(([k, v]) => el('tr', {}, [el('th', { class: 'l', text: k }), el('td', { class: 'l', text: v })])))]));
  } else {
    children.push(el('p', { class: 'muted', text: 'Click a contact (in the table or the 3-D view) for its details.' }));
  }
  children.push(el('table', {}, [el('thead', {}, [el('tr', {}, head.map((h) => el('th', { text: h })))]), el('tbody', {}, rows)]));
  if (f.joints) children.push(el('p', {}, [el('b', { text: `Joints at step ${f.step}` }), ' ' + jointSummary(f.joints)]));
  contactPanel.replaceChildren(...children);
}

/** A frame's joints in one line: how many of each kind, their largest errors and impulse. */
function jointSummary(j) {
  const count = j.length / JF;
  const kinds = new Map();
  let linear = 0, angular = 0, impulse = 0;
  for (let o = 0; o < j.length; o += JF) {
    const kind = JOINT_KINDS[j[o + 9]] || '?';
    kinds.set(kind, (kinds.get(kind) || 0) + 1);
    linear = Math.max(linear, j[o + 6]);
    angular = Math.max(angular, j[o + 7]);
    impulse = Math.max(impulse, j[o + 8]);
  }
  if (count === 0) return 'none';
  return [...kinds].map(([k, n]) => `${n} ${k}`).join(', ') +
    ` · largest error ${fmt(linear)} m, ${fmt(angular)} rad · largest impulse ${fmt(impulse)} N·s`;
}

// Picking contacts in the 3-D view (a click, not a drag).
views.forEach((v, vi) => {
  let down = null;
  v.renderer.domElement.addEventListener('pointerdown', (e) => { down = [e.clientX, e.clientY]; });
  v.renderer.domElement.addEventListener('pointerup', (e) => {
    if (!down || Math.hypot(e.clientX - down[0], e.clientY - down[1]) > 4) return;
    const rect = v.renderer.domElement.getBoundingClientRect();
    const ndc = { x: ((e.clientX - rect.left) / rect.width) * 2 - 1, y: -((e.clientY - rect.top) / rect.height) * 2 + 1 };
    const f = frameAt(v.run, ui.index);
    const c = f.contacts;
    let best = -1, bestD = 0.03;
    const p = new THREE.Vector3();
    for (let k = 0; k < c.length / CF; k++) {
      p.set(c[CF * k + 2], c[CF * k + 3], c[CF * k + 4]).project(camera);
      const d = Math.hypot(p.x - ndc.x, p.y - ndc.y);
      if (d < bestD) { bestD = d; best = k; }
    }
    if (best >= 0) { ui.detailRun = vi; ui.selected = best; update(true); }
  });
});

// ---- state changes --------------------------------------------------------------------------
function renderAll() {
  for (const v of views) v.render();
}

function resize() {
  const width = viewsEl.clientWidth / views.length - (views.length - 1) * 4;
  const height = Math.max(260, Math.min(window.innerHeight * 0.55, width * 0.75));
  for (const v of views) { v.container.style.height = height + 'px'; v.resize(width, height); }
  camera.aspect = width / height;
  camera.updateProjectionMatrix();
  renderAll();
}

function update(details) {
  const i = ui.index;
  slider.value = String(i);
  views.forEach((v) => v.show(frameAt(v.run, i)));
  renderAll();
  const r0 = RUNS[0].series;
  const j = Math.min(i, r0.step.length - 1);
  stepLabel.textContent = `step ${stepNumber(i)} / ${stepNumber(NSTEPS - 1)} · t = ${fmt(r0.time[j])} s · ` +
    RUNS.map((r) => `${r.label}: ${r.series.status[Math.min(i, r.series.status.length - 1)]}`).join(', ');
  for (const p of plots) if (p) p.redraw(false, false);
  if (details) { renderHistory(); renderContacts(); }
  const state = { ready: true, step: stepNumber(i), index: i, runs: RUNS.length, selected: ui.selected };
  views.forEach((v, k) => {
    state[k === 0 ? 'markers' : 'markers' + k] = v.markers.count;
    state[k === 0 ? 'joints' : 'joints' + k] = v.jointCount;
    state[k === 0 ? 'jointMarkers' : 'jointMarkers' + k] = v.jointMarkers.count;
    state[k === 0 ? 'frameStep' : 'frameStep' + k] = frameAt(v.run, i).step;
  });
  publishState(state);
}

function setIndex(i) {
  const next = Math.max(0, Math.min(NSTEPS - 1, i));
  if (next !== ui.index) ui.selected = -1;
  ui.index = next;
  update(!ui.playing);
}

function setPlaying(on) {
  ui.playing = on && NSTEPS > 1;
  playButton.textContent = ui.playing ? '⏸' : '▶';
  if (ui.playing) {
    if (ui.index >= NSTEPS - 1) ui.index = 0;
    requestAnimationFrame(tick);
  } else {
    update(true);
  }
}

function tick() {
  if (!ui.playing) return;
  const stride = Math.min(...RUNS.map((r) => r.stride));
  setIndex(ui.index + ui.speed * stride);
  if (ui.index >= NSTEPS - 1) { setPlaying(false); return; }
  requestAnimationFrame(tick);
}

window.addEventListener('resize', resize);
window.lcpbenchSetStep = (s) => { const k = RUNS[0].series.step.indexOf(s); setIndex(k >= 0 ? k : s); };
const hashStep = /step=(\d+)/.exec(location.hash);
if (hashStep) {
  const s = Number(hashStep[1]);
  const k = RUNS[0].series.step.indexOf(s);
  ui.index = Math.max(0, Math.min(NSTEPS - 1, k >= 0 ? k : s));
}
resize();
update(true);
