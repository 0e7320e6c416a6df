// reefgen studio page: paint a sketch or drag the curve generator's inputs;
// every change asks the local server for heights and redraws the island.
// No framework: one canvas per editor, three.js for the 3D view.
const $ = (id) => document.getElementById(id);
const status = (text) => { $('status').textContent = text; };

// Exposed for the browser tests and the benchmark: what was drawn, and when.
const probe = { updates: 0, timings: [], lastSum: 0, errors: [] };
window.__reefgen = probe;

// ---------- the label palette (docs/DESIGN.md §2: hue per region, value = 1 − 0.75·subsidence)
const REGIONS = [
  { id: 0, name: 'island', rgb: [1, 1, 0] },
  { id: 1, name: 'beach', rgb: [0, 1, 0] },
  { id: 2, name: 'lagoon', rgb: [0, 1, 1] },
  { id: 3, name: 'reef', rgb: [0, 0, 1] },
  { id: 4, name: 'abyss', rgb: [1, 0, 0] },
];
const ABYSS = 4;
function regionColour(id, subsidence) {
  const v = Math.round(255 * (1 - 0.75 * subsidence));
  return REGIONS[id].rgb.map((c) => c * v);
}

// ---------- talking to the server
let latestRequest = 0;
async function api(path, body, contentType) {
  const res = await fetch(path, { method: body === undefined ? 'GET' : 'POST', body,
    headers: contentType ? { 'Content-Type': contentType } : {} });
  if (res.status === 409) return null;  // a newer stroke overtook this one: nothing to draw
  if (!res.ok) {
    let msg = res.statusText;
    try { msg = (await res.json()).error; } catch (e) { /* not JSON */ }
    throw new Error(msg);
  }
  return res;
}
// The server's heights answer: [uint32 n][n bytes JSON][size² float32], little-endian.
async function readHeights(res) {
  const buf = await res.arrayBuffer();
  const n = new DataView(buf).getUint32(0, true);
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  return { meta, h: new Float32Array(buf, 4 + n, meta.size * meta.size) };
}
async function runUpdate(makeRequest, t0) {
  const id = ++latestRequest, forMode = mode;
  try {
    const res = await makeRequest();
    if (!res) return;
    const { meta: j, h } = await readHeights(res);
    const t1 = performance.now();
    if (id !== latestRequest || forMode !== mode) return;  // an older answer, or the other mode's
    showHeights(h, j.size, j);
    if (j.label_png) showLabel(j.label_png);
    const t2 = performance.now();
    await new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(() => r())));  // drawn (the frame after)
    const ms = performance.now() - t0;
    probe.updates += 1;
    probe.timings.push({ total_ms: ms, server_ms: j.ms, encode_ms: probe.encode_ms || 0, response_ms: t1 - t0, update_ms: t2 - t1, draw_ms: performance.now() - t2 });
    probe.lastSum = h.reduce((a, b) => a + b, 0);
    $('view3d').dataset.updates = String(probe.updates);
    status(`${j.size}² · ${j.min_m.toFixed(0)}…${j.max_m.toFixed(0)} m · updated in ${ms.toFixed(0)} ms (server ${j.ms.toFixed(0)} ms)`);
  } catch (e) {
    probe.errors.push(String(e.message || e));
    status('error: ' + (e.message || e));
  }
}

// ---------- paint mode
const paint = $('paint');
const pctx = paint.getContext('2d', { willReadFrequently: true });
let region = 0, tool = 'brush';
const undoStack = [], redoStack = [];
function age() { return Number($('age').value) / 100; }
function clearCanvas() {
  const [r, g, b] = regionColour(ABYSS, age());
  pctx.fillStyle = `rgb(${r},${g},${b})`;
  pctx.fillRect(0, 0, paint.width, paint.height);
}
function snapshot() {
  undoStack.push(pctx.getImageData(0, 0, paint.width, paint.height));
  if (undoStack.length > 40) undoStack.shift();
  redoStack.length = 0;
}
function restore(from, to) {
  if (!from.length) return;
  to.push(pctx.getImageData(0, 0, paint.width, paint.height));
  const img = from.pop();
  if (img.width !== paint.width) { paint.width = paint.height = img.width; }
  pctx.putImageData(img, 0, 0);
  requestInfer();
}
function brushColour() { return regionColour(tool === 'eraser' ? ABYSS : region, age()); }
function dab(x, y) {
  const radius = Number($('brush').value) * paint.width / 256;
  const soft = Number($('softness').value) / 100;
  const [r, g, b] = brushColour();
  const grad = pctx.createRadialGradient(x, y, radius * (1 - soft), x, y, radius);
  grad.addColorStop(0, `rgba(${r},${g},${b},1)`);
  grad.addColorStop(1, `rgba(${r},${g},${b},0)`);
  pctx.fillStyle = soft > 0 ? grad : `rgb(${r},${g},${b})`;
  pctx.beginPath();
  pctx.arc(x, y, radius, 0, 2 * Math.PI);
  pctx.fill();
}
function canvasPoint(ev, canvas) {
  const rect = canvas.getBoundingClientRect();
  return [(ev.clientX - rect.left) * canvas.width / rect.width, (ev.clientY - rect.top) * canvas.height / rect.height];
}
function floodFill(x0, y0) {
  const W = paint.width, H = paint.height;
  const img = pctx.getImageData(0, 0, W, H), d = img.data;
  const at = (x, y) => 4 * (y * W + x);
  const start = at(Math.floor(x0), Math.floor(y0));
  const target = [d[start], d[start + 1], d[start + 2]];
  const [r, g, b] = brushColour();
  if (target[0] === r && target[1] === g && target[2] === b) return;
  const close = (i) => Math.abs(d[i] - target[0]) + Math.abs(d[i + 1] - target[1]) + Math.abs(d[i + 2] - target[2]) < 48;
  const stack = [[Math.floor(x0), Math.floor(y0)]];
  const seen = new Uint8Array(W * H);
  while (stack.length) {
    const [x, y] = stack.pop();
    if (x < 0 || y < 0 || x >= W || y >= H || seen[y * W + x]) continue;
    seen[y * W + x] = 1;
    const i = at(x, y);
    if (!close(i)) continue;
    d[i] = r; d[i + 1] = g; d[i + 2] = b; d[i + 3] = 255;
    stack.push([x + 1, y], [x - 1, y], [x, y + 1], [x, y - 1]);
  }
  pctx.putImageData(img, 0, 0);
}
let painting = false, last = null;
paint.addEventListener('pointerdown', (ev) => {
  const [x, y] = canvasPoint(ev, paint);
  snapshot();
  if (tool === 'fill') { floodFill(x, y); requestInfer(); return; }
  painting = true; last = [x, y];
  paint.setPointerCapture(ev.pointerId);
  dab(x, y);
});
paint.addEventListener('pointermove', (ev) => {
  if (!painting) return;
  const [x, y] = canvasPoint(ev, paint);
  const steps = Math.max(1, Math.ceil(Math.hypot(x - last[0], y - last[1]) / 2));
  for (let s = 1; s <= steps; ++s) dab(last[0] + (x - last[0]) * s / steps, last[1] + (y - last[1]) * s / steps);
  last = [x, y];
});
const endStroke = () => { if (painting) { painting = false; requestInfer(); } };
paint.addEventListener('pointerup', endStroke);
paint.addEventListener('pointercancel', endStroke);

function sketchBlob() { return new Promise((r) => paint.toBlob(r, 'image/png')); }
function requestInfer() {
  const t0 = performance.now();
  runUpdate(async () => {
    const blob = await sketchBlob();
    probe.encode_ms = performance.now() - t0;
    return api('/api/infer', blob, 'image/png');
  }, t0);
}

// ---------- curves mode: the Figure-3 inputs, dragged directly
const curves = $('curves');
const cctx = curves.getContext('2d');
const K = 12;  // control radii per outline
let spec = null, labelImage = null, drag = null, windDraft = null, defaults = null;
function defaultSpec() {
  return { outlines: [0.3, 0.38, 0.55, 0.68, 0.98], wind: [], subsidence: 0 };
}
function expand(o) { return Array.isArray(o) ? resample(o, K) : new Array(K).fill(o); }
function resample(a, n) {  // periodic linear resampling of radii to n control points
  return Array.from({ length: n }, (_, k) => {
    const t = k * a.length / n, i = Math.floor(t), f = t - i;
    return a[i % a.length] * (1 - f) + a[(i + 1) % a.length] * f;
  });
}
function loadSpec(s) {
  spec = JSON.parse(JSON.stringify(s));
  delete spec.description;
  spec.outlines = spec.outlines.map(expand);
  spec.wind = spec.wind || [];
  // Missing curves are the paper's (GET /api/defaults), shown and editable.
  spec.profile = spec.profile || (defaults && defaults.profile.slice()) || null;
  spec.resistance = spec.resistance || (defaults && defaults.resistance.slice()) || null;
  $('subsidence').value = Math.round(100 * (spec.subsidence || 0));
  drawCurves();
  drawCurveEditor('profile');
  drawCurveEditor('resistance');
}
const toCanvas = ([x, y]) => [(x + 1) / 2 * curves.width, (1 - y) / 2 * curves.height];  // +y up
const fromCanvas = ([px, py]) => [px / curves.width * 2 - 1, 1 - py / curves.height * 2];
function handlePoint(ring, k) {
  const th = 2 * Math.PI * k / K, r = spec.outlines[ring][k];
  return toCanvas([r * Math.cos(th), r * Math.sin(th)]);
}
function catmull(p0, p1, p2, p3, t) {
  const t2 = t * t, t3 = t2 * t;
  return 0.5 * (2 * p1 + (-p0 + p2) * t + (2 * p0 - 5 * p1 + 4 * p2 - p3) * t2 + (-p0 + 3 * p1 - 3 * p2 + p3) * t3);
}
function drawCurves() {
  cctx.clearRect(0, 0, curves.width, curves.height);
  if (labelImage) cctx.drawImage(labelImage, 0, 0, curves.width, curves.height);
  const ringColours = ['#ff0', '#0f0', '#0ff', '#48f', '#f44'];
  spec.outlines.forEach((radii, ring) => {
    cctx.strokeStyle = ringColours[ring];
    cctx.lineWidth = 1.5;
    cctx.beginPath();
    for (let s = 0; s <= K * 8; ++s) {
      const k = Math.floor(s / 8) % K, t = (s % 8) / 8;
      const r = catmull(radii[(k + K - 1) % K], radii[k], radii[(k + 1) % K], radii[(k + 2) % K], t);
      const th = 2 * Math.PI * (k + t) / K;
      const [x, y] = toCanvas([r * Math.cos(th), r * Math.sin(th)]);
      s ? cctx.lineTo(x, y) : cctx.moveTo(x, y);
    }
    cctx.stroke();
    for (let k = 0; k < K; ++k) {
      const [x, y] = handlePoint(ring, k);
      cctx.fillStyle = ringColours[ring];
      cctx.fillRect(x - 3, y - 3, 6, 6);
    }
  });
  cctx.strokeStyle = '#fff';
  cctx.lineWidth = 2;
  for (const w of spec.wind.concat(windDraft ? [windDraft] : [])) {
    cctx.beginPath();
    w.points.forEach((p, i) => { const [x, y] = toCanvas(p); i ? cctx.lineTo(x, y) : cctx.moveTo(x, y); });
    cctx.stroke();
    const [ax, ay] = toCanvas(w.points[w.points.length - 1]);
    cctx.beginPath(); cctx.arc(ax, ay, 4, 0, 2 * Math.PI); cctx.fillStyle = '#fff'; cctx.fill();
  }
}
curves.addEventListener('contextmenu', (ev) => {
  ev.preventDefault();
  const p = fromCanvas(canvasPoint(ev, curves));
  const i = spec.wind.findIndex((w) => w.points.some((q) => Math.hypot(q[0] - p[0], q[1] - p[1]) < 0.08));
  if (i >= 0) { spec.wind.splice(i, 1); drawCurves(); requestGenerate(); }
});
curves.addEventListener('pointerdown', (ev) => {
  if (ev.button !== 0) return;
  const pt = canvasPoint(ev, curves);
  curves.setPointerCapture(ev.pointerId);
  if (ev.shiftKey) { windDraft = { points: [fromCanvas(pt)], strength: 0.3, width: 0.15 }; return; }
  let best = null;
  spec.outlines.forEach((_, ring) => {
    for (let k = 0; k < K; ++k) {
      const [x, y] = handlePoint(ring, k), d = Math.hypot(x - pt[0], y - pt[1]);
      if (d < 10 && (!best || d < best.d)) best = { ring, k, d };
    }
  });
  drag = best;
});
curves.addEventListener('pointermove', (ev) => {
  const pt = canvasPoint(ev, curves);
  if (windDraft) {
    const p = fromCanvas(pt), q = windDraft.points[windDraft.points.length - 1];
    if (Math.hypot(p[0] - q[0], p[1] - q[1]) > 0.05) windDraft.points.push(p);
    drawCurves();
    return;
  }
  if (!drag) return;
  const [x, y] = fromCanvas(pt);
  spec.outlines[drag.ring][drag.k] = Math.min(3, Math.max(0.01, Math.hypot(x, y)));
  drawCurves();
  requestGenerate();
});
curves.addEventListener('pointerup', () => {
  if (windDraft) {
    if (windDraft.points.length >= 2) {
      // At most 8 points: the stroke is an open Catmull-Rom curve anyway.
      const pts = windDraft.points, n = Math.min(8, pts.length);
      windDraft.points = Array.from({ length: n }, (_, i) => pts[Math.round(i * (pts.length - 1) / (n - 1))]);
      spec.wind.push(windDraft);
      if (spec.wind.length > 64) spec.wind.shift();
      requestGenerate();
    }
    windDraft = null;
    drawCurves();
  }
  drag = null;
});
// 1-D curve editors (profile, resistance): drag to set the samples.
const PAPER_DEFAULT_SAMPLES = 30;
function curveValues(which) {
  if (!spec[which]) spec[which] = null;
  return spec[which] || null;
}
function drawCurveEditor(which) {
  const c = $(which), ctx = c.getContext('2d');
  ctx.fillStyle = '#081018'; ctx.fillRect(0, 0, c.width, c.height);
  const v = curveValues(which);
  ctx.strokeStyle = '#9cf'; ctx.beginPath();
  if (!v) { ctx.fillStyle = '#8aa'; ctx.fillText('paper default — drag to edit', 10, c.height / 2); return; }
  v.forEach((y, i) => {
    const px = i / (v.length - 1) * c.width, py = (1 - y) * c.height;
    i ? ctx.lineTo(px, py) : ctx.moveTo(px, py);
  });
  ctx.stroke();
}
for (const which of ['profile', 'resistance']) {
  const c = $(which);
  let down = false;
  const edit = (ev) => {
    if (!spec[which]) {  // start from a flat ramp the user reshapes (the paper's samples live server-side)
      spec[which] = Array.from({ length: PAPER_DEFAULT_SAMPLES }, (_, i) =>
        which === 'profile' ? Math.max(0, 1 - i / (PAPER_DEFAULT_SAMPLES - 1)) : 0.5);
    }
    const [x, y] = canvasPoint(ev, c), v = spec[which];
    const i = Math.round(x / c.width * (v.length - 1));
    v[Math.max(0, Math.min(v.length - 1, i))] = Math.max(0, Math.min(1, 1 - y / c.height));
    drawCurveEditor(which);
    requestGenerate();
  };
  c.addEventListener('pointerdown', (ev) => { down = true; c.setPointerCapture(ev.pointerId); edit(ev); });
  c.addEventListener('pointermove', (ev) => { if (down) edit(ev); });
  c.addEventListener('pointerup', () => { down = false; });
}
function specForServer() {
  const s = JSON.parse(JSON.stringify(spec));
  if (!s.profile) delete s.profile;
  if (!s.resistance) delete s.resistance;
  s.subsidence = Number($('subsidence').value) / 100;
  return s;
}
let generatePending = false;
function requestGenerate() {
  if (generatePending) return;  // one per frame; the latest state is read when it runs
  generatePending = true;
  requestAnimationFrame(() => {
    generatePending = false;
    if (mode !== 'curves') return;
    const t0 = performance.now();
    runUpdate(() => api('/api/generate?size=256', JSON.stringify(specForServer()), 'application/json'), t0);
  });
}
function showLabel(b64) {
  const img = new Image();
  img.onload = () => { labelImage = img; if (mode === 'curves') drawCurves(); };
  img.src = 'data:image/png;base64,' + b64;
}
$('subsidence').addEventListener('input', requestGenerate);

// ---------- 2D hill-shaded view
function hypsometric(h) {
  if (h < 0) { const t = Math.max(0, Math.min(1, -h / 100)); return [20 + 60 * (1 - t), 80 + 120 * (1 - t), 140 + 90 * (1 - t)]; }
  const t = Math.min(1, h / 500);
  return t < 0.02 ? [230, 215, 160] : [60 + 120 * t, 140 - 40 * t + 40 * t * t, 60 + 100 * t];
}
function showShade(h, n, mpp) {
  const c = $('shade');
  c.width = c.height = n;
  const ctx = c.getContext('2d'), img = ctx.createImageData(n, n);
  for (let y = 0; y < n; ++y) for (let x = 0; x < n; ++x) {
    const i = y * n + x;
    const dx = (h[y * n + Math.min(n - 1, x + 1)] - h[y * n + Math.max(0, x - 1)]) / (2 * mpp);
    const dy = (h[Math.min(n - 1, y + 1) * n + x] - h[Math.max(0, y - 1) * n + x]) / (2 * mpp);
    const shade = Math.max(0.25, Math.min(1.2, (1 + (-dx - dy) * 2) / Math.sqrt(1 + dx * dx + dy * dy)));
    const [r, g, b] = hypsometric(h[i]);
    img.data.set([r * shade, g * shade, b * shade, 255], 4 * i);
  }
  ctx.putImageData(img, 0, 0);
}

// ---------- 3D view (three.js, vendored; the page still works without it)
let THREE = null, scene, camera, renderer, controls, terrain = null, current = null, renderQueued = false;
// Tests: render now and return the 3D view's pixels as a data URL.
probe.snapshot3d = () => { if (!THREE) return null; renderer.render(scene, camera); return renderer.domElement.toDataURL(); };
function requestRender() {
  if (!THREE || renderQueued) return;
  renderQueued = true;
  requestAnimationFrame(() => { renderQueued = false; renderer.render(scene, camera); });
}
try {
  THREE = await import('three');
  const { OrbitControls } = await import('./vendor/OrbitControls.js');
  const el = $('view3d');
  renderer = new THREE.WebGLRenderer({ antialias: !window.__reefgen_software_gl });
  renderer.setSize(el.clientWidth, el.clientHeight);
  el.appendChild(renderer.domElement);
  scene = new THREE.Scene();
  scene.background = new THREE.Color(0x9ec9e8);
  camera = new THREE.PerspectiveCamera(40, el.clientWidth / el.clientHeight, 0.05, 100);
  camera.position.set(0, 4.5, 6.5);
  controls = new OrbitControls(camera, renderer.domElement);
  controls.target.set(0, 0, 0);
  scene.add(new THREE.HemisphereLight(0xdfefff, 0x304050, 1.2));
  const sun = new THREE.DirectionalLight(0xffffff, 1.6);
  sun.position.set(-4, 6, 3);
  scene.add(sun);
  const sea = new THREE.Mesh(new THREE.PlaneGeometry(6.4, 6.4),
    new THREE.MeshPhongMaterial({ color: 0x1f6fa8, transparent: true, opacity: 0.55 }));
  sea.rotation.x = -Math.PI / 2;
  scene.add(sea);
  // Render on demand (a change of view or of terrain), never in a loop: the
  // CPU stays free for inference between strokes.
  controls.addEventListener('change', requestRender);
} catch (e) {
  THREE = null;
  $('no3d').hidden = false;
  console.warn('no 3D view:', e);
}
function show3d(h, n) {
  if (!THREE) return;
  const m = Math.min(n, 256), step = n / m;  // at most 256² vertices: smooth enough, fast to update
  const exag = Number($('exaggeration').value);
  // One grid, updated in place: no allocation per stroke.
  if (!terrain || terrain.userData.m !== m) {
    if (terrain) { scene.remove(terrain); terrain.geometry.dispose(); }
    const geo = new THREE.PlaneGeometry(6, 6, m - 1, m - 1);
    geo.rotateX(-Math.PI / 2);
    geo.setAttribute('color', new THREE.BufferAttribute(new Float32Array(geo.attributes.position.count * 3), 3));
    terrain = new THREE.Mesh(geo, new THREE.MeshLambertMaterial({ vertexColors: true }));
    terrain.userData.m = m;
    scene.add(terrain);
  }
  const geo = terrain.geometry, pos = geo.attributes.position.array, col = geo.attributes.color.array;
  for (let j = 0; j < m; ++j) for (let i = 0; i < m; ++i) {
    const v = j * m + i, hv = h[Math.floor(j * step) * n + Math.floor(i * step)];
    pos[3 * v + 1] = hv / 1000 * exag;  // 6 scene units = 6 km
    const [r, g, b] = hypsometric(hv);
    col[3 * v] = r / 255; col[3 * v + 1] = g / 255; col[3 * v + 2] = b / 255;
  }
  geo.attributes.position.needsUpdate = true;
  geo.attributes.color.needsUpdate = true;
  geo.computeVertexNormals();
  geo.computeBoundingSphere();
  requestRender();
}
function showHeights(h, n, j) {
  current = { h, n, mpp: j.metres_per_px };
  showShade(h, n, j.metres_per_px);
  show3d(h, n);
  $('legend').textContent = `${j.min_m.toFixed(0)} m … ${j.max_m.toFixed(0)} m`;
}
$('exaggeration').addEventListener('input', () => { if (current) show3d(current.h, current.n); });

// ---------- exports: the same writers as the CLI, into the studio's folder
for (const b of document.querySelectorAll('#exports button')) {
  b.addEventListener('click', async () => {
    const format = b.dataset.format, name = $('name').value;
    let body;
    if (mode === 'paint') {
      const buf = new Uint8Array(await (await sketchBlob()).arrayBuffer());
      let s = '';
      for (let i = 0; i < buf.length; i += 8192) s += String.fromCharCode(...buf.subarray(i, i + 8192));
      body = { sketch_png: btoa(s) };
    } else {
      body = { spec: specForServer(), size: 256 };
    }
    try {
      const res = await api(`/api/export?format=${format}&name=${encodeURIComponent(name)}`, JSON.stringify(body), 'application/json');
      const blob = await res.blob();
      const a = document.createElement('a');
      a.href = URL.createObjectURL(blob);
      a.download = (res.headers.get('Content-Disposition') || '').match(/filename="([^"]+)"/)?.[1] || name;
      a.click();
      status(`exported ${a.download} (also in ${res.headers.get('X-Reefgen-Path')})`);
    } catch (e) { status('export failed: ' + e.message); probe.errors.push(e.message); }
  });
}

// ---------- wiring
let mode = 'paint';
function setMode(m) {
  mode = m;
  $('paint-panel').hidden = m !== 'paint';
  $('curves-panel').hidden = m !== 'curves';
  $('mode-paint').classList.toggle('active', m === 'paint');
  $('mode-curves').classList.toggle('active', m === 'curves');
  if (m === 'paint') requestInfer(); else requestGenerate();
}
$('mode-paint').onclick = () => setMode('paint');
$('mode-curves').onclick = () => setMode('curves');
for (const r of REGIONS) {
  const b = document.createElement('button');
  b.className = 'region' + (r.id === region ? ' active' : '');
  b.title = r.name;
  b.dataset.region = String(r.id);
  b.style.background = `rgb(${regionColour(r.id, 0).join(',')})`;
  b.onclick = () => {
    region = r.id;
    document.querySelectorAll('.region').forEach((x) => x.classList.toggle('active', x === b));
    if (tool === 'eraser') setTool('brush');
  };
  $('regions').appendChild(b);
}
function setTool(t) {
  tool = t;
  for (const n of ['brush', 'fill', 'eraser']) $('tool-' + n).classList.toggle('active', n === t);
}
$('tool-brush').onclick = () => setTool('brush');
$('tool-fill').onclick = () => setTool('fill');
$('tool-eraser').onclick = () => setTool('eraser');
$('undo').onclick = () => restore(undoStack, redoStack);
$('redo').onclick = () => restore(redoStack, undoStack);
document.addEventListener('keydown', (ev) => {
  if (!(ev.ctrlKey || ev.metaKey)) return;
  if (ev.key === 'z') { ev.preventDefault(); restore(undoStack, redoStack); }
  if (ev.key === 'y') { ev.preventDefault(); restore(redoStack, undoStack); }
});
$('clear').onclick = () => { snapshot(); clearCanvas(); requestInfer(); };
$('canvas-size').onchange = () => {
  snapshot();
  const old = document.createElement('canvas');
  old.width = paint.width; old.height = paint.height;
  old.getContext('2d').drawImage(paint, 0, 0);
  paint.width = paint.height = Number($('canvas-size').value);
  pctx.imageSmoothingEnabled = false;
  pctx.drawImage(old, 0, 0, paint.width, paint.height);
  requestInfer();
};
$('load').onchange = (ev) => {
  const f = ev.target.files[0];
  if (!f) return;
  const img = new Image();
  img.onload = () => { snapshot(); pctx.drawImage(img, 0, 0, paint.width, paint.height); requestInfer(); };
  img.src = URL.createObjectURL(f);
};

// Start: a small young volcano to look at, the presets for curves mode.
clearCanvas();
for (const [id, r] of [[3, 0.42], [2, 0.34], [1, 0.26], [0, 0.2]]) {
  const [cr, cg, cb] = regionColour(id, 0);
  pctx.fillStyle = `rgb(${cr},${cg},${cb})`;
  pctx.beginPath();
  pctx.arc(paint.width / 2, paint.height / 2, r * paint.width, 0, 2 * Math.PI);
  pctx.fill();
}
try { defaults = await (await api('/api/defaults')).json(); } catch (e) { status('defaults: ' + e.message); }
loadSpec(defaultSpec());
try {
  const presets = await (await api('/api/presets')).json();
  for (const name of Object.keys(presets)) {
    const o = document.createElement('option');
    o.textContent = name;
    $('preset').appendChild(o);
  }
  $('preset').onchange = () => { loadSpec(presets[$('preset').value]); requestGenerate(); };
  if (presets['young-volcano']) { $('preset').value = 'young-volcano'; loadSpec(presets['young-volcano']); }
} catch (e) { status('presets: ' + e.message); }
requestInfer();
