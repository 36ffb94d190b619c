// The cutsim player: plays back a run packed by `cutsim view` (src/view/packer.cpp) into the page
// that embeds this script. The page holds two elements: #cutsim-meta (JSON: the frames, each
// with [offset, count] of its arrays in the blob, the CSV's series, the run's description) and
// #cutsim-data (the blob, base64). Nothing is fetched: the page works offline, from disk.
//
// Window API (used by the browser test, tests/viewer/player.test.mjs):
//   window.cutsimPlayer = { ready, frames(), seek(i), frame, setLit(bool), setField(name),
//                           setRange(mode), project(k), hotTriangles(k), series(name) }
import * as THREE from 'three';
import { OrbitControls } from 'three/examples/jsm/controls/OrbitControls.js';
import { LineSegments2 } from 'three/examples/jsm/lines/LineSegments2.js';
import { LineSegmentsGeometry } from 'three/examples/jsm/lines/LineSegmentsGeometry.js';
import { LineMaterial } from 'three/examples/jsm/lines/LineMaterial.js';
import css from './style.css';
import { colormap, colormapCss } from './colormap.js';
import { Plot } from './plot.js';

const FIELDS = {
  strain: { label: 'strain (max principal Green)', unit: '' },
  speed: { label: 'speed', unit: 'm/s' },
  displacement: { label: 'displacement from rest', unit: 'm' },
};

const LIP_COLOR = [1.0, 0.0, 0.85];
const BORDER_COLOR = [0.62, 0.66, 0.72];

function decodeBase64(text) {
  const table = new Uint8Array(128);
  const alphabet = 'ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/';
  for (let i = 0; i < alphabet.length; i++) table[alphabet.charCodeAt(i)] = i;
  let n = text.length;
  while (n > 0 && (text[n - 1] === '=' || text[n - 1] === '\n' || text[n - 1] === ' ')) n--;
  const out = new Uint8Array(Math.floor((n * 3) / 4));
  let o = 0, acc = 0, bits = 0;
  for (let i = 0; i < n; i++) {
    const c = text.charCodeAt(i);
    if (c === 10 || c === 13 || c === 32) continue;
    acc = (acc << 6) | table[c];
    bits += 6;
    if (bits >= 8) {
      bits -= 8;
      out[o++] = (acc >> bits) & 0xff;
    }
  }
  return out.buffer.slice(0, o);
}

const ICONS = {
  first: 'M6 5h2v14H6zM20 5v14L9 12z',
  previous: 'M6 5h2v14H6zM18 5v14L9 12z',
  play: 'M7 5v14l12-7z',
  pause: 'M6 5h4v14H6zM14 5h4v14h-4z',
  next: 'M16 5h2v14h-2zM6 5v14l9-7z',
  last: 'M16 5h2v14h-2zM4 5v14l11-7z',
};

function icon(name) {
  const ns = 'http://www.w3.org/2000/svg';
  const svg = document.createElementNS(ns, 'svg');
  svg.setAttribute('viewBox', '0 0 24 24');
  svg.setAttribute('width', '16');
  svg.setAttribute('height', '16');
  const path = document.createElementNS(ns, 'path');
  path.setAttribute('d', ICONS[name]);
  path.setAttribute('fill', 'currentColor');
  svg.append(path);
  return svg;
}

function el(tag, attrs = {}, ...children) {
  const e = document.createElement(tag);
  for (const [k, v] of Object.entries(attrs)) {
    if (k === 'class') e.className = v;
    else if (k.startsWith('on')) e.addEventListener(k.slice(2), v);
    else e.setAttribute(k, v);
  }
  for (const c of children) e.append(c);
  return e;
}

/// The unit axis along which points spread least: the eigenvector of the smallest eigenvalue of
/// their covariance (cyclic Jacobi rotations on the 3 x 3 matrix).
function leastSpreadAxis(points) {
  const m = [0, 0, 0];
  for (const p of points) { m[0] += p.x / points.length; m[1] += p.y / points.length; m[2] += p.z / points.length; }
  const a = [[0, 0, 0], [0, 0, 0], [0, 0, 0]];
  for (const p of points) {
    const d = [p.x - m[0], p.y - m[1], p.z - m[2]];
    for (let i = 0; i < 3; i++) for (let j = 0; j < 3; j++) a[i][j] += d[i] * d[j];
  }
  const v = [[1, 0, 0], [0, 1, 0], [0, 0, 1]];
  for (let sweep = 0; sweep < 50; sweep++) {
    const off = Math.abs(a[0][1]) + Math.abs(a[0][2]) + Math.abs(a[1][2]);
    if (off <= 1e-15 * (Math.abs(a[0][0]) + Math.abs(a[1][1]) + Math.abs(a[2][2]) + 1e-300)) break;
    for (const [p, q] of [[0, 1], [0, 2], [1, 2]]) {
      if (a[p][q] === 0) continue;
      const theta = (a[q][q] - a[p][p]) / (2 * a[p][q]);
      const t = Math.sign(theta || 1) / (Math.abs(theta) + Math.sqrt(theta * theta + 1));
      const c = 1 / Math.sqrt(t * t + 1), s = t * c;
      for (let k = 0; k < 3; k++) {  // A <- A J
        const akp = a[k][p], akq = a[k][q];
        a[k][p] = c * akp - s * akq; a[k][q] = s * akp + c * akq;
      }
      for (let k = 0; k < 3; k++) {  // A <- J^T A
        const apk = a[p][k], aqk = a[q][k];
        a[p][k] = c * apk - s * aqk; a[q][k] = s * apk + c * aqk;
      }
      for (let k = 0; k < 3; k++) {  // V <- V J
        const vkp = v[k][p], vkq = v[k][q];
        v[k][p] = c * vkp - s * vkq; v[k][q] = s * vkp + c * vkq;
      }
    }
  }
  let best = 0;
  for (let i = 1; i < 3; i++) if (a[i][i] < a[best][best]) best = i;
  const axis = new THREE.Vector3(v[0][best], v[1][best], v[2][best]);
  return axis.lengthSq() > 0 ? axis.normalize() : new THREE.Vector3(0, 0, 1);
}

function fmt(v, digits = 4) {
  if (v === undefined || v === null || Number.isNaN(v)) return '-';
  if (v === 0) return '0';
  const a = Math.abs(v);
  if (a >= 1e4 || a < 1e-3) return v.toExponential(2);
  return Number(v.toPrecision(digits)).toString();
}

/// The q-quantile of a sample of values (sorted copy).
function quantile(values, q) {
  if (values.length === 0) return 0;
  const s = Float64Array.from(values).sort();
  return s[Math.min(s.length - 1, Math.max(0, Math.round(q * (s.length - 1))))];
}

class Player {
  constructor(meta, buffer) {
    this.meta = meta;
    this.buffer = buffer;
    this.frameList = meta.frames;
    this.index = 0;
    this.field = 'strain';
    this.rangeMode = 'run';
    this.lit = true;
    this.playing = false;
    this.speed = 1;
    this.show = { borders: true, springs: false, stitches: true, held: true, obstacles: true, instruments: true, wireframe: false };
    this.ranges = {};
    this.hasSprings = this.frameList.some((f) => f.spring);
    this.buildDom();
    this.buildScene();
    this.buildPlots();
    this.computeRanges();
    this.fitCamera();
    const hash = new URLSearchParams(location.hash.slice(1));
    if (hash.has('field') && FIELDS[hash.get('field')]) this.setField(hash.get('field'));
    const start = hash.has('frame') ? Number(hash.get('frame')) : 0;
    this.seek(Number.isFinite(start) ? start : 0);
    this.loop();
  }

  array(kind, ref) {
    if (!ref) return null;
    const [offset, count] = ref;
    return new kind(this.buffer, offset, count);
  }

  // ---------------------------------------------------------------------------------------------
  // Page

  buildDom() {
    const style = el('style');
    style.textContent = css;
    document.head.append(style);
    const run = this.meta.run;
    this.viewEl = el('div', { id: 'view' });
    this.countsEl = el('div', { class: 'counts' });
    const desc = el('div', { class: 'desc' }, run.description || '');
    const toggleDesc = el('button', { class: 'link', onclick: () => desc.classList.toggle('collapsed') }, 'description');
    const info = el('div', { id: 'info', class: 'panel' }, el('h1', {}, run.name), run.description ? desc : '',
      run.description ? toggleDesc : '', this.countsEl);
    this.fieldSelect = el('select', { id: 'field', onchange: () => this.setField(this.fieldSelect.value) });
    for (const [name, f] of Object.entries(FIELDS)) {
      if (this.frameList.some((fr) => fr[name])) this.fieldSelect.append(el('option', { value: name }, f.label));
    }
    this.rangeSelect = el('select', { id: 'range', onchange: () => this.setRange(this.rangeSelect.value) },
      el('option', { value: 'run' }, 'range: whole run'), el('option', { value: 'frame' }, 'range: this frame'));
    this.colorbar = el('canvas', { id: 'colorbar', width: 22, height: 220 });
    this.ticksEl = el('div', { id: 'colorbar-ticks' });
    const toggles = el('div', { id: 'toggles' });
    const toggle = (key, label, title) => {
      const box = el('input', { type: 'checkbox', id: 'show-' + key });
      box.checked = this.show[key];
      box.addEventListener('change', () => { this.show[key] = box.checked; this.applyVisibility(); this.render(); });
      toggles.append(el('label', { title }, box, ' ' + label));
    };
    toggle('borders', 'borders and cut lips', 'the border the surface started with in grey, borders opened by cuts, tears and removals in magenta');
    if (this.hasSprings) toggle('springs', 'bending springs', 'one line between the two wing points of each bending spring');
    if (this.frameList.some((f) => f.stitch)) toggle('stitches', 'stitches', 'each suture\'s thread (green), between the two points it ties');
    if (this.frameList.some((f) => f.held)) toggle('held', 'fixed and grasped points', 'fixed points white, grasped points orange');
    if (this.frameList.some((f) => f.obstacleX)) toggle('obstacles', 'obstacles', 'the contact obstacles');
    if (this.frameList.some((f) => f.instrumentX)) toggle('instruments', 'instruments', 'a scalpel\'s blade, a cautery\'s tip (yellow, tips marked) where they are');
    toggle('wireframe', 'triangle edges', 'the mesh edges over the colours');
    const litBox = el('input', { type: 'checkbox', id: 'lit' });
    litBox.checked = true;
    litBox.addEventListener('change', () => this.setLit(litBox.checked));
    this.litBox = litBox;
    toggles.append(el('label', { title: 'shading by a light; off: the colour map\'s colours exactly' }, litBox, ' lighting'));
    const legend = el('div', { id: 'legend', class: 'panel' }, this.fieldSelect, this.rangeSelect,
      el('div', { id: 'colorbar-row' }, this.colorbar, this.ticksEl), toggles);
    const banner = el('div', { id: 'banner', class: 'panel' },
      `partial run: ${run.framesInRun} frames written so far (the run stopped or is still going)`);
    if (run.partial) banner.style.display = 'block';
    this.playButton = el('button', { id: 'play', title: 'play / pause (space)', onclick: () => this.togglePlay() }, icon('play'));
    this.scrubber = el('input', { id: 'scrubber', type: 'range', min: 0, max: this.frameList.length - 1, value: 0, step: 1 });
    this.scrubber.addEventListener('input', () => { this.pause(); this.seek(Number(this.scrubber.value)); });
    this.speedSelect = el('select', { id: 'speed', title: 'playback speed (simulated time per second)' });
    for (const s of [0.1, 0.25, 0.5, 1, 2, 4, 10]) this.speedSelect.append(el('option', { value: s }, `${s}\u00D7`));
    this.speedSelect.value = '1';
    this.speedSelect.addEventListener('change', () => { this.speed = Number(this.speedSelect.value); });
    this.timeEl = el('span', { id: 'time' });
    const controls = el('div', { id: 'controls' },
      el('button', { title: 'first frame (Home)', onclick: () => { this.pause(); this.seek(0); } }, icon('first')),
      el('button', { title: 'previous frame (\u2190)', onclick: () => { this.pause(); this.seek(this.index - 1); } }, icon('previous')),
      this.playButton,
      el('button', { title: 'next frame (\u2192)', onclick: () => { this.pause(); this.seek(this.index + 1); } }, icon('next')),
      el('button', { title: 'last frame (End)', onclick: () => { this.pause(); this.seek(this.frameList.length - 1); } }, icon('last')),
      this.scrubber, this.speedSelect, this.timeEl);
    this.plotsEl = el('div', { id: 'plots' });
    document.body.append(this.viewEl, info, legend, banner, controls, this.plotsEl);
    window.addEventListener('keydown', (e) => {
      if (e.target instanceof HTMLSelectElement || e.target instanceof HTMLInputElement && e.target.type !== 'range') return;
      if (e.key === ' ') { this.togglePlay(); e.preventDefault(); }
      else if (e.key === 'ArrowRight') { this.pause(); this.seek(this.index + 1); e.preventDefault(); }
      else if (e.key === 'ArrowLeft') { this.pause(); this.seek(this.index - 1); e.preventDefault(); }
      else if (e.key === 'Home') { this.pause(); this.seek(0); }
      else if (e.key === 'End') { this.pause(); this.seek(this.frameList.length - 1); }
    });
  }

  buildScene() {
    const renderer = new THREE.WebGLRenderer({ antialias: true, preserveDrawingBuffer: true });
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setClearColor(0x1f2329);
    this.viewEl.append(renderer.domElement);
    this.renderer = renderer;
    const scene = new THREE.Scene();
    this.scene = scene;
    const up = this.meta.run.up || [0, 0, 1];
    this.up = new THREE.Vector3(up[0], up[1], up[2]).normalize();
    this.camera = new THREE.PerspectiveCamera(35, 1, 1e-3, 1e3);
    this.camera.up.copy(this.up);
    this.controls = new OrbitControls(this.camera, renderer.domElement);
    this.controls.addEventListener('change', () => this.render());
    scene.add(new THREE.HemisphereLight(0xffffff, 0x40444c, 1.6));
    this.light = new THREE.DirectionalLight(0xffffff, 1.4);
    scene.add(this.light);
    scene.add(this.light.target);

    this.surface = new THREE.BufferGeometry();
    this.litMaterial = new THREE.MeshPhongMaterial({ vertexColors: true, side: THREE.DoubleSide, flatShading: true,
      shininess: 12, polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
    this.flatMaterial = new THREE.MeshBasicMaterial({ vertexColors: true, side: THREE.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1 });
    this.mesh = new THREE.Mesh(this.surface, this.litMaterial);
    scene.add(this.mesh);

    // Borders as screen-space lines of 2.5 px (WebGL's own lines are 1 px wide).
    this.borderMaterial = new LineMaterial({ vertexColors: true, linewidth: 2.5 });
    this.borders = new LineSegments2(new LineSegmentsGeometry(), this.borderMaterial);
    scene.add(this.borders);
    this.springGeometry = new THREE.BufferGeometry();
    this.springs = new THREE.LineSegments(this.springGeometry,
      new THREE.LineBasicMaterial({ color: 0xd8dde5, transparent: true, opacity: 0.35 }));
    scene.add(this.springs);
    this.stitchGeometry = new THREE.BufferGeometry();
    this.stitches = new THREE.LineSegments(this.stitchGeometry,
      new THREE.LineBasicMaterial({ color: 0x3ddc84, depthTest: false }));
    this.stitches.renderOrder = 2;
    scene.add(this.stitches);
    this.wireGeometry = new THREE.BufferGeometry();
    this.wire = new THREE.LineSegments(this.wireGeometry,
      new THREE.LineBasicMaterial({ color: 0x000000, transparent: true, opacity: 0.35 }));
    scene.add(this.wire);
    this.heldGeometry = new THREE.BufferGeometry();
    this.held = new THREE.Points(this.heldGeometry, new THREE.PointsMaterial({ size: 6, sizeAttenuation: false, vertexColors: true }));
    scene.add(this.held);
    this.obstacleGeometry = new THREE.BufferGeometry();
    this.obstacles = new THREE.Mesh(this.obstacleGeometry, new THREE.MeshPhongMaterial({ color: 0x8b95a3,
      transparent: true, opacity: 0.45, side: THREE.DoubleSide, depthWrite: false }));
    scene.add(this.obstacles);
    this.instrumentGeometry = new THREE.BufferGeometry();
    this.instruments = new THREE.LineSegments(this.instrumentGeometry,
      new THREE.LineBasicMaterial({ color: 0xffd23f, depthTest: false }));
    this.instruments.renderOrder = 2;
    scene.add(this.instruments);
    this.tipGeometry = new THREE.BufferGeometry();
    this.tips = new THREE.Points(this.tipGeometry, new THREE.PointsMaterial({ color: 0xffd23f, size: 7,
      sizeAttenuation: false, depthTest: false }));
    this.tips.renderOrder = 2;
    scene.add(this.tips);

    // Their geometries change with every frame: never culled by a bounding sphere of another frame.
    for (const o of [this.borders, this.springs, this.stitches, this.wire, this.held, this.obstacles, this.instruments, this.tips]) o.frustumCulled = false;
    this.raycaster = new THREE.Raycaster();
    const resize = () => {
      const w = this.viewEl.clientWidth, h = Math.max(1, this.viewEl.clientHeight);
      renderer.setSize(w, h, false);
      this.borderMaterial.resolution.set(w, h);
      this.camera.aspect = w / h;
      this.camera.updateProjectionMatrix();
      for (const p of this.plots || []) p.resize();
      this.render();
    };
    window.addEventListener('resize', resize);
    this.resize = resize;
    resize();
  }

  buildPlots() {
    const names = this.meta.series.names || [];
    const columns = this.meta.series.columns || [];
    this.seriesData = {};
    names.forEach((n, i) => { this.seriesData[n] = this.array(Float64Array, columns[i]); });
    const time = this.seriesData.time;
    const groups = [];
    const pick = (re) => names.filter((n) => n !== 'time' && re.test(n));
    const energy = pick(/^kinetic_energy$|^potential_|^gravity_energy$/);
    if (energy.length) groups.push({ name: 'energies (J)', columns: energy });
    // The energy accounts (docs/energy.md): cumulative, then per step.
    const accounts = pick(/^energy_stored$|^work_(gravity|constraints|contact)$|^dissipated_damping$|^energy_removed$|^energy_drift$/);
    if (accounts.length) groups.push({ name: 'energy accounts (J)', columns: accounts });
    const perStep = pick(/^step_(work_(gravity|constraints|contact)|dissipated_damping|energy_removed|energy_drift)$/);
    if (perStep.length) groups.push({ name: 'energy accounts per step (J)', columns: perStep });
    const solver = pick(/^solver_iterations$|^newton_iterations$/);
    if (solver.length) groups.push({ name: 'solver iterations', columns: solver });
    const residual = pick(/^solver_residual$/);
    if (residual.length) groups.push({ name: 'solver residual (log)', columns: residual, log: true });
    const grasp = pick(/_f[xyz]$/);
    if (grasp.length) groups.push({ name: 'grasp forces (N)', columns: grasp });
    const contact = pick(/_normal_force$|_friction_force$/);
    if (contact.length) groups.push({ name: 'contact forces (N)', columns: contact });
    const counts = pick(/^points$|^edges$|^triangles$|^active_springs$/);
    if (counts.length) groups.push({ name: 'counts', columns: counts });
    this.plots = [];
    if (!time || groups.length === 0) {
      const why = names.length === 0 ? 'no steps.csv in this run' : 'steps.csv has no time column or no series to plot';
      this.plotsEl.append(el('div', { style: 'padding: 12px; color: #8a929c' }, `${why}: no plots`));
      return;
    }
    // A run that keeps energy accounts asked for them: they come first.
    const defaults = [groups.find((g) => g.name === 'energy accounts (J)') || groups[0], groups.find((g) => g.name.startsWith('grasp')) || groups.find((g) => g.name.startsWith('contact')) ||
      groups.find((g) => g.name === 'solver iterations') || groups[1] || groups[0]];
    for (let k = 0; k < 2; k++) {
      const box = el('div', { class: 'plot' });
      const select = el('select', {});
      groups.forEach((g, i) => select.append(el('option', { value: i }, g.name)));
      select.value = String(groups.indexOf(defaults[k]));
      const canvas = el('canvas', {});
      box.append(select, canvas);
      this.plotsEl.append(box);
      const plot = new Plot(canvas, time);
      const set = () => {
        const g = groups[Number(select.value)];
        plot.setSeries(g.columns.map((c) => ({ name: c, values: this.seriesData[c] })), g.log);
        plot.setCursor(this.current().t);
      };
      select.addEventListener('change', set);
      canvas.addEventListener('click', (e) => {
        const t = plot.timeAt(e.offsetX);
        if (t === null) return;
        let best = 0;
        this.frameList.forEach((f, i) => { if (Math.abs(f.t - t) < Math.abs(this.frameList[best].t - t)) best = i; });
        this.pause();
        this.seek(best);
      });
      set();
      this.plots.push(plot);
    }
    requestAnimationFrame(() => this.plots.forEach((p) => p.resize()));
  }

  computeRanges() {
    // Per field: from min(0, the lowest value) to the 99.5th percentile of the values of all
    // frames (sampled): a few extreme triangles at a crack's tip do not wash out the rest.
    for (const name of Object.keys(FIELDS)) {
      const sample = [];
      for (const f of this.frameList) {
        const a = this.array(Float32Array, f[name]);
        if (!a) continue;
        const step = Math.max(1, Math.floor(a.length / 2000));
        for (let i = 0; i < a.length; i += step) sample.push(a[i]);
      }
      if (!sample.length) continue;
      let hi = quantile(sample, 0.995);
      const lo = Math.min(0, quantile(sample, 0.005));
      if (!(hi > lo)) hi = lo + 1e-12;
      this.ranges[name] = [lo, hi];
    }
  }

  fitCamera() {
    // Points of every frame (a sample of each); the view frames all of them: playing never
    // leaves the view, and nothing is wasted on the empty corners of their bounding box.
    const samples = [];
    for (const f of this.frameList) {
      const x = this.array(Float32Array, f.x);
      const n = x.length / 3;
      const step = Math.max(1, Math.floor(n / Math.max(50, 200000 / this.frameList.length)));
      for (let p = 0; p < n; p += step) samples.push(new THREE.Vector3(x[3 * p], x[3 * p + 1], x[3 * p + 2]));
      if (n) samples.push(new THREE.Vector3(x[3 * n - 3], x[3 * n - 2], x[3 * n - 1]));
    }
    if (samples.length === 0) samples.push(new THREE.Vector3(0, 0, 0), new THREE.Vector3(1, 1, 0));  // no point at all
    // A three-quarter view from above the horizon.
    const up = this.up;
    const h1 = new THREE.Vector3(1, 0, 0);
    if (Math.abs(h1.dot(up)) > 0.9) h1.set(0, 1, 0);
    h1.sub(up.clone().multiplyScalar(h1.dot(up))).normalize();
    const h2 = new THREE.Vector3().crossVectors(up, h1).normalize();
    const threeQuarter = h1.clone().multiplyScalar(0.45).addScaledVector(h2, -0.8).addScaledVector(up, 0.5).normalize();
    // Turned towards the surface's face: the normal of the plane nearest to all the points (the
    // axis of their least spread), on the three-quarter view's side. A sheet is seen from above
    // its face, not edge-on.
    const normal = leastSpreadAxis(samples);
    if (normal.dot(threeQuarter) < 0) normal.negate();
    const back = normal.clone().addScaledVector(threeQuarter, 0.9).normalize();
    if (Math.abs(back.dot(up)) > 0.97) back.addScaledVector(h2, -0.3).normalize();  // not straight down the up axis
    const right = new THREE.Vector3().crossVectors(up, back).normalize();
    const upView = new THREE.Vector3().crossVectors(back, right).normalize();
    // The target: the middle of the points' extents across and up the view, and in depth.
    const lo = [Infinity, Infinity, Infinity], hi = [-Infinity, -Infinity, -Infinity];
    for (const p of samples) {
      const c = [p.dot(right), p.dot(upView), p.dot(back)];
      for (let k = 0; k < 3; k++) { lo[k] = Math.min(lo[k], c[k]); hi[k] = Math.max(hi[k], c[k]); }
    }
    const mid = [0, 1, 2].map((k) => (lo[k] + hi[k]) / 2);
    const center = right.clone().multiplyScalar(mid[0]).addScaledVector(upView, mid[1]).addScaledVector(back, mid[2]);
    // The nearest camera distance at which every point is inside the frustum, with a margin.
    const tanV = Math.tan(THREE.MathUtils.degToRad(this.camera.fov / 2));
    const tanH = tanV * this.camera.aspect;
    let distance = 1e-6;
    for (const p of samples) {
      const depth = p.dot(back) - mid[2];
      distance = Math.max(distance, depth + Math.abs(p.dot(right) - mid[0]) / tanH,
        depth + Math.abs(p.dot(upView) - mid[1]) / tanV);
    }
    distance *= 1.04;
    this.camera.position.copy(center).addScaledVector(back, distance);
    this.camera.near = distance / 100;
    this.camera.far = distance * 100;
    this.camera.updateProjectionMatrix();
    this.controls.target.copy(center);
    this.controls.update();
    this.light.position.copy(center).addScaledVector(back, distance).addScaledVector(up, distance);
    this.light.target.position.copy(center);
  }

  // ---------------------------------------------------------------------------------------------
  // Frames

  current() { return this.frameList[this.index]; }

  seek(i) {
    this.index = Math.max(0, Math.min(this.frameList.length - 1, Math.round(i)));
    this.scrubber.value = String(this.index);
    const f = this.current();
    this.playTime = f.t;
    this.x = this.array(Float32Array, f.x);
    this.tri = this.array(Uint32Array, f.tri);
    this.updateSurface();
    this.updateLines();
    this.updateColors();
    this.updateInfo();
    for (const p of this.plots) p.setCursor(f.t);
    this.render();
  }

  updateSurface() {
    const x = this.x, tri = this.tri;
    const pos = new Float32Array(tri.length * 3);
    for (let k = 0; k < tri.length; k++) {
      const p = 3 * tri[k];
      pos[3 * k] = x[p]; pos[3 * k + 1] = x[p + 1]; pos[3 * k + 2] = x[p + 2];
    }
    this.surface.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    if (!this.surface.getAttribute('color') || this.surface.getAttribute('color').count !== tri.length)
      this.surface.setAttribute('color', new THREE.BufferAttribute(new Float32Array(tri.length * 3), 3));
    this.surface.computeBoundingSphere();
    // Triangle edges (each drawn once per triangle side: interior edges twice, cheap enough).
    if (this.show.wireframe) {
      const w = new Float32Array(tri.length * 6);
      for (let k = 0; k < tri.length; k += 3) {
        for (let s = 0; s < 3; s++) {
          const a = 3 * tri[k + s], b = 3 * tri[k + (s + 1) % 3], o = 6 * (k + s);
          w[o] = x[a]; w[o + 1] = x[a + 1]; w[o + 2] = x[a + 2];
          w[o + 3] = x[b]; w[o + 4] = x[b + 1]; w[o + 5] = x[b + 2];
        }
      }
      this.wireGeometry.setAttribute('position', new THREE.BufferAttribute(w, 3));
    }
  }

  segments(ref) {
    const idx = this.array(Uint32Array, ref);
    if (!idx) return null;
    const out = new Float32Array(idx.length * 3);
    for (let k = 0; k < idx.length; k++) {
      const p = 3 * idx[k];
      out[3 * k] = this.x[p]; out[3 * k + 1] = this.x[p + 1]; out[3 * k + 2] = this.x[p + 2];
    }
    return out;
  }

  updateLines() {
    const f = this.current();
    const b = this.segments(f.border);
    this.borders.geometry.dispose();
    this.borders.geometry = new LineSegmentsGeometry();
    if (b && b.length) {
      // Outer border light grey, the sides of cuts and tears magenta (not a colour of the map).
      const lip = this.array(Uint8Array, f.lip);
      const c = new Float32Array(b.length);
      for (let e = 0; e < lip.length; e++) {
        const rgb = lip[e] ? LIP_COLOR : BORDER_COLOR;
        for (let s = 0; s < 2; s++) c.set(rgb, 6 * e + 3 * s);
      }
      this.borders.geometry.setPositions(b);
      this.borders.geometry.setColors(c);
    }
    this.springGeometry.setAttribute('position', new THREE.BufferAttribute(this.segments(f.spring) || new Float32Array(0), 3));
    this.stitchGeometry.setAttribute('position', new THREE.BufferAttribute(this.segments(f.stitch) || new Float32Array(0), 3));
    const held = this.array(Uint8Array, f.held);
    const hp = [], hc = [];
    if (held) {
      for (let p = 0; p < held.length; p++) {
        if (!held[p]) continue;
        hp.push(this.x[3 * p], this.x[3 * p + 1], this.x[3 * p + 2]);
        if (held[p] === 1) hc.push(0.9, 0.9, 0.9); else hc.push(1.0, 0.35, 0.0);
      }
    }
    this.heldGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(hp), 3));
    this.heldGeometry.setAttribute('color', new THREE.BufferAttribute(new Float32Array(hc), 3));
    const ox = this.array(Float32Array, f.obstacleX), ot = this.array(Uint32Array, f.obstacleTri);
    if (ox && ot) {
      this.obstacleGeometry.setAttribute('position', new THREE.BufferAttribute(ox, 3));
      this.obstacleGeometry.setIndex(new THREE.BufferAttribute(ot, 1));
      this.obstacleGeometry.computeVertexNormals();
    } else {
      this.obstacleGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(0), 3));
      this.obstacleGeometry.setIndex(null);
    }
    // Instruments: segments from their tips (two points each), drawn over the surface; a tip is
    // marked where a chain of segments starts (a blade's; a cautery's wire sphere is chains).
    const ix = this.array(Float32Array, f.instrumentX) || new Float32Array(0);
    this.instrumentGeometry.setAttribute('position', new THREE.BufferAttribute(ix, 3));
    const marked = [];
    for (let k = 0; 6 * k < ix.length; k++) {
      const continues = k > 0 && ix[6 * k] === ix[6 * k - 3] && ix[6 * k + 1] === ix[6 * k - 2] &&
        ix[6 * k + 2] === ix[6 * k - 1];
      if (!continues) marked.push(ix[6 * k], ix[6 * k + 1], ix[6 * k + 2]);
    }
    this.tipGeometry.setAttribute('position', new THREE.BufferAttribute(new Float32Array(marked), 3));
    this.applyVisibility();
  }

  applyVisibility() {
    this.borders.visible = this.show.borders;
    this.springs.visible = this.show.springs;
    this.stitches.visible = this.show.stitches;
    this.held.visible = this.show.held;
    this.obstacles.visible = this.show.obstacles;
    this.instruments.visible = this.tips.visible = this.show.instruments;
    this.wire.visible = this.show.wireframe;
    if (this.show.wireframe && this.x) this.updateSurface();
  }

  range() {
    if (this.rangeMode === 'frame') {
      const a = this.array(Float32Array, this.current()[this.field]);
      if (a && a.length) {
        let lo = 0, hi = -Infinity;
        for (const v of a) { lo = Math.min(lo, v); hi = Math.max(hi, v); }
        return [lo, hi > lo ? hi : lo + 1e-12];
      }
    }
    return this.ranges[this.field] || [0, 1];
  }

  updateColors() {
    const values = this.array(Float32Array, this.current()[this.field]);
    const color = this.surface.getAttribute('color');
    const [lo, hi] = this.range();
    const c = color.array;
    const rgb = [0, 0, 0];
    const n = this.tri.length / 3;
    for (let k = 0; k < n; k++) {
      const v = values ? values[k] : 0;
      colormap((v - lo) / (hi - lo), rgb);
      for (let s = 0; s < 3; s++) {
        c[9 * k + 3 * s] = rgb[0]; c[9 * k + 3 * s + 1] = rgb[1]; c[9 * k + 3 * s + 2] = rgb[2];
      }
    }
    color.needsUpdate = true;
    this.drawColorbar(lo, hi);
  }

  drawColorbar(lo, hi) {
    const ctx = this.colorbar.getContext('2d');
    const h = this.colorbar.height, w = this.colorbar.width;
    for (let y = 0; y < h; y++) {
      ctx.fillStyle = colormapCss(1 - y / (h - 1));
      ctx.fillRect(0, y, w, 1);
    }
    this.ticksEl.textContent = '';
    const unit = FIELDS[this.field].unit;
    for (let i = 0; i <= 4; i++) {
      const v = hi - (i / 4) * (hi - lo);
      const span = el('span', {}, fmt(v, 3) + (i === 0 && unit ? ' ' + unit : ''));
      span.style.top = `${(i / 4) * 100}%`;
      this.ticksEl.append(span);
    }
  }

  updateInfo() {
    const f = this.current();
    const run = this.meta.run;
    const lines = [
      // Frames count from 0, as --png N and #frame=N do.
      `t = ${fmt(f.t, 6)} s    frame ${this.index} (0 to ${this.frameList.length - 1})` +
        (run.framesShown < run.framesInRun ? `, the run's frame ${run.frameIndices[this.index]} (0 to ${run.framesInRun - 1})` : ''),
      `${f.points} points, ${f.triangles} triangles`,
      f.borders === null || f.borders === undefined ? 'border edges: not in this run\'s frames'
        : `${f.borders} border edges, ${f.lipEdges} opened by cuts, tears or removals`,
    ];
    const held = f.fixed || f.grasped ? `${f.fixed} fixed, ${f.grasped} grasped points` : '';
    const springs = this.hasSprings ? `${f.springs} bending springs` : '';
    if (springs || held) lines.push([springs, held].filter(Boolean).join(', '));
    const row = f.row ?? -1;
    if (row >= 0) {
      const s = this.seriesData;
      const pot = Object.keys(s).filter((n) => n.startsWith('potential_')).reduce((a, n) => a + s[n][row], 0);
      lines.push(`kinetic ${fmt(s.kinetic_energy?.[row])} J, potential ${fmt(pot)} J`);
      if (s.solver_iterations) lines.push(`solver: ${s.solver_iterations[row]} iterations, residual ${fmt(s.solver_residual?.[row], 3)}`);
    }
    this.countsEl.textContent = lines.join('\n');
    this.timeEl.textContent = `t = ${fmt(f.t, 5)} s`;
  }

  // ---------------------------------------------------------------------------------------------
  // Controls

  setField(name) {
    if (!FIELDS[name]) throw new Error(`no field ${name}`);
    this.field = name;
    this.fieldSelect.value = name;
    this.updateColors();
    this.render();
  }

  setRange(mode) {
    this.rangeMode = mode === 'frame' ? 'frame' : 'run';
    this.rangeSelect.value = this.rangeMode;
    this.updateColors();
    this.render();
  }

  setLit(lit) {
    this.lit = !!lit;
    this.litBox.checked = this.lit;
    this.mesh.material = this.lit ? this.litMaterial : this.flatMaterial;
    this.render();
  }

  togglePlay() { if (this.playing) this.pause(); else this.play(); }

  play() {
    if (this.index === this.frameList.length - 1) this.seek(0);
    this.playing = true;
    this.lastTick = performance.now();
    this.playButton.replaceChildren(icon('pause'));
  }

  pause() {
    this.playing = false;
    this.playButton.replaceChildren(icon('play'));
  }

  loop() {
    requestAnimationFrame(() => this.loop());
    if (!this.playing) return;
    const now = performance.now();
    const dt = (now - this.lastTick) / 1000;
    this.lastTick = now;
    this.playTime += dt * this.speed;
    let i = this.index;
    while (i + 1 < this.frameList.length && this.frameList[i + 1].t <= this.playTime) i++;
    if (i !== this.index) {
      const t = this.playTime;
      this.seek(i);
      this.playTime = t;
    }
    if (i === this.frameList.length - 1) this.pause();
  }

  render() { if (this.renderer) this.renderer.render(this.scene, this.camera); }

  // ---------------------------------------------------------------------------------------------
  // For tests and scripts

  /// Canvas coordinates (CSS pixels, relative to the page) of triangle k's centroid, and whether
  /// the triangle is the first surface hit there.
  project(k) {
    const x = this.x, tri = this.tri;
    const c = new THREE.Vector3();
    for (let s = 0; s < 3; s++) {
      const p = 3 * tri[3 * k + s];
      c.x += x[p] / 3; c.y += x[p + 1] / 3; c.z += x[p + 2] / 3;
    }
    const ndc = c.clone().project(this.camera);
    const rect = this.renderer.domElement.getBoundingClientRect();
    this.raycaster.setFromCamera(new THREE.Vector2(ndc.x, ndc.y), this.camera);
    const hits = this.raycaster.intersectObject(this.mesh, false);
    const visible = hits.length > 0 && hits[0].faceIndex === k && ndc.z < 1 && Math.abs(ndc.x) < 1 && Math.abs(ndc.y) < 1;
    return { x: rect.left + (ndc.x + 1) / 2 * rect.width, y: rect.top + (1 - ndc.y) / 2 * rect.height, visible };
  }

  /// The k triangles of the current frame with the largest values of the shown field.
  hotTriangles(k) {
    const values = this.array(Float32Array, this.current()[this.field]);
    if (!values) return [];
    const order = Array.from(values.keys()).sort((a, b) => values[b] - values[a]).slice(0, k);
    const [lo, hi] = this.range();
    return order.map((t) => ({ triangle: t, value: values[t], barPosition: (values[t] - lo) / (hi - lo), ...this.project(t) }));
  }
}

function main() {
  const metaEl = document.getElementById('cutsim-meta');
  const dataEl = document.getElementById('cutsim-data');
  try {
    if (!metaEl || !dataEl) throw new Error('this page holds no run (no #cutsim-meta or #cutsim-data)');
    const meta = JSON.parse(metaEl.textContent);
    const buffer = decodeBase64(dataEl.textContent);
    dataEl.textContent = '';  // the decoded blob is kept; the text is not needed any more
    if (!meta.frames || meta.frames.length === 0) throw new Error('the run has no frames');
    const player = new Player(meta, buffer);
    window.cutsimPlayer = {
      ready: true,
      meta,
      frames: () => meta.frames.map((f) => ({ t: f.t, points: f.points, triangles: f.triangles, row: f.row, csvRow: f.csvRow,
        borders: f.borders, lipEdges: f.lipEdges, springs: f.springs })),
      seek: (i) => player.seek(i),
      get frame() { return player.index; },
      setLit: (v) => player.setLit(v),
      setField: (n) => player.setField(n),
      setRange: (m) => player.setRange(m),
      range: () => player.range(),
      project: (k) => player.project(k),
      hotTriangles: (k) => player.hotTriangles(k),
      series: (name) => (player.seriesData[name] ? Array.from(player.seriesData[name]) : null),
      colorbarBox: () => { const r = player.colorbar.getBoundingClientRect(); return { x: r.left, y: r.top, width: r.width, height: r.height }; },
      play: () => player.play(),
      pause: () => player.pause(),
      player,  // the internals (three.js scene, camera, controls), for scripts
    };
    document.title = `${meta.run.name} - cutsim`;
  } catch (e) {
    const box = el('div', { id: 'error' }, `cutsim player: ${e.message}`);
    box.style.display = 'flex';
    document.body.append(box);
    window.cutsimPlayer = { ready: false, error: String(e.message) };
  }
}

main();
