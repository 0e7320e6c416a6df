// Browser test of reefgen studio: Debian's chromium driven by
// playwright-core (no browser download). Paints strokes, checks that the 3D
// and 2D views update, drags a curve handle, exports a GLB, and prints the
// stroke-to-update timings (request -> heights -> drawn) as JSON on stdout.
//   node browser_test.mjs URL [--strokes N] [--size 256|512|1024] [--burst] [--screenshot FILE]
// --size paints on that canvas; --burst then adds 10 strokes in 2 s and
// reports the time from the last one to its view (the bar).
import { createRequire } from 'node:module';
// playwright-core lives in the build's npm folder (studio/package-lock.json).
const require = createRequire((process.env.REEFGEN_NODE_MODULES || '.') + '/');
const { chromium } = require('playwright-core');

const url = process.argv[2];
const arg = (name, dflt) => { const i = process.argv.indexOf(name); return i > 0 ? process.argv[i + 1] : dflt; };
const strokes = Number(arg('--strokes', 12));
const shot = arg('--screenshot', '');
const size = arg('--size', '256');
const burst = process.argv.includes('--burst');
const fail = (msg) => { console.error('FAIL: ' + msg); process.exitCode = 1; };

const browser = await chromium.launch({
  executablePath: process.env.CHROMIUM || '/usr/bin/chromium',
  args: ['--no-sandbox', '--use-gl=angle', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
});
try {
  const page = await browser.newPage({ viewport: { width: 1400, height: 900 }, acceptDownloads: true });
  const consoleErrors = [];
  page.on('pageerror', (e) => consoleErrors.push(String(e)));
  await page.goto(url);
  await page.waitForFunction(() => window.__reefgen && window.__reefgen.updates >= 1, null, { timeout: 30000 });
  const has3d = await page.evaluate(() => !!document.querySelector('#view3d canvas'));
  if (!has3d) fail('no 3D canvas (three.js missing from the build?)');

  if (size !== '256') {
    const n = await page.evaluate(() => window.__reefgen.updates);
    await page.selectOption('#canvas-size', size);
    await page.waitForFunction((k) => window.__reefgen.updates > k, n, { timeout: 30000 });
  }
  // Paint: pick the island brush and draw strokes; each must update the views.
  const box = await page.locator('#paint').boundingBox();
  await page.click('.region[data-region="0"]');
  let before = await page.evaluate(() => window.__reefgen.updates);
  const first = await page.evaluate(() => window.__reefgen.timings.length);  // the strokes' timings start here
  for (let s = 0; s < strokes; ++s) {
    const cx = box.x + box.width * (0.25 + 0.5 * ((s * 37) % 10) / 10), cy = box.y + box.height * (0.3 + 0.4 * ((s * 53) % 10) / 10);
    await page.mouse.move(cx, cy);
    await page.mouse.down();
    for (let k = 1; k <= 6; ++k) await page.mouse.move(cx + k * 8, cy + k * 5);
    await page.mouse.up();
    await page.waitForFunction((n) => window.__reefgen.updates > n, before, { timeout: 10000 });
    before = await page.evaluate(() => window.__reefgen.updates);
  }
  const sums = await page.evaluate(() => window.__reefgen.lastSum);
  let burstMs = null;
  if (burst) {  // 10 strokes in 2 s: the last stroke's view, timed from its end
    for (let s = 0; s < 10; ++s) {
      const cx = box.x + box.width * (0.3 + 0.04 * s), cy = box.y + box.height * 0.6;
      await page.mouse.move(cx, cy); await page.mouse.down();
      for (let k = 1; k <= 3; ++k) await page.mouse.move(cx + k * 6, cy + k * 4);
      await page.mouse.up();
      await page.waitForTimeout(150);
    }
    const last = await page.evaluate(() => window.__reefgen.lastQueuedAt);
    await page.waitForFunction((t) => window.__reefgen.lastRequestedAt === t, last, { timeout: 30000 });
    burstMs = await page.evaluate(() => window.__reefgen.timings[window.__reefgen.timings.length - 1].total_ms);
  }
  // Undo every stroke: the heights must change back.
  for (let s = 0; s < strokes; ++s) await page.click('#undo');
  await page.waitForFunction((v) => Math.abs(window.__reefgen.lastSum - v) > 1, sums, { timeout: 15000 });

  // The 3D view really draws terrain: its pixels vary.
  const spread = await page.evaluate(async () => {
    const img = new Image();
    img.src = window.__reefgen.snapshot3d();
    await img.decode();
    const g = document.createElement('canvas'); g.width = 64; g.height = 48;
    const x = g.getContext('2d'); x.drawImage(img, 0, 0, 64, 48);
    const d = x.getImageData(0, 0, 64, 48).data; let lo = 255, hi = 0;
    for (let i = 0; i < d.length; i += 4) { const v = (d[i] + d[i + 1] + d[i + 2]) / 3; lo = Math.min(lo, v); hi = Math.max(hi, v); }
    return hi - lo;
  });
  if (!(spread > 30)) fail(`3D view looks blank (pixel spread ${spread})`);

  // Relief 0 paints a pastel of the region's hue (saturation 0.35, a smooth
  // shield to the decoder); the server answers it; Relief back to 100.
  {
    await page.$eval('#relief', (el) => { el.value = '0'; el.dispatchEvent(new Event('input')); });
    const n = await page.evaluate(() => window.__reefgen.updates);
    const px = box.x + box.width * 0.5, py = box.y + box.height * 0.5;
    await page.mouse.move(px, py); await page.mouse.down(); await page.mouse.move(px + 2, py + 1); await page.mouse.up();
    await page.waitForFunction((k) => window.__reefgen.updates > k, n, { timeout: 15000 });
    const rgb = await page.evaluate(() => {
      const c = document.getElementById('paint');
      return Array.from(c.getContext('2d').getImageData(c.width / 2, c.height / 2, 1, 1).data.slice(0, 3));
    });
    const mx = Math.max(...rgb), sat = (mx - Math.min(...rgb)) / mx;
    if (!(Math.abs(sat - 0.35) < 0.03) || !(rgb[0] > 200 && rgb[1] > 200)) fail(`relief 0: painted ${rgb} (saturation ${sat}), not a pastel yellow`);
    await page.$eval('#relief', (el) => { el.value = '100'; el.dispatchEvent(new Event('input')); });
  }

  // Re-roll: another island (the heights change), the painting untouched, the seed shown.
  {
    const paintSum = () => page.evaluate(() => {
      const c = document.getElementById('paint'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
      let s = 0; for (let i = 0; i < d.length; ++i) s = (s * 31 + d[i]) >>> 0; return s;
    });
    const canvas0 = await paintSum(), heights0 = await page.evaluate(() => window.__reefgen.lastSum);
    const n = await page.evaluate(() => window.__reefgen.updates);
    await page.click('#reroll');
    await page.waitForFunction((k) => window.__reefgen.updates > k, n, { timeout: 15000 });
    const heights1 = await page.evaluate(() => window.__reefgen.lastSum);
    if (!(Math.abs(heights1 - heights0) > 1)) fail(`re-roll: the heights did not change (${heights0} -> ${heights1})`);
    if ((await paintSum()) !== canvas0) fail('re-roll: the painting changed');
    if ((await page.evaluate(() => window.__reefgen.islandSeed())) !== 1) fail('re-roll: the seed is not 1 after one click');
    if (!(await page.textContent('#reroll')).includes('seed 1')) fail('re-roll: the button does not show the seed');
    // Variations: the next four seeds' islands side by side; clicking the
    // third keeps its seed (4) and draws that island.
    await page.click('#variations');
    await page.waitForFunction(() => document.querySelectorAll('#variations-sheet img').length === 4, null, { timeout: 30000 });
    const seeds = await page.$$eval('#variations-sheet img', (ims) => ims.map((i) => Number(i.dataset.seed)));
    if (seeds.join(',') !== '2,3,4,5') fail(`variations: seeds ${seeds}, not 2,3,4,5`);
    const loaded = await page.$$eval('#variations-sheet img', (ims) => ims.map((i) => i.complete && i.naturalWidth > 0));
    if (!loaded.every(Boolean)) fail('variations: a picture did not load');
    const m = await page.evaluate(() => window.__reefgen.updates);
    await page.click('#variations-sheet img[data-seed="4"]');
    await page.waitForFunction((k) => window.__reefgen.updates > k, m, { timeout: 15000 });
    if ((await page.evaluate(() => window.__reefgen.islandSeed())) !== 4) fail('variations: picking seed 4 did not keep it');
    if (!(await page.textContent('#reroll')).includes('seed 4')) fail('variations: the Re-roll button does not show seed 4');
    if (!(await page.isHidden('#variations-sheet'))) fail('variations: the sheet stays open after a pick');
  }

  // Export: a GLB download arrives and is glTF.
  const [download] = await Promise.all([page.waitForEvent('download', { timeout: 15000 }), page.click('#exports button[data-format="glb"]')]);
  const stream = await download.createReadStream();
  const chunks = []; for await (const c of stream) chunks.push(c);
  const glb = Buffer.concat(chunks);
  if (glb.subarray(0, 4).toString() !== 'glTF') fail('export: the download is not a GLB');

  // Curves mode: drag a handle of the reef ring outwards; the island is regenerated.
  await page.click('#mode-curves');
  let n0 = await page.evaluate(() => window.__reefgen.updates);
  await page.waitForFunction((n) => window.__reefgen.updates > n, n0, { timeout: 10000 });
  n0 = await page.evaluate(() => window.__reefgen.updates);
  const cb = await page.locator('#curves').boundingBox();
  const handle = await page.evaluate(() => {  // handle k=0 of ring 3 (reef), in page pixels
    const c = document.getElementById('curves'), r = c.getBoundingClientRect();
    return null;
  });
  void handle;
  // Ring 3's first handle sits at angle 0: find it by scanning the right half of the centre row.
  const start = await page.evaluate(() => {
    const c = document.getElementById('curves'), x = c.getContext('2d');
    const d = x.getImageData(0, c.height / 2 - 3, c.width, 6).data;
    // the handle is a 6×6 square of #48f; return the first such pixel right of centre
    for (let i = c.width / 2; i < c.width; ++i) {
      const p = 4 * (3 * c.width + i);
      if (d[p] === 0x44 && d[p + 1] === 0x88 && d[p + 2] === 0xff) return i;
    }
    return -1;
  });
  if (start < 0) fail('curves: reef handle not found');
  else {
    const sx = cb.x + (start + 2) * cb.width / 512, sy = cb.y + cb.height / 2;
    await page.mouse.move(sx, sy); await page.mouse.down();
    await page.mouse.move(sx + 40, sy, { steps: 5 }); await page.mouse.up();
    await page.waitForFunction((n) => window.__reefgen.updates > n, n0, { timeout: 10000 });
  }
  if (shot) {  // docs/studio.png: the example painting, as a user would load it
    await page.click('#mode-paint');
    const n1 = await page.evaluate(() => window.__reefgen.updates);
    await page.setInputFiles('#load', process.env.REEFGEN_SHOT_SKETCH || 'docs/examples/painted-sketch.png');
    await page.waitForFunction((n) => window.__reefgen.updates > n + 1, n1, { timeout: 15000 });
    await page.waitForTimeout(500);
    await page.screenshot({ path: shot });
  }
  if (consoleErrors.length) fail('page errors: ' + consoleErrors.join(' | '));
  const t = await page.evaluate(() => window.__reefgen.timings);
  const paintT = t.slice(first, first + strokes).map((x) => x.total_ms).sort((a, b) => a - b);
  const p95 = paintT[Math.min(paintT.length - 1, Math.ceil(0.95 * paintT.length) - 1)];
  const median = paintT[Math.floor(paintT.length / 2)];
  console.log(JSON.stringify({ size: Number(size), burst_last_stroke_to_view_ms: burstMs, strokes: paintT.length, stroke_to_update_ms_median: median, stroke_to_update_ms_p95: p95,
    server_ms_median: t.slice(first, first + strokes).map((x) => x.server_ms).sort((a, b) => a - b)[Math.floor(paintT.length / 2)],
    phases_ms_median: Object.fromEntries(['encode_ms', 'response_ms', 'update_ms', 'draw_ms'].map((k) => [k,
      t.slice(first, first + strokes).map((x) => x[k]).sort((a, b) => a - b)[Math.floor(paintT.length / 2)]])),
    errors: await page.evaluate(() => window.__reefgen.errors) }));
} finally {
  await browser.close();
}
