// Browser test of the studio's controls: one check per point a new
// user tripped over — each one failed on the page before the fix. Debian's
// chromium driven by playwright-core, as browser_test.mjs.
//   node ux_test.mjs URL [--only NAME] [--part K/N] [--screenshots DIR]
// --part K/N runs checks K, K+N, K+2N, … (1-based): ctest runs the checks as
// two entries so that neither passes a minute (tests/CMakeLists.txt).
// Prints one line per check and a JSON summary (with the stroke-to-update
// lags it saw) on stdout; exit 1 if any check fails.
import { createRequire } from 'node:module';
const require = createRequire((process.env.REEFGEN_NODE_MODULES || '.') + '/');
const { chromium } = require('playwright-core');

const url = process.argv[2];
const arg = (name, dflt) => { const i = process.argv.indexOf(name); return i > 0 ? process.argv[i + 1] : dflt; };
const only = arg('--only', '');
const shots = arg('--screenshots', '');
const [partK, partN] = arg('--part', '1/1').split('/').map(Number);
if (!(partN >= 1 && partK >= 1 && partK <= partN)) throw new Error(`--part ${arg('--part')}: expected K/N with 1 <= K <= N`);
let checkNo = 0;
const failures = [];
const summary = {};

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});

// A fresh page at the given viewport, loaded and showing its first island.
async function open(width = 1400, height = 900) {
  const page = await browser.newPage({ viewport: { width, height }, acceptDownloads: true });
  page.errors = [];
  page.notFound = [];
  page.on('pageerror', (e) => page.errors.push(String(e)));
  page.on('response', (r) => { if (r.status() === 404) page.notFound.push(r.url()); });
  await page.goto(url);
  await page.waitForFunction(() => window.__reefgen && window.__reefgen.updates >= 1, null, { timeout: 30000 });
  return page;
}
const updates = (page) => page.evaluate(() => window.__reefgen.updates);
async function nextUpdate(page, n, timeout = 20000) {
  try {
    await page.waitForFunction((k) => window.__reefgen.updates > k, n, { timeout });
  } catch (e) {  // say which wait: a bare playwright timeout names none
    const now = await page.evaluate(() => window.__reefgen.updates).catch(() => '?');
    throw new Error(`no view after update ${n} within ${timeout} ms (updates now ${now})`);
  }
}
// The painting's pixels, summed per channel (cheap fingerprint) and at a point.
const canvasSums = (page) => page.evaluate(() => {
  const c = document.getElementById('paint'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  const s = [0, 0, 0];
  for (let i = 0; i < d.length; i += 4) { s[0] += d[i]; s[1] += d[i + 1]; s[2] += d[i + 2]; }
  return s.join(',');
});
const pixelAt = (page, fx, fy) => page.evaluate(([x, y]) => {
  const c = document.getElementById('paint');
  return Array.from(c.getContext('2d').getImageData(Math.floor(x * c.width), Math.floor(y * c.height), 1, 1).data.slice(0, 3));
}, [fx, fy]);
async function stroke(page, fx, fy, { dx = 40, dy = 25, steps = 6 } = {}) {
  const b = await page.locator('#paint').boundingBox();
  const x = b.x + fx * b.width, y = b.y + fy * b.height;
  await page.mouse.move(x, y);
  await page.mouse.down();
  for (let k = 1; k <= steps; ++k) await page.mouse.move(x + dx * k / steps, y + dy * k / steps);
  await page.mouse.up();
}

async function check(name, body) {
  if (only && only !== name) return;
  if (checkNo++ % partN !== partK - 1) return;
  let page;
  try {
    page = await body();
    if (page && page.errors.length) throw new Error('page errors: ' + page.errors.join(' | '));
    console.log(`ok   ${name}`);
  } catch (e) {
    failures.push(name);
    console.log(`FAIL ${name}: ${e.message.split('\n')[0]}`);
  } finally {
    if (page) await page.close();
  }
}
const expect = (cond, msg) => { if (!cond) throw new Error(msg); };

// 1. Subsidence re-sinks the whole painting, live, in one request per change.
await check('subsidence-resinks-the-painting', async () => {
  const page = await open();
  const before = await pixelAt(page, 0.5, 0.5), sum0 = await page.evaluate(() => window.__reefgen.lastSum);
  const n = await updates(page);
  let infers = 0;
  page.on('request', (r) => { if (r.url().includes('/api/infer')) infers += 1; });
  await page.locator('#paint-subsidence').fill('80');
  await nextUpdate(page, n);
  await page.waitForTimeout(300);
  const after = await pixelAt(page, 0.5, 0.5);
  expect(Math.max(...before) > 240, `the default painting is not bright at Subsidence 0 (${before})`);
  expect(Math.abs(Math.max(...after) - 255 * (1 - 0.75 * 0.8)) <= 3, `centre pixel ${after} is not at Subsidence 80's brightness`);
  expect(after[2] === 0 && after[0] > 0 && after[1] > 0, `centre pixel ${after} lost its hue (island = yellow)`);
  const sum1 = await page.evaluate(() => window.__reefgen.lastSum);
  expect(sum1 < sum0, 'the heights did not sink with the Subsidence');
  expect(infers === 1, `${infers} inference requests for one Subsidence change`);
  // One undo step restores the painting and the slider.
  await page.click('#undo');
  await page.waitForTimeout(200);
  expect(await page.inputValue('#paint-subsidence') === '0', 'undo did not restore the Subsidence slider');
  expect(Math.max(...await pixelAt(page, 0.5, 0.5)) > 240, 'undo did not restore the bright painting');
  return page;
});

// 1a. Age (in My, infer --age-myr) moves both things an age sets: the
// Subsidence slider to √(t / 60 My) (the painting re-sunk) and the Maturity
// to t / 1 My, sent as ?maturity= in the one request of that change; the
// Maturity then moves alone. Untouched, no maturity is sent.
await check('age-sets-subsidence-and-maturity', async () => {
  const page = await open();
  const urls = [];
  page.on('request', (r) => { if (r.url().includes('/api/infer')) urls.push(r.url()); });
  expect(await page.evaluate(() => window.__reefgen.maturity()) === null, 'a maturity is set before the Age moved');
  const n = await updates(page);
  // Position 77 of the log scale 0.05…60 My: 0.05 · 1200^0.77 = 11.8 My.
  await page.locator('#age-myr').fill('77');
  await nextUpdate(page, n);
  await page.waitForTimeout(300);
  const t = 0.05 * Math.pow(1200, 0.77);
  const sub = Number(await page.inputValue('#paint-subsidence'));
  expect(sub === Math.round(100 * Math.sqrt(t / 60)), `Age ${t.toFixed(1)} My set Subsidence ${sub}, not ${Math.round(100 * Math.sqrt(t / 60))}`);
  expect(Math.abs(Math.max(...await pixelAt(page, 0.5, 0.5)) - 255 * (1 - 0.75 * sub / 100)) <= 3, 'the painting was not re-sunk to the Age');
  const m = await page.evaluate(() => window.__reefgen.maturity());
  expect(Math.abs(m - t) / t < 0.07, `Age ${t.toFixed(1)} My set Maturity ${m}`);
  expect(urls.length === 1 && urls[0].includes(`maturity=${m}`), `one request with maturity=${m}: ${urls.join(' ')}`);
  expect((await page.$eval('#age-myr-out', (o) => o.textContent)) === `${t.toFixed(0)} My`, 'the Age does not show its years');
  const k = await updates(page);
  await page.locator('#maturity').fill('10');
  await nextUpdate(page, k);
  expect(Number(await page.inputValue('#paint-subsidence')) === sub, 'the Maturity moved the Subsidence');
  expect(urls.length === 2 && /maturity=0\.091(&|$)/.test(urls[1]), `Maturity alone: ${urls[1]}`);
  return page;
});

// 1b. Re-sinking a soft edge gives what painting it at that Subsidence gives: the
// blend of yellow over blue is dim grey, and must stay as dim (scaling each
// pixel to full brightness made it a bright land ring: +46.5 m where
// painting at that Subsidence gives −1.8 m).
await check('resinking-a-soft-edge-equals-painting-it-at-that-subsidence', async () => {
  const paintStrokes = async (page) => {
    await page.click('#clear');
    await page.locator('#softness').fill('100');
    await page.click('.region[data-region="3"]');  // reef
    await stroke(page, 0.3, 0.5, { dx: 120, dy: 0 });
    await page.click('.region[data-region="0"]');  // island over it, soft
    await stroke(page, 0.45, 0.35, { dx: 0, dy: 80 });
  };
  const canvas = (page) => page.evaluate(() => {
    const c = document.getElementById('paint');
    return Array.from(c.getContext('2d').getImageData(0, 0, c.width, c.height).data);
  });
  const reaged = await open();
  await paintStrokes(reaged);
  await reaged.locator('#paint-subsidence').fill('60');
  const a = await canvas(reaged);
  const direct = await open();
  await direct.locator('#paint-subsidence').fill('60');
  await paintStrokes(direct);
  const b = await canvas(direct);
  await direct.close();
  let worst = 0, at = 0;
  for (let i = 0; i < a.length; ++i) if (Math.abs(a[i] - b[i]) > worst) { worst = Math.abs(a[i] - b[i]); at = i; }
  // Rounding only: each of the stroke's overlapping dabs is composited and
  // rounded to 8 bits at its own brightness (measured: 6 at most); 8 of 255
  // is a subsidence error of 0.04. Scaling each pixel to V gave 71 here.
  expect(worst <= 8, `re-aged pixel ${at >> 2} differs by ${worst} from painting at Subsidence 60 (${a.slice(at & ~3, (at & ~3) + 3)} vs ${b.slice(at & ~3, (at & ~3) + 3)})`);
  return reaged;
});

// 2. A legend says what each colour becomes at the current Subsidence, before painting.
await check('legend-says-what-each-colour-becomes', async () => {
  const page = await open();
  const legend = page.locator('#subsidence-legend');
  expect(await legend.isVisible(), 'no legend beside the brushes');
  const row = (r) => page.locator(`#subsidence-legend [data-region="${r}"]`).innerText();
  // docs/INFERENCE.md's table: a lagoon is water at every Subsidence; a bright
  // beach is land, a dark one partly (green on a reef ring: motu).
  expect(/^\S+ → land/.test(await row(0)) && /→ land/.test(await row(1)), `at Subsidence 0 island/beach should say land: ${await row(0)} / ${await row(1)}`);
  expect(/water/.test(await row(2)), `a lagoon is water at Subsidence 0: ${await row(2)}`);
  await page.locator('#paint-subsidence').fill('60');
  expect(/water/.test(await row(0)) && /water/.test(await row(2)), `at Subsidence 60 island/lagoon should say water: ${await row(0)} / ${await row(2)}`);
  expect(/\d+ % land/.test(await row(1)), `at Subsidence 60 a beach is partly land (motu): ${await row(1)}`);
  expect(/water/.test(await row(4)), 'abyss should say water');
  return page;
});

// 3. Swatches with visible names and aria-labels; every slider shows its value.
await check('swatches-named-sliders-show-values', async () => {
  const page = await open();
  const names = await page.$$eval('.region', (bs) => bs.map((b) => [b.innerText.trim(), b.getAttribute('aria-label')]));
  expect(names.length === 5, `${names.length} swatches`);
  for (const [text, aria] of names) expect(text.length > 2 && aria && aria.includes(text), `swatch "${text}" / aria "${aria}"`);
  for (const id of ['brush', 'softness', 'paint-subsidence', 'exaggeration']) {
    const out = () => page.$eval(`output[for="${id}"]`, (o) => o.textContent).catch(() => '');
    const v = await page.inputValue(`#${id}`);
    expect((await out()).startsWith(v), `#${id} shows "${await out()}", value ${v}`);
  }
  await page.locator('#brush').fill('40');
  expect((await page.$eval('output[for="brush"]', (o) => o.textContent)).startsWith('40'), 'brush value not updated');
  return page;
});

// 4. Ctrl-Z while typing in the export name does not undo the painting.
await check('ctrl-z-in-a-text-field-keeps-the-painting', async () => {
  const page = await open();
  const n = await updates(page);
  await stroke(page, 0.2, 0.2);
  await nextUpdate(page, n);
  const painted = await canvasSums(page);
  await page.click('#name');
  await page.keyboard.type('x');
  await page.keyboard.press('Control+z');
  await page.waitForTimeout(300);
  expect(await canvasSums(page) === painted, 'Ctrl-Z in the name field undid the painting');
  // On the canvas it still undoes.
  await page.focus('#paint');
  await page.keyboard.press('Control+z');
  await page.waitForTimeout(300);
  expect(await canvasSums(page) !== painted, 'Ctrl-Z on the canvas did not undo');
  return page;
});

// 5. Undo after a canvas-size change puts the size menu back.
await check('undo-restores-the-size-menu', async () => {
  const page = await open();
  await page.selectOption('#canvas-size', '512');
  expect(await page.$eval('#paint', (c) => c.width) === 512, 'canvas not 512');
  await page.click('#undo');
  await page.waitForTimeout(200);
  const w = await page.$eval('#paint', (c) => c.width), menu = await page.inputValue('#canvas-size');
  expect(w === 256 && menu === '256', `after undo: canvas ${w}, menu ${menu}`);
  await page.click('#redo');
  await page.waitForTimeout(200);
  expect(await page.inputValue('#canvas-size') === '512', 'redo did not restore the menu');
  return page;
});

// 6. Fill replaces a region with its soft edge: no seams of the old colour.
await check('fill-leaves-no-seams', async () => {
  const page = await open();
  await page.click('#clear');
  await page.click('.region[data-region="1"]');  // beach, default softness
  for (const [x, y] of [[0.3, 0.3], [0.5, 0.6], [0.6, 0.35]]) await stroke(page, x, y, { dx: 120, dy: 60, steps: 12 });
  await page.click('#tool-fill');
  await page.click('.region[data-region="2"]');  // lagoon replaces the abyss
  const b = await page.locator('#paint').boundingBox();
  await page.mouse.click(b.x + 3, b.y + 3);
  const seams = await page.evaluate(() => {
    const c = document.getElementById('paint'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let n = 0;  // red survives only in the old abyss colour and its blends
    const where = [];
    for (let i = 0; i < d.length; i += 4) if (d[i] > 24) { n += 1; if (where.length < 8) where.push([(i / 4) % c.width, Math.floor(i / 4 / c.width), d[i], d[i + 1], d[i + 2]]); }
    return n ? `${n} ${JSON.stringify(where)}` : 0;
  });
  summary.fill_seam_pixels = seams;
  expect(seams < 100, `${seams} pixels keep the old abyss colour after the fill`);
  return page;
});

// 7. Exports are offered only where they work: no Spec JSON in paint mode.
await check('exports-offered-where-they-work', async () => {
  const page = await open();
  const spec = page.locator('#exports button[data-format="spec"]');
  expect(!(await spec.isVisible()), 'Spec JSON is offered in paint mode');
  await page.click('#mode-curves');
  expect(await spec.isVisible(), 'Spec JSON is not offered in curves mode');
  return page;
});

// 8. 16-bit exports keep the whole range and say so.
await check('png16-export-states-its-unclipped-range', async () => {
  const page = await open();
  await page.click('#mode-curves');
  await page.selectOption('#preset', 'young-volcano');
  await page.waitForFunction(() => window.__reefgen.lastMeta && window.__reefgen.lastMeta.label_png, null, { timeout: 20000 });
  await page.waitForTimeout(300);
  const maxM = await page.evaluate(() => window.__reefgen.lastMeta.max_m);
  await Promise.all([page.waitForEvent('download', { timeout: 20000 }), page.click('#exports button[data-format="png16"]')]);
  const text = await page.locator('#status').innerText();
  const m = text.match(/(-?[\d.]+)…(-?[\d.]+) m → 0…65535/);
  expect(m, `the status does not state the PNG16 range: "${text}"`);
  expect(Number(m[2]) >= maxM - 0.05, `range top ${m[2]} m below the island's ${maxM} m: clipped`);
  summary.png16_range_m = [Number(m[1]), Number(m[2])];
  return page;
});

// 8b. Engine bundles from the export bar: one ZIP of the bundle folder,
// with its README and the engine's files (docs/ENGINES.md).
await check('bundle-export-downloads-a-zip', async () => {
  const page = await open();
  const fs = await import('node:fs');
  for (const [engine, file] of [['unity', 'island.raw'], ['godot', 'island.control.exr']]) {
    const [dl] = await Promise.all([page.waitForEvent('download', { timeout: 60000 }),
                                    page.click(`#exports button[data-format="${engine}"]`)]);
    expect(dl.suggestedFilename() === `island.${engine}.zip`, `download named ${dl.suggestedFilename()}`);
    const bytes = fs.readFileSync(await dl.path());
    const text = bytes.toString('latin1');
    expect(text.startsWith('PK\x03\x04'), `${engine}: not a ZIP`);
    for (const want of [`island.${engine}/README.txt`, `island.${engine}/${file}`])
      expect(text.includes(want), `${engine}: the ZIP lacks ${want}`);
    await page.waitForFunction(() => /exported/.test(document.getElementById('status').textContent), null, { timeout: 20000 });
  }
  return page;
});

// 8c. The layer switch: materials and flow replace the hill-shaded heights
// on the 2D view and the 3D surface, and Heights brings them back.
await check('layer-views-switch', async () => {
  const page = await open();
  const pixels = () => page.evaluate(() => {
    const c = document.getElementById('shade'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
    let h = 0;
    for (let i = 0; i < d.length; i += 97) h = (h * 31 + d[i]) >>> 0;
    return h;
  });
  const heights = await pixels(), shot0 = await page.evaluate(() => window.__reefgen.snapshot3d());
  const seen = {};
  for (const view of ['materials', 'flow']) {
    const n = await page.evaluate(() => window.__reefgen.layerViews);
    await page.selectOption('#layer-view', view);
    await page.waitForFunction((k) => window.__reefgen.layerViews > k, n, { timeout: 30000 });
    seen[view] = await pixels();
    expect(seen[view] !== heights, `${view}: the 2D view still shows the heights`);
    expect(await page.evaluate(() => window.__reefgen.snapshot3d()) !== shot0, `${view}: the 3D view did not change`);
  }
  expect(seen.materials !== seen.flow, 'materials and flow look the same');
  await page.selectOption('#layer-view', 'heights');
  await page.waitForTimeout(300);
  expect(await pixels() === heights, 'Heights did not bring the hill-shaded heights back');
  if (shots) await page.selectOption('#layer-view', 'materials');
  return page;
});

// 9. At 1024×700 canvas and 3D view sit side by side, both on screen.
await check('side-by-side-at-1024x700', async () => {
  const page = await open(1024, 700);
  const p = await page.locator('#paint').boundingBox(), v = await page.locator('#view3d').boundingBox();
  expect(v.x >= p.x + p.width - 1, `3D view (x ${v.x}) not beside the canvas (right edge ${p.x + p.width})`);
  expect(p.y + p.height <= 700 && v.y + v.height <= 700, `below the fold: canvas bottom ${p.y + p.height}, view bottom ${v.y + v.height}`);
  expect(p.width >= 300 && v.width >= 300, `too small: canvas ${p.width}, view ${v.width}`);
  if (shots) await page.screenshot({ path: `${shots}/studio-1024x700.png` });
  return page;
});

// 10. Ten quick strokes: never more than one inference in flight, and the
// last view answers the last stroke. The lag is printed (the bar lives in
// scripts/bench-studio.sh, not in a test).
await check('quick-strokes-one-inference-behind', async () => {
  const page = await open();
  // Count before the change: read after it, a quick 1024² answer already
  // counted would leave the wait for one more that never comes.
  const n = await updates(page);
  await page.selectOption('#canvas-size', '1024');
  await nextUpdate(page, n, 30000);
  let open_ = 0, maxOpen = 0;
  page.on('request', (r) => { if (r.url().includes('/api/infer')) maxOpen = Math.max(maxOpen, ++open_); });
  const done = (r) => { if (r.url().includes('/api/infer')) open_ -= 1; };
  page.on('requestfinished', done);
  page.on('requestfailed', done);
  await page.click('.region[data-region="0"]');
  for (let s = 0; s < 10; ++s) {
    await stroke(page, 0.2 + 0.05 * s, 0.25 + 0.04 * s, { dx: 20, dy: 10, steps: 3 });
    await page.waitForTimeout(120);
  }
  // The view that is finally drawn answers the last change queued.
  const last = await page.evaluate(() => window.__reefgen.lastQueuedAt);
  await page.waitForFunction((t) => window.__reefgen.lastRequestedAt === t, last, { timeout: 60000 });
  const lag = await page.evaluate(() => window.__reefgen.timings[window.__reefgen.timings.length - 1].total_ms);
  summary.quick_strokes_1024 = { max_requests_in_flight: maxOpen, last_stroke_to_view_ms: Math.round(lag) };
  expect(maxOpen <= 1, `${maxOpen} inference requests in flight at once`);
  return page;
});

// 11. A 1024² canvas shows its full resolution in 3D.
await check('3d-view-at-full-resolution', async () => {
  const page = await open();
  const n = await updates(page);
  await page.selectOption('#canvas-size', '1024');
  await nextUpdate(page, n, 30000);
  const v = await page.evaluate(() => ({ size: window.__reefgen.lastMeta.size, view: window.__reefgen.view3d }));
  expect(v.size === 1024, `the answer is ${v.size}²`);
  expect(v.view && v.view.texture_px === 1024, `the 3D surface is ${v.view && v.view.texture_px}², not the answer's 1024²`);
  expect(v.view.mesh_px >= 256, `mesh ${v.view.mesh_px}²`);
  if (shots) {  // docs/studio-1024.png: the example painting on the 1024² canvas
    const k = await updates(page);
    await page.setInputFiles('#load', process.env.REEFGEN_SHOT_SKETCH || 'docs/examples/painted-sketch.png');
    await nextUpdate(page, k, 30000);
    await page.waitForTimeout(500);
    await page.screenshot({ path: `${shots}/studio-1024.png` });
  }
  return page;
});

// 12. Curves: after a wind stroke the handles sit on the deformed region
// edges; and no request 404s (favicon).
await check('handles-follow-the-wind-and-no-404', async () => {
  const page = await open();
  await page.click('#mode-curves');
  await page.selectOption('#preset', 'young-volcano');
  await page.waitForTimeout(500);
  const n = await page.evaluate(() => window.__reefgen.labelsShown || 0);
  const b = await page.locator('#curves').boundingBox();
  await page.keyboard.down('Shift');
  await page.mouse.move(b.x + 0.25 * b.width, b.y + 0.5 * b.height);
  await page.mouse.down();
  for (let k = 1; k <= 10; ++k) await page.mouse.move(b.x + (0.25 + 0.05 * k) * b.width, b.y + 0.5 * b.height);
  await page.mouse.up();
  await page.keyboard.up('Shift');
  await page.waitForFunction((k) => (window.__reefgen.labelsShown || 0) > k, n, { timeout: 20000 });
  await page.waitForTimeout(300);
  const worst = await page.evaluate(() => {
    const img = window.__reefgen.labelImage(), n = img.width, c = document.createElement('canvas');
    c.width = c.height = n;
    const x = c.getContext('2d'); x.drawImage(img, 0, 0);
    const d = x.getImageData(0, 0, n, n).data;
    const region = (px, py) => {  // the test's own reading of the label colours
      px = Math.max(0, Math.min(n - 1, px)); py = Math.max(0, Math.min(n - 1, py));
      const i = 4 * (py * n + px), [R, G, B] = [d[i], d[i + 1], d[i + 2]], m = Math.max(R, G, B) / 2;
      if (R > m && G > m) return 0; if (G > m && B > m) return 2; if (G > m) return 1; if (B > m) return 3; return 4;
    };
    const cv = document.getElementById('curves'), handles = window.__reefgen.handles();
    let worst = 0;
    for (let ring = 0; ring < 4; ++ring) for (const [hx, hy] of handles[ring]) {
      const px = Math.floor(hx / cv.width * n), py = Math.floor(hy / cv.height * n);
      let best = 99;  // distance (label px) to an edge between ≤ ring and > ring
      for (let dy = -6; dy <= 6; ++dy) for (let dx = -6; dx <= 6; ++dx) {
        const a = region(px + dx, py + dy) <= ring, e = region(px + dx + 1, py + dy) <= ring, s = region(px + dx, py + dy + 1) <= ring;
        if (a !== e || a !== s) best = Math.min(best, Math.hypot(dx, dy));
      }
      worst = Math.max(worst, best);
    }
    return worst;
  });
  summary.handle_to_edge_px_max = worst;
  expect(worst <= 2, `a handle sits ${worst} label px off its region's edge`);
  expect(page.notFound.length === 0, `404: ${page.notFound.join(', ')}`);
  return page;
});

// 13. Curves mode: a preset's subsidence shows its own number (it showed the
// previous one: slider 90, label 74), and undo steps back through presets
// and drags, Ctrl-Z included.
await check('curves-subsidence-label-and-undo', async () => {
  const page = await open();
  await page.click('#mode-curves');
  await page.selectOption('#preset', 'barrier-reef');
  await page.selectOption('#preset', 'atoll');
  const label = () => page.$eval('output[for="subsidence"]', (o) => o.textContent);
  expect(await page.inputValue('#subsidence') === '90' && (await label()).startsWith('90'),
    `atoll: slider ${await page.inputValue('#subsidence')}, label ${await label()}`);
  // A drag of a ring handle: the outer ring's right-hand handle, outwards.
  const before = await page.evaluate(() => window.__reefgen.spec());
  const h = await page.evaluate(() => window.__reefgen.handles()[4][0]);
  const b = await page.locator('#curves').boundingBox(), cv = await page.$eval('#curves', (c) => c.width);
  const k = b.width / cv;
  await page.mouse.move(b.x + h[0] * k, b.y + h[1] * k);
  await page.mouse.down();
  await page.mouse.move(b.x + h[0] * k + 30, b.y + h[1] * k, { steps: 5 });
  await page.mouse.up();
  expect(await page.evaluate(() => window.__reefgen.spec()) !== before, 'the drag moved nothing');
  await page.keyboard.press('Control+z');  // the canvas has the focus after the drag
  expect(await page.evaluate(() => window.__reefgen.spec()) === before, 'Ctrl-Z did not undo the drag');
  await page.click('#curves-undo');
  expect(await page.inputValue('#preset') === 'barrier-reef' && (await label()).startsWith('30'),
    `undo of the atoll preset: ${await page.inputValue('#preset')}, label ${await label()}`);
  await page.click('#curves-redo');
  expect(await page.inputValue('#preset') === 'atoll' && (await label()).startsWith('90'), 'redo did not bring the atoll back');
  return page;
});

// 14. The camera never goes under the sea, however far it is dragged up, and
// Reset view brings the first view back.
await check('camera-stays-above-the-sea-and-resets', async () => {
  const page = await open();
  if (!await page.evaluate(() => !!window.__reefgen.camera)) return page;  // no three.js in this build: nothing to orbit
  const first = await page.evaluate(() => window.__reefgen.camera());
  const b = await page.locator('#view3d').boundingBox();
  await page.mouse.move(b.x + b.width / 2, b.y + b.height / 2);
  await page.mouse.down();
  await page.mouse.move(b.x + b.width / 2, b.y - 2 * b.height, { steps: 20 });  // far past a sixth of the view
  await page.mouse.up();
  const dragged = await page.evaluate(() => window.__reefgen.camera());
  expect(dragged.y > 0, `camera at y = ${dragged.y.toFixed(2)}: under the sea`);
  expect(Math.abs(dragged.polar - first.polar) > 0.2, 'the drag did not orbit at all');
  await page.click('#view-reset');
  const back = await page.evaluate(() => window.__reefgen.camera());
  expect(Math.abs(back.y - first.y) < 1e-6 && Math.abs(back.polar - first.polar) < 1e-6, 'Reset view did not return to the first view');
  return page;
});

// 15. A slow export says it is working (an OBJ took 7 s with no word).
await check('export-shows-progress', async () => {
  const page = await open();
  const n = await updates(page);
  await page.selectOption('#canvas-size', '1024');
  await nextUpdate(page, n, 30000);
  const obj = page.locator('#exports button[data-format="obj"]');
  const download = page.waitForEvent('download', { timeout: 60000 });
  await obj.click();
  await page.waitForTimeout(150);
  const during = await page.$eval('#status', (e) => e.textContent);
  const disabled = await obj.isDisabled();
  await download;
  expect(/exporting .*…/.test(during), `status during the export: "${during}"`);
  expect(disabled, 'the export button stayed live during its export');
  await page.waitForFunction(() => /exported/.test(document.getElementById('status').textContent), null, { timeout: 60000 });
  expect(!await obj.isDisabled(), 'the export button stayed disabled');
  return page;
});

await browser.close();
summary.failed = failures;
console.log(JSON.stringify(summary));
process.exitCode = failures.length ? 1 : 0;
