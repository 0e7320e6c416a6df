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
const LABELS = ['Island', 'Beach', 'Lagoon', 'Reef', 'Abyss'];
function regionColour(id, subsidence) {
  const v = Math.round(255 * (1 - 0.75 * subsidence));
  return REGIONS[id].rgb.map((c) => c * v);
}
// What each colour becomes at each Subsidence: the shipped model's training data,
// median height (m) and share above the sea per subsidence band, measured in
// docs/INFERENCE.md ("What each colour means, at each brightness"). Bands:
// λ < 0.1, < 0.3, < 0.5, < 0.7, < 0.9, ≤ 1.
const SUBSIDENCE_BANDS = [0.1, 0.3, 0.5, 0.7, 0.9, 1.01];
const SUBSIDENCE_TABLE = [
  [[151, 1], [84, 1], [1, 0.55], [-27, 0.03], [-29, 0], [-29, 0]],          // island
  [[6, 0.99], [2, 0.74], [-17, 0.24], [-27, 0.24], [-27, 0.23], [-27, 0.26]],  // beach
  [[-6, 0.01], [-18, 0], [-25, 0], [-25, 0], [-25, 0], [-25, 0]],           // lagoon
  [[-5, 0], [-14, 0.01], [-21, 0.01], [-21, 0.01], [-21, 0.01], [-21, 0.01]],  // reef
  [[-88, 0], [-88, 0], [-88, 0], [-88, 0], [-88, 0], [-88, 0]],             // abyss
];
function becomes(id, subsidence) {
  const [m, dry] = SUBSIDENCE_TABLE[id][SUBSIDENCE_BANDS.findIndex((b) => subsidence < b)];
  const what = dry >= 0.9 ? 'land' : dry >= 0.1 ? `${Math.round(100 * dry)} % land` : 'water';
  return { m, dry, text: `${what}, ${m > 0 ? '+' : ''}${m} m` };
}

// ---------- talking to the server
let latestRequest = 0;
// At most one update in flight; while it runs, only the newest change waits
// (its request is built when it leaves the queue, from the canvas as it is
// then). So the view is never more than one inference behind the brush, and
// no stale request keeps the server busy.
let inFlight = false, queued = null;
function submit(makeRequest) {
  queued = { makeRequest, t0: performance.now() };
  probe.lastQueuedAt = queued.t0;
  if (inFlight) return;
  inFlight = true;
  (async () => {
    while (queued) {
      const q = queued;
      queued = null;
      probe.requests = (probe.requests || 0) + 1;
      await runUpdate(q.makeRequest, q.t0);
    }
    inFlight = false;
  })();
}
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
// The server's heights answer: [uint32 n][n bytes JSON][size² heights],
// little-endian. The page asks for uint16 steps (?enc=u16: half the bytes of
// float32, 1 cm steps) and expands them here.
async function readHeights(res) {
  const buf = await res.arrayBuffer();
  const n = new DataView(buf).getUint32(0, true);
  const meta = JSON.parse(new TextDecoder().decode(new Uint8Array(buf, 4, n)));
  const N = meta.size * meta.size;
  if (meta.encoding !== 'u16') return { meta, h: new Float32Array(buf, 4 + n, N) };
  const q = new Uint16Array(buf, 4 + n, N), h = new Float32Array(N), lo = meta.u16_lo_m, step = meta.u16_step_m;
  for (let i = 0; i < N; i++) h[i] = lo + q[i] * step;
  return { meta, h };
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
    probe.lastMeta = j;
    probe.lastRequestedAt = t0;
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
let sinkBase = null;  // the painting as it was when the Subsidence slider was grabbed
let paintSubsidence = '0';  // the Subsidence slider's value the painting's pixels have
const undoStack = [], redoStack = [];
function subsidence() { return Number($('paint-subsidence').value) / 100; }
function clearCanvas() {
  const [r, g, b] = regionColour(ABYSS, subsidence());
  pctx.fillStyle = `rgb(${r},${g},${b})`;
  pctx.fillRect(0, 0, paint.width, paint.height);
}
// Undo steps remember the Subsidence slider with the pixels (a re-sink is a step).
function grab() {
  const img = pctx.getImageData(0, 0, paint.width, paint.height);
  img.subsidenceValue = paintSubsidence;
  return img;
}
function snapshot() {
  undoStack.push(grab());
  if (undoStack.length > 40) undoStack.shift();
  redoStack.length = 0;
}
function restore(from, to) {
  if (!from.length) return;
  to.push(grab());
  const img = from.pop();
  $('paint-subsidence').value = paintSubsidence = img.subsidenceValue;
  $('paint-subsidence').dispatchEvent(new Event('sync'));
  sinkBase = null;
  if (img.width !== paint.width) { paint.width = paint.height = img.width; }
  $('canvas-size').value = String(img.width);  // the menu shows the canvas it restored
  pctx.putImageData(img, 0, 0);
  requestInfer();
}
// Relief (the colour's saturation, docs/INFERENCE.md "Per-region style"):
// 100 = the palette's full colour (rugged), 0 = a pastel of saturation 0.35
// (a smooth shield); between, the saturation the decoder reads linearly
// (0.35 + 0.5·r, rugged from 0.85 up).
function relief() { return Number($('relief').value) / 100; }
function withRelief([r, g, b], rel) {
  if (rel >= 1) return [r, g, b];
  const v = Math.max(r, g, b), sat = 0.35 + 0.5 * rel;
  return [r, g, b].map((c) => Math.round(v - (v - c) * sat));
}
function brushColour() {
  return tool === 'eraser' ? regionColour(ABYSS, subsidence()) : withRelief(regionColour(region, subsidence()), relief());
}
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
// Fill replaces a region including its soft edge: the connected pixels of the
// clicked colour T, then the blended pixels around them (up to the widest
// soft edge a brush draws), each keeping its share a of T (p = a·T +
// (1−a)·N) with T swapped for the new colour C. The old fill left 1–2 px
// seams of T there, which the model read as a thin ring of that region.
function floodFill(x0, y0) {
  const W = paint.width, H = paint.height, N = W * H;
  const img = pctx.getImageData(0, 0, W, H), d = img.data;
  const sx = Math.floor(x0), sy = Math.floor(y0), s0 = 4 * (sy * W + sx);
  const T = [d[s0], d[s0 + 1], d[s0 + 2]];
  const C = brushColour();
  if (T[0] === C[0] && T[1] === C[1] && T[2] === C[2]) return;
  const close = (i) => Math.abs(d[i] - T[0]) + Math.abs(d[i + 1] - T[1]) + Math.abs(d[i + 2] - T[2]) < 48;
  const state = new Uint8Array(N);  // 1 core, 2 edge
  const stack = [sy * W + sx];
  state[sy * W + sx] = 1;
  const core = [];
  while (stack.length) {
    const q = stack.pop();
    core.push(q);
    const x = q % W, y = (q - x) / W;
    for (const n of [x > 0 ? q - 1 : -1, x < W - 1 ? q + 1 : -1, y > 0 ? q - W : -1, y < H - 1 ? q + W : -1]) {
      if (n >= 0 && !state[n] && close(4 * n)) { state[n] = 1; stack.push(n); }
    }
  }
  // Each pixel around the region is read as a blend a·T + (1−a)·N of the
  // old colour and the pure colour N (a region's hue at T's or the brush's
  // brightness) that explains it best.
  const vT = Math.max(...T), vC = Math.max(...C);
  const pures = [];
  for (const r of REGIONS) for (const v of [vT, vC]) pures.push(r.rgb.map((c) => c * v));
  const share = (i) => {
    let bestA = 0, bestErr = Infinity;
    for (const Nc of pures) {
      let num = 0, den = 0;
      for (let c = 0; c < 3; ++c) { const tn = T[c] - Nc[c]; num += (d[i + c] - Nc[c]) * tn; den += tn * tn; }
      if (den === 0) continue;
      const a = Math.max(0, Math.min(1, num / den));
      let err = 0;
      for (let c = 0; c < 3; ++c) { const e = d[i + c] - (a * T[c] + (1 - a) * Nc[c]); err += e * e; }
      if (err < bestErr) { bestErr = err; bestA = a; }
    }
    return bestA;
  };
  // The soft edge: outwards from the region, ring by ring, while T's share
  // keeps falling (a soft edge fades out; a flat area of another colour that
  // happens to look like a blend — a darker island — does not, and stays).
  const shareOf = new Float32Array(N).fill(1);
  const band = Math.ceil(80 * W / 256) + 2;
  let ring = core;
  const edge = [];
  for (let r = 0; r < band && ring.length; ++r) {
    const next = [];
    for (const q of ring) {
      const x = q % W, y = (q - x) / W;
      for (const n of [x > 0 ? q - 1 : -1, x < W - 1 ? q + 1 : -1, y > 0 ? q - W : -1, y < H - 1 ? q + W : -1]) {
        if (n < 0 || state[n]) continue;
        const a = share(4 * n);
        if (a > 0.02 && a < shareOf[q] - 1e-3) { state[n] = 2; shareOf[n] = a; next.push(n); edge.push(n); }
      }
    }
    ring = next;
  }
  for (const q of edge) {
    const i = 4 * q, a = shareOf[q];
    for (let c = 0; c < 3; ++c) d[i + c] = Math.max(0, Math.min(255, Math.round(d[i + c] + a * (C[c] - T[c]))));
    d[i + 3] = 255;
  }
  for (const q of core) { const i = 4 * q; d[i] = C[0]; d[i + 1] = C[1]; d[i + 2] = C[2]; d[i + 3] = 255; }
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

// The island's seed (infer --seed): Re-roll draws another island for the
// same painting; exports and layer views use the seed shown.
let islandSeed = 0;
probe.islandSeed = () => islandSeed;
// The erosion maturity the page asks for (the Age and Maturity sliders below).
const AGE_MIN_MYR = 0.05, AGE_MAX_MYR = 60, ATOLL_AGE_MYR = 60, MATURITY_MIN = 0.05, MATURITY_MAX = 20;
// A slider's 0..100 on a log scale from lo to hi, and back.
const logScale = (lo, hi) => ({
  value: (p) => Math.min(hi, lo * Math.pow(hi / lo, p / 100)),
  position: (v) => Math.round(100 * Math.log(v / lo) / Math.log(hi / lo)),
});
const ageScale = logScale(AGE_MIN_MYR, AGE_MAX_MYR), maturityScale = logScale(MATURITY_MIN, MATURITY_MAX);
let maturitySet = false;
const shortNumber = (v) => v.toFixed(v < 1 ? 2 : v < 10 ? 1 : 0);
function ageMyr() { return ageScale.value(Number($('age-myr').value)); }
function maturity() { return Number(maturityScale.value(Number($('maturity').value)).toFixed(4)); }
function maturityParam() { return maturitySet ? `&maturity=${maturity()}` : ''; }
function showMaturity() { $('maturity-out').textContent = maturitySet ? `${shortNumber(maturity())}` : '–'; }
probe.maturity = () => (maturitySet ? maturity() : null);
function sketchBlob() { return new Promise((r) => paint.toBlob(r, 'image/png')); }
// The canvas goes to the server as raw RGBA: getImageData takes ~1 ms where
// PNG encoding (toBlob) took up to a second of the main thread per stroke.
function requestInfer() {
  submit(async () => {
    const t = performance.now();
    const px = pctx.getImageData(0, 0, paint.width, paint.height).data;
    probe.encode_ms = performance.now() - t;
    return api(`/api/infer?w=${paint.width}&h=${paint.height}&enc=u16&seed=${islandSeed}${maturityParam()}`, px, 'application/x-reefgen-rgba');
  });
}

// ---------- curves mode: the Figure-3 inputs, dragged directly
const curves = $('curves');
const cctx = curves.getContext('2d');
const K = 12;  // control radii per outline
let spec = null, labelImage = null, drag = null, windDraft = null, defaults = null, shownPreset = '';
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
  $('subsidence').value = committedSubsidence = String(Math.round(100 * (spec.subsidence || 0)));
  $('subsidence').dispatchEvent(new Event('sync'));  // its number too (it went stale after a preset)
  drawCurves();
  drawCurveEditor('profile');
  drawCurveEditor('resistance');
}
// Undo in curves mode: whole states (spec, subsidence, preset), one step per
// drag, stroke, removal, curve edit, preset or slider change.
let committedSubsidence = '0';  // the slider's value before the drag in progress
const specUndo = [], specRedo = [];
function specState() { return JSON.stringify({ spec, subsidence: committedSubsidence, preset: shownPreset }); }
function specSnapshot() {
  specUndo.push(specState());
  if (specUndo.length > 40) specUndo.shift();
  specRedo.length = 0;
}
function specRestore(from, to) {
  if (!from.length) return;
  to.push(specState());
  const st = JSON.parse(from.pop());
  spec = st.spec;
  $('subsidence').value = committedSubsidence = st.subsidence;
  $('subsidence').dispatchEvent(new Event('sync'));
  $('preset').value = shownPreset = st.preset;
  drawCurves();
  drawCurveEditor('profile');
  drawCurveEditor('resistance');
  requestGenerate();
}
probe.spec = () => JSON.stringify(spec);
const toCanvas = ([x, y]) => [(x + 1) / 2 * curves.width, (1 - y) / 2 * curves.height];  // +y up
const fromCanvas = ([px, py]) => [px / curves.width * 2 - 1, 1 - py / curves.height * 2];
// Wind strokes warp the regions after the outlines are drawn (docs/SPEC.md),
// so a handle at its spec radius would float off the region it moves. Each
// handle is drawn where the ray at its angle crosses its region's edge in the
// generated label map, the crossing nearest to its spec radius; the abyss
// ring (no edge in the map) and rays that cross nothing keep the spec radius.
let labelRegions = null;  // {n, r: Uint8Array n² region ids} of the last label map
function regionsOf(img) {
  const n = img.width, c = document.createElement('canvas');
  c.width = c.height = n;
  const x = c.getContext('2d', { willReadFrequently: true });
  x.drawImage(img, 0, 0);
  const d = x.getImageData(0, 0, n, n).data, r = new Uint8Array(n * n);
  for (let i = 0; i < n * n; ++i) {
    const R = d[4 * i], G = d[4 * i + 1], B = d[4 * i + 2], m = Math.max(R, G, B) / 2;
    const code = (R > m ? 4 : 0) | (G > m ? 2 : 0) | (B > m ? 1 : 0);
    r[i] = { 6: 0, 2: 1, 3: 2, 1: 3, 4: 4 }[code] ?? 4;
  }
  return { n, r };
}
function regionAt(x, y) {  // canvas units → region id of the label map
  const n = labelRegions.n;
  const px = Math.floor((x + 1) / 2 * n), py = Math.floor((1 - y) / 2 * n);
  if (px < 0 || py < 0 || px >= n || py >= n) return 4;
  return labelRegions.r[py * n + px];
}
function deformedRadius(ring, th, r0) {
  if (!labelRegions || ring > 3) return r0;
  const step = 1 / labelRegions.n, c = Math.cos(th), sn = Math.sin(th);
  let best = null, inside = regionAt(0, 0) <= ring;
  for (let r = step; r < 1.5; r += step) {
    const now = regionAt(r * c, r * sn) <= ring;
    if (now !== inside && (best === null || Math.abs(r - r0) < Math.abs(best - r0))) best = r;
    inside = now;
  }
  return best === null ? r0 : best;
}
// Tests: the label map shown and the handles' canvas positions.
probe.labelImage = () => labelImage;
probe.handles = () => spec.outlines.map((_, ring) => Array.from({ length: K }, (_, k) => handlePoint(ring, k)));
function handlePoint(ring, k) {
  const th = 2 * Math.PI * k / K, r = deformedRadius(ring, th, spec.outlines[ring][k]);
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
      const th = 2 * Math.PI * (k + t) / K;
      const r = deformedRadius(ring, th, catmull(radii[(k + K - 1) % K], radii[k], radii[(k + 1) % K], radii[(k + 2) % K], t));
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
  if (i >= 0) { specSnapshot(); spec.wind.splice(i, 1); drawCurves(); requestGenerate(); }
});
curves.addEventListener('pointerdown', (ev) => {
  curves.focus();
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
  if (best) {  // drags move the spec radius by the pointer's radial motion
    specSnapshot();
    const [x, y] = fromCanvas(pt);
    best.r0 = spec.outlines[best.ring][best.k];
    best.p0 = Math.hypot(x, y);
  }
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
  spec.outlines[drag.ring][drag.k] = Math.min(3, Math.max(0.01, drag.r0 + Math.hypot(x, y) - drag.p0));
  drawCurves();
  requestGenerate();
});
curves.addEventListener('pointerup', () => {
  if (windDraft) {
    if (windDraft.points.length >= 2) {
      // At most 8 points: the stroke is an open Catmull-Rom curve anyway.
      const pts = windDraft.points, n = Math.min(8, pts.length);
      windDraft.points = Array.from({ length: n }, (_, i) => pts[Math.round(i * (pts.length - 1) / (n - 1))]);
      specSnapshot();
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
  c.addEventListener('pointerdown', (ev) => { specSnapshot(); down = true; c.setPointerCapture(ev.pointerId); edit(ev); });
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
    submit(() => api('/api/generate?size=256&enc=u16', JSON.stringify(specForServer()), 'application/json'));
  });
}
function showLabel(b64) {
  const img = new Image();
  img.onload = () => {
    labelImage = img;
    labelRegions = regionsOf(img);
    if (mode === 'curves') drawCurves();
    probe.labelsShown = (probe.labelsShown || 0) + 1;
  };
  img.src = 'data:image/png;base64,' + b64;
}
$('subsidence').addEventListener('input', () => {
  // The first move of a drag is the undo step; the drag's end commits it.
  if ($('subsidence').value !== committedSubsidence && specUndo[specUndo.length - 1] !== specState()) specSnapshot();
  requestGenerate();
});
$('subsidence').addEventListener('change', () => { committedSubsidence = $('subsidence').value; });
$('curves-undo').onclick = () => specRestore(specUndo, specRedo);
$('curves-redo').onclick = () => specRestore(specRedo, specUndo);

// ---------- 2D hill-shaded view
function hypsometric(h) {
  if (h < 0) { const t = Math.max(0, Math.min(1, -h / 100)); return [20 + 60 * (1 - t), 80 + 120 * (1 - t), 140 + 90 * (1 - t)]; }
  const t = Math.min(1, h / 500);
  return t < 0.02 ? [230, 215, 160] : [60 + 120 * t, 140 - 40 * t + 40 * t * t, 60 + 100 * t];
}
// Colours per 0.5 m from −128 m to 1024 m, looked up per pixel: a 1024²
// answer is a million pixels, and a colour array per pixel cost ~50 ms.
const HYPSO_LO = -128, HYPSO_STEP = 0.5, HYPSO = (() => {
  const n = Math.round((1024 - HYPSO_LO) / HYPSO_STEP) + 1, t = new Float32Array(3 * n);
  for (let k = 0; k < n; ++k) t.set(hypsometric(HYPSO_LO + k * HYPSO_STEP), 3 * k);
  return t;
})();
function showShade(h, n, mpp) {
  const c = $('shade');
  if (c.width !== n) c.width = c.height = n;
  const ctx = c.getContext('2d'), img = ctx.createImageData(n, n), d = img.data;
  const last = HYPSO.length / 3 - 1, inv = 1 / (2 * mpp);
  for (let y = 0; y < n; ++y) {
    const row = y * n, up = Math.max(0, y - 1) * n, down = Math.min(n - 1, y + 1) * n;
    for (let x = 0; x < n; ++x) {
      const i = row + x;
      const dx = (h[row + Math.min(n - 1, x + 1)] - h[row + Math.max(0, x - 1)]) * inv;
      const dy = (h[down + x] - h[up + x]) * inv;
      const shade = Math.max(0.25, Math.min(1.2, (1 + (-dx - dy) * 2) / Math.sqrt(1 + dx * dx + dy * dy)));
      const k = 3 * Math.max(0, Math.min(last, Math.round((h[i] - HYPSO_LO) / HYPSO_STEP)));
      d[4 * i] = HYPSO[k] * shade; d[4 * i + 1] = HYPSO[k + 1] * shade; d[4 * i + 2] = HYPSO[k + 2] * shade; d[4 * i + 3] = 255;
    }
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
  // The camera stays above the sea (a drag used to swing it under the water
  // plane, a sixth of the view's height was enough), pans along the ground,
  // and keeps the island in reach; Reset view returns to this first view.
  controls.maxPolarAngle = Math.PI / 2 - 0.08;
  controls.screenSpacePanning = false;
  controls.minDistance = 0.8;
  controls.maxDistance = 25;
  controls.saveState();
  probe.camera = () => ({ y: camera.position.y, polar: controls.getPolarAngle() });
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
  // The layout sizes the view from the window (two columns from 1024 px up):
  // follow it.
  new ResizeObserver(() => {
    if (!el.clientWidth || !el.clientHeight) return;
    renderer.setSize(el.clientWidth, el.clientHeight);
    camera.aspect = el.clientWidth / el.clientHeight;
    camera.updateProjectionMatrix();
    requestRender();
  }).observe(el);
} catch (e) {
  THREE = null;
  $('no3d').hidden = false;
  console.warn('no 3D view:', e);
}
// Level of detail: the mesh carries at most 512² vertices (the silhouette),
// its surface the answer's full resolution — the hill-shaded colour image of
// the 2D view (n², lit from the heights at every pixel) is its texture. So a
// 1024² answer shows all its gullies without a million-vertex mesh to
// rebuild per stroke.
const MESH_MAX = 512;
let surface = null;
function show3d(h, n) {
  if (!THREE) return;
  const m = Math.min(n, MESH_MAX), step = (n - 1) / (m - 1);
  const exag = Number($('exaggeration').value);
  // One grid, updated in place: no allocation per stroke.
  if (!terrain || terrain.userData.m !== m) {
    if (terrain) { scene.remove(terrain); terrain.geometry.dispose(); }
    const geo = new THREE.PlaneGeometry(6, 6, m - 1, m - 1);
    geo.rotateX(-Math.PI / 2);
    terrain = new THREE.Mesh(geo, new THREE.MeshBasicMaterial());
    terrain.userData.m = m;
    scene.add(terrain);
  }
  const shade = $('shade');
  if (!surface || surface.image !== shade || surface.userData.n !== n) {
    if (surface) surface.dispose();
    surface = new THREE.CanvasTexture(shade);
    surface.userData.n = n;
    surface.colorSpace = THREE.SRGBColorSpace;
    surface.anisotropy = 4;
    terrain.material.map = surface;
    terrain.material.needsUpdate = true;
  }
  surface.needsUpdate = true;
  const geo = terrain.geometry, pos = geo.attributes.position.array;
  for (let j = 0; j < m; ++j) for (let i = 0; i < m; ++i) {
    const hv = h[Math.round(j * step) * n + Math.round(i * step)];
    pos[3 * (j * m + i) + 1] = hv / 1000 * exag;  // 6 scene units = 6 km
  }
  geo.attributes.position.needsUpdate = true;
  geo.computeBoundingSphere();
  probe.view3d = { mesh_px: m, texture_px: shade.width };
  requestRender();
}
function showHeights(h, n, j) {
  current = { h, n, mpp: j.metres_per_px };
  showShade(h, n, j.metres_per_px);
  show3d(h, n);
  if ($('layer-view').value !== 'heights') showLayer();
  $('legend').textContent = `${j.min_m.toFixed(0)} m … ${j.max_m.toFixed(0)} m`;
}
$('exaggeration').addEventListener('input', () => { if (current) show3d(current.h, current.n); });

// ---------- layer views: the server's materials or flow picture (the CLI's
// layers of this very island) in place of the hill-shaded heights, on the
// 2D view and as the 3D surface. Only the latest request's answer is shown.
let layerToken = 0;
probe.layerViews = 0;
async function sourceBody(size) {
  if (mode === 'curves') return { spec: specForServer(), size };
  const buf = new Uint8Array(await (await sketchBlob()).arrayBuffer());
  let s = '';
  for (let i = 0; i < buf.length; i += 8192) s += String.fromCharCode(...buf.subarray(i, i + 8192));
  const body = { sketch_png: btoa(s), seed: islandSeed };
  if (maturitySet) body.maturity = maturity();
  return body;
}
async function showLayer() {
  const view = $('layer-view').value, token = ++layerToken;
  if (!current) return;
  if (view === 'heights') { showShade(current.h, current.n, current.mpp); show3d(current.h, current.n); return; }
  try {
    const res = await api(`/api/layers?view=${view}`, JSON.stringify(await sourceBody(current.n)), 'application/json');
    const picture = await createImageBitmap(await res.blob());
    if (token !== layerToken) return;
    const c = $('shade');
    if (c.width !== picture.width) c.width = c.height = picture.width;
    c.getContext('2d').drawImage(picture, 0, 0);
    show3d(current.h, current.n);
    probe.layerViews++;
    probe.layerView = view;
  } catch (e) { status('layer view failed: ' + e.message); probe.errors.push(e.message); }
}
$('layer-view').addEventListener('change', showLayer);
$('view-reset').onclick = () => { if (controls) { controls.reset(); requestRender(); } };

// ---------- exports: the same writers as the CLI, into the studio's folder
for (const b of document.querySelectorAll('#exports button')) {
  b.addEventListener('click', async () => {
    const format = b.dataset.format, name = $('name').value;
    const body = await sourceBody(256);
    const floor = $('ocean-floor').value.trim();
    if (floor !== '') body.ocean_floor_m = Number(floor);
    // Some exports take seconds (OBJ of a 1024² island: ~7 s): say so, and
    // keep the button from starting a second one meanwhile.
    const t0 = performance.now();
    const tick = () => status(`exporting ${b.textContent.trim()}… ${((performance.now() - t0) / 1000).toFixed(0)} s`);
    b.disabled = true;
    tick();
    const timer = setInterval(tick, 500);
    try {
      const res = await api(`/api/export?format=${format}&name=${encodeURIComponent(name)}`, JSON.stringify(body), 'application/json');
      const blob = await res.blob();
      const a = document.createElement('a');
      a.href = URL.createObjectURL(blob);
      a.download = (res.headers.get('Content-Disposition') || '').match(/filename="([^"]+)"/)?.[1] || name;
      a.click();
      // 16-bit files span the field's own range (nothing clipped): say which.
      const range = (res.headers.get('X-Reefgen-Range-M') || '').split(' ').map(Number);
      const span = range.length === 2 ? ` — ${range[0].toFixed(1)}…${range[1].toFixed(1)} m → 0…65535, scale in ${res.headers.get('X-Reefgen-Import-Note')}` : '';
      const note = res.headers.get('X-Reefgen-Note');
      status(`exported ${a.download}${span} (also in ${res.headers.get('X-Reefgen-Path')})${note ? ' — ' + note : ''}`);
    } catch (e) { status('export failed: ' + e.message); probe.errors.push(e.message); }
    finally { clearInterval(timer); b.disabled = false; }
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
  // Only the exports that work in this mode (Spec JSON needs the curves).
  for (const b of document.querySelectorAll('#exports button[data-modes]')) b.hidden = !b.dataset.modes.split(' ').includes(m);
  if (m === 'paint') requestInfer(); else requestGenerate();
}
$('mode-paint').onclick = () => setMode('paint');
$('mode-curves').onclick = () => setMode('curves');
for (const r of REGIONS) {
  const b = document.createElement('button');
  b.className = 'region' + (r.id === region ? ' active' : '');
  b.dataset.region = String(r.id);
  b.setAttribute('role', 'radio');
  b.setAttribute('aria-checked', String(r.id === region));
  b.setAttribute('aria-label', `${LABELS[r.id]} brush`);
  const chip = document.createElement('span');
  chip.className = 'chip';
  const name = document.createElement('span');
  name.textContent = LABELS[r.id];
  b.append(chip, name);
  b.onclick = () => {
    region = r.id;
    document.querySelectorAll('.region').forEach((x) => {
      x.classList.toggle('active', x === b);
      x.setAttribute('aria-checked', String(x === b));
    });
    if (tool === 'eraser') setTool('brush');
  };
  $('regions').appendChild(b);
}
// Swatches in the current Subsidence's colours, and what each becomes at it.
function showSubsidence() {
  const a = subsidence();
  for (const b of document.querySelectorAll('.region')) {
    b.querySelector('.chip').style.background = `rgb(${regionColour(Number(b.dataset.region), a).join(',')})`;
  }
  const rows = REGIONS.map((r) => `<div data-region="${r.id}"><b>${LABELS[r.id]}</b> → ${becomes(r.id, a).text}</div>`);
  $('subsidence-legend').innerHTML = `<div>At subsidence ${Math.round(100 * a)} (median of the training data):</div>` + rows.join('');
}
// Slider values beside the sliders (Age and Maturity show their own).
for (const out of document.querySelectorAll('output[for]')) {
  if (out.id) continue;
  const input = $(out.htmlFor.value), unit = { brush: ' px', softness: ' %', exaggeration: '×' }[input.id] || '';
  const show = () => { out.textContent = input.value + unit; };
  input.addEventListener('input', show);
  input.addEventListener('sync', show);
  show();
}
// Subsidence re-sinks the whole painting as if it had been painted at the
// new subsidence: every region colour is its hue times V = 1 − 0.75·λ, so a
// pixel painted at one λ — a pure colour or a soft edge blending several — is
// the same blend at another λ scaled by V(new) / V(old). (Scaling each pixel to
// full brightness instead lifted the dim blends of a soft edge — yellow
// over blue is grey at half V — to V itself: bright land rings.) Rescaled
// from the painting as it was when the slider was grabbed (no rounding drift
// while dragging); one undo step per drag, one request per change
// (coalesced while dragging).
let sinkBaseV = 0;  // V of the Subsidence the painting had when the slider was grabbed
function resink() {
  if (!sinkBase) {
    snapshot();
    sinkBase = pctx.getImageData(0, 0, paint.width, paint.height);
    sinkBaseV = 1 - 0.75 * Number(paintSubsidence) / 100;
  }
  paintSubsidence = $('paint-subsidence').value;
  const src = sinkBase.data, img = pctx.createImageData(sinkBase.width, sinkBase.height), d = img.data;
  const k = (1 - 0.75 * subsidence()) / sinkBaseV;
  for (let i = 0; i < src.length; i += 4) {
    for (let c = 0; c < 3; ++c) d[i + c] = Math.min(255, Math.round(src[i + c] * k));
    d[i + 3] = 255;
  }
  pctx.putImageData(img, 0, 0);
  showSubsidence();
  requestInfer();
}
$('paint-subsidence').addEventListener('input', resink);
$('paint-subsidence').addEventListener('change', () => { sinkBase = null; });
$('paint-subsidence').addEventListener('sync', showSubsidence);
showSubsidence();
// Age (infer --age-myr; docs/SPEC.md "Age"): one age in millions of years
// sets both things an island's age changes (reefgen/age.hpp) — the
// Subsidence, the painting's brightness (λ = √(t / 60 My), re-sunk as the
// Subsidence slider does), and the erosion Maturity (t / 1 My). Either can
// then be moved alone. The page sends the maturity (?maturity=), never the
// age: the painting's own brightness is its subsidence. Until the Age or the
// Maturity moves, neither is sent (the default island).
$('age-myr').addEventListener('input', () => {
  const t = ageMyr();
  $('age-myr-out').textContent = `${shortNumber(t)} My`;
  maturitySet = true;
  $('maturity').value = maturityScale.position(Math.min(MATURITY_MAX, Math.max(MATURITY_MIN, t)));
  showMaturity();
  $('paint-subsidence').value = Math.round(100 * Math.min(1, Math.sqrt(t / ATOLL_AGE_MYR)));
  $('paint-subsidence').dispatchEvent(new Event('sync'));
  resink();
});
$('age-myr').addEventListener('change', () => { sinkBase = null; });
$('maturity').addEventListener('input', () => { maturitySet = true; showMaturity(); requestInfer(); });
function setTool(t) {
  tool = t;
  for (const n of ['brush', 'fill', 'eraser']) $('tool-' + n).classList.toggle('active', n === t);
}
$('tool-brush').onclick = () => setTool('brush');
$('tool-fill').onclick = () => setTool('fill');
$('tool-eraser').onclick = () => setTool('eraser');
$('undo').onclick = () => restore(undoStack, redoStack);
$('redo').onclick = () => restore(redoStack, undoStack);
// Ctrl-Z / Ctrl-Y (Ctrl-Shift-Z) act on the painting only when the focus is
// on the canvas or on no control: typing in the export name (or a menu) keeps
// the browser's own undo there.
document.addEventListener('keydown', (ev) => {
  if (!(ev.ctrlKey || ev.metaKey)) return;
  const f = document.activeElement;
  const own = mode === 'paint' ? paint : $('curves');
  if (f && f !== own && f !== document.body && !(f.tagName === 'BUTTON')) return;
  const k = ev.key.toLowerCase();
  const [back, fwd] = mode === 'paint' ? [() => restore(undoStack, redoStack), () => restore(redoStack, undoStack)]
                                       : [() => specRestore(specUndo, specRedo), () => specRestore(specRedo, specUndo)];
  if (k === 'z' && !ev.shiftKey) { ev.preventDefault(); back(); }
  if (k === 'y' || (k === 'z' && ev.shiftKey)) { ev.preventDefault(); fwd(); }
});
paint.addEventListener('pointerdown', () => paint.focus());
$('clear').onclick = () => { snapshot(); clearCanvas(); requestInfer(); };
function keepSeed(seed) {
  islandSeed = seed % 1000000;
  $('reroll').textContent = `Re-roll (seed ${islandSeed})`;
  requestInfer();
}
$('reroll').onclick = () => keepSeed(islandSeed + 1);
// Variations (infer --variations): the next four seeds' islands side by
// side, hill-shaded; clicking one keeps its seed.
$('variations').onclick = async () => {
  const sheet = $('variations-sheet');
  const px = pctx.getImageData(0, 0, paint.width, paint.height).data;
  $('variations').disabled = true;
  try {
    const res = await api(`/api/variations?w=${paint.width}&h=${paint.height}&n=4&seed=${islandSeed + 1}${maturityParam()}`, px,
      'application/x-reefgen-rgba');
    if (!res) return;  // a newer request overtook this one
    const j = await res.json();
    sheet.innerHTML = '';
    j.seeds.forEach((seed, k) => {
      const img = document.createElement('img');
      img.src = `data:image/png;base64,${j.previews[k]}`;
      img.alt = img.title = `seed ${seed}: click to keep this island`;
      img.dataset.seed = seed;
      img.tabIndex = 0;
      const pick = () => { sheet.hidden = true; keepSeed(Number(seed)); };
      img.onclick = pick;
      img.onkeydown = (ev) => { if (ev.key === 'Enter') pick(); };
      sheet.appendChild(img);
    });
    sheet.hidden = false;
  } catch (e) {
    status(`variations: ${e.message}`);
  } finally {
    $('variations').disabled = false;
  }
};
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
  $('preset').onchange = () => {
    specSnapshot();  // what was shown before this preset, its menu value included
    shownPreset = $('preset').value;
    loadSpec(presets[shownPreset]);
    requestGenerate();
  };
  if (presets['young-volcano']) { $('preset').value = shownPreset = 'young-volcano'; loadSpec(presets['young-volcano']); }
} catch (e) { status('presets: ' + e.message); }
setMode('paint');
