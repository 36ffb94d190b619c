// The player page in a real browser, as a user opens it: Debian's chromium driven by
// playwright-core (viewer/node_modules; no browser is downloaded), headless WebGL through
// SwiftShader. Run by CTest (tests/CMakeLists.txt) with CUTSIM (the program), CUTSIM_SCENE (a
// scene with a cut) and CUTSIM_WORK (a scratch folder) in the environment.
//
// 1. `cutsim run SCENE --html`, then the page: its frames' times and triangle counts against the
//    .pvd's frames and their .vtp files, and the CSV's rows at those times (read here, apart).
// 2. The last frame, unlit: a screenshot; the surface covers at least 20% of the view, and the
//    most strained visible triangles are drawn in the colour bar's hot end (its top pixel).
// 3. `cutsim view --max-mb` small: every k-th frame and the last; a partial run plays with its
//    banner; bad folders exit with 2 and say why; `cutsim view --png` renders a still.
import assert from 'node:assert/strict';
import { execFileSync, spawnSync } from 'node:child_process';
import fs from 'node:fs';
import path from 'node:path';
import { createRequire } from 'node:module';

const require = createRequire(import.meta.url);
const viewerModules = path.resolve(path.dirname(new URL(import.meta.url).pathname), '../../viewer/node_modules');
const { chromium } = require(path.join(viewerModules, 'playwright-core'));
const { PNG } = require(path.join(viewerModules, 'pngjs'));

const cutsim = process.env.CUTSIM;
const scene = process.env.CUTSIM_SCENE;
const work = process.env.CUTSIM_WORK;
assert.ok(cutsim && scene && work, 'CUTSIM, CUTSIM_SCENE and CUTSIM_WORK must be set');
fs.rmSync(work, { recursive: true, force: true });
fs.mkdirSync(work, { recursive: true });
const browserPath = process.env.CUTSIM_CHROMIUM || '/usr/bin/chromium';

let failures = 0;
async function check(name, body) {
  try {
    await body();
    console.log(`ok - ${name}`);
  } catch (e) {
    failures++;
    console.log(`not ok - ${name}\n${e.stack || e}`);
  }
}

// --- the run, read apart from the player ---------------------------------------------------------
const out = path.join(work, 'run');
execFileSync(cutsim, ['run', scene, '--out', out, '--html', '--quiet'], { stdio: ['ignore', 'pipe', 'inherit'] });
const html = path.join(out, 'player.html');

function pvdFrames(dir, name) {
  const text = fs.readFileSync(path.join(dir, name), 'utf8');
  return [...text.matchAll(/<DataSet timestep="([^"]+)"[^>]*file="([^"]+)"/g)].map((m) => {
    const vtp = fs.readFileSync(path.join(dir, m[2]), 'utf8');
    return { t: Number(m[1]), triangles: Number(/NumberOfPolys="(\d+)"/.exec(vtp)[1]),
      points: Number(/NumberOfPoints="(\d+)"/.exec(vtp)[1]) };
  });
}

function csvRows(file) {
  const [header, ...lines] = fs.readFileSync(file, 'utf8').trim().split('\n');
  const names = header.split(',');
  return lines.map((l) => Object.fromEntries(l.split(',').map((v, i) => [names[i], Number(v)])));
}

const expected = pvdFrames(out, 'surface.pvd');
const rows = csvRows(path.join(out, 'steps.csv'));
assert.ok(expected.length >= 3, 'the scene writes a few frames');
assert.ok(new Set(expected.map((f) => f.triangles)).size > 1, 'the scene cuts: its triangle count changes');

// --- the browser ----------------------------------------------------------------------------------
const browser = await chromium.launch({
  executablePath: browserPath,
  headless: true,
  args: ['--no-sandbox', '--enable-unsafe-swiftshader', '--use-angle=swiftshader', '--disable-background-networking',
    '--disable-component-update', '--no-first-run', '--disable-sync'],
});

async function open(file) {
  const page = await browser.newPage({ viewport: { width: 1280, height: 800 }, deviceScaleFactor: 1 });
  const errors = [];
  page.on('pageerror', (e) => errors.push(e.message));
  page.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
  // Nothing may be fetched: every request but the page itself (and data: URLs) is refused.
  const requests = [];
  await page.route('**/*', (route) => {
    const url = route.request().url();
    if (url.startsWith('file://') && url.split('#')[0] === 'file://' + file) return route.continue();
    if (url.startsWith('data:')) return route.continue();
    requests.push(url);
    return route.abort();
  });
  await page.goto('file://' + file);
  await page.waitForFunction(() => window.cutsimPlayer && 'ready' in window.cutsimPlayer, null, { timeout: 60000 });
  const state = await page.evaluate(() => ({ ready: window.cutsimPlayer.ready, error: window.cutsimPlayer.error }));
  assert.equal(state.ready, true, `the player is ready (${state.error || errors.join('; ')})`);
  return { page, errors, requests };
}

function decodePng(buffer) { return PNG.sync.read(buffer); }

function pixel(png, x, y) {
  const i = 4 * (Math.round(y) * png.width + Math.round(x));
  return [png.data[i], png.data[i + 1], png.data[i + 2]];
}

const distance = (a, b) => Math.hypot(a[0] - b[0], a[1] - b[1], a[2] - b[2]);

await check('the frames are the .pvd\'s, with the CSV\'s rows at their times', async () => {
  const { page, errors, requests } = await open(html);
  const frames = await page.evaluate(() => window.cutsimPlayer.frames());
  const series = await page.evaluate(() => ({ time: window.cutsimPlayer.series('time'),
    kinetic_energy: window.cutsimPlayer.series('kinetic_energy') }));
  assert.equal(frames.length, expected.length, 'every frame (the run is small)');
  frames.forEach((f, i) => {
    assert.equal(f.t, expected[i].t, `frame ${i}'s time`);
    assert.equal(f.triangles, expected[i].triangles, `frame ${i}'s triangles`);
    assert.equal(f.points, expected[i].points, `frame ${i}'s points`);
    const row = rows.find((r) => r.time === f.t);
    assert.ok(row, `steps.csv has a row at t = ${f.t}`);
    assert.equal(f.csvRow, rows.indexOf(row), `frame ${i}'s CSV row`);
    const kinetic = series.kinetic_energy[f.row], time = series.time[f.row];
    assert.equal(time, f.t, `the page's series at frame ${i}'s row`);
    assert.equal(kinetic, row.kinetic_energy, `the page's kinetic energy at frame ${i}`);
    assert.equal(row.triangles, f.triangles, `the CSV's triangles at t = ${f.t}`);
  });
  const kinetic = await page.evaluate(() => window.cutsimPlayer.series('kinetic_energy'));
  assert.deepEqual(kinetic, rows.map((r) => r.kinetic_energy), 'the plotted series is the CSV\'s column');
  assert.deepEqual(errors, [], 'no error in the page');
  assert.deepEqual(requests, [], 'nothing fetched');
  await page.close();
});

await check('the last frame: the surface covers the view and the most strained triangles are hot', async () => {
  const { page } = await open(html);
  const last = expected.length - 1;
  await page.evaluate((i) => { window.cutsimPlayer.seek(i); window.cutsimPlayer.setLit(false); }, last);
  assert.equal(await page.evaluate(() => window.cutsimPlayer.frame), last);
  // Frames count from 0 everywhere: the label names the frame seek(), --png and #frame= take.
  const label = await page.evaluate(() => document.querySelector('.counts').textContent);
  assert.ok(label.includes(`frame ${last} (0 to ${last})`), `the label of frame ${last}: ${label}`);
  const shot = decodePng(await page.screenshot({ path: path.join(work, 'last_frame.png') }));
  // The 3D view: the canvas's rectangle, minus the panels drawn over it.
  const view = await page.evaluate(() => {
    const r = document.querySelector('#view canvas').getBoundingClientRect();
    const panels = [...document.querySelectorAll('.panel')].filter((p) => getComputedStyle(p).display !== 'none')
      .map((p) => p.getBoundingClientRect()).map((b) => ({ x: b.left, y: b.top, w: b.width, h: b.height }));
    return { x: r.left, y: r.top, w: r.width, h: r.height, panels };
  });
  const background = [0x1f, 0x23, 0x29];
  let covered = 0, total = 0;
  for (let y = Math.ceil(view.y); y < view.y + view.h; y++) {
    for (let x = Math.ceil(view.x); x < view.x + view.w; x++) {
      if (view.panels.some((p) => x >= p.x && x < p.x + p.w && y >= p.y && y < p.y + p.h)) continue;
      total++;
      if (distance(pixel(shot, x, y), background) > 24) covered++;
    }
  }
  const coverage = covered / total;
  console.log(`# surface covers ${(100 * coverage).toFixed(1)}% of the view`);
  assert.ok(coverage >= 0.2, `the surface covers ${(100 * coverage).toFixed(1)}% of the view, less than 20%`);

  // Colours against the colour bar, both read from screenshots. With the range of the whole run
  // (the default), each of the most strained visible triangles is drawn in the bar's colour at
  // its value; with the range of this frame, the most strained are at the bar's hot end.
  const bar = await page.evaluate(() => window.cutsimPlayer.colorbarBox());
  const barColor = (png, position) =>
    pixel(png, bar.x + bar.width / 2, bar.y + 2 + (1 - Math.min(1, Math.max(0, position))) * (bar.height - 5));
  const hot = barColor(shot, 1);
  assert.ok(hot[0] > 200 && hot[2] < 80, `the bar's hot end is red (${hot})`);
  const inRun = await page.evaluate(() => window.cutsimPlayer.hotTriangles(12));
  const seen = inRun.filter((t) => t.visible);
  assert.ok(seen.length > 0, 'one of the most strained triangles is in sight');
  for (const t of seen.slice(0, 3)) {
    const c = pixel(shot, t.x, t.y), want = barColor(shot, t.barPosition);
    assert.ok(distance(c, want) < 60, `triangle ${t.triangle} (strain ${t.value}, at ${t.barPosition.toFixed(3)} of the ` +
      `bar) is drawn ${c}, the bar has ${want} there`);
  }
  await page.evaluate(() => window.cutsimPlayer.setRange('frame'));
  const framed = decodePng(await page.screenshot({ path: path.join(work, 'last_frame_range.png') }));
  const hotFramed = barColor(framed, 1);
  const inFrame = await page.evaluate(() => window.cutsimPlayer.hotTriangles(12));
  assert.ok(inFrame[0].barPosition > 0.999, `the most strained triangle is at ${inFrame[0].barPosition} of the bar`);
  const hotSeen = inFrame.filter((t) => t.visible && t.barPosition >= 0.9);
  assert.ok(hotSeen.length > 0, 'one of the most strained triangles is in sight');
  for (const t of hotSeen.slice(0, 3)) {
    const c = pixel(framed, t.x, t.y);
    assert.ok(distance(c, hotFramed) < 60, `triangle ${t.triangle} (strain ${t.value}) is drawn ${c}, not the hot end ${hotFramed}`);
  }
  await page.close();
});

await check('a size budget keeps one frame in k and the last', async () => {
  // The scene with a frame every step (31 frames), and a budget 3% below its whole page.
  const dense = JSON.parse(fs.readFileSync(scene, 'utf8'));
  dense.output = { ...(dense.output || {}), every: 1 };
  const denseScene = path.join(work, 'dense.json');
  fs.writeFileSync(denseScene, JSON.stringify(dense));
  const denseOut = path.join(work, 'dense');
  execFileSync(cutsim, ['run', denseScene, '--out', denseOut, '--html', '--quiet'], { stdio: ['ignore', 'pipe', 'inherit'] });
  const whole = fs.statSync(path.join(denseOut, 'player.html')).size;
  const budgetMb = (0.97 * whole) / 1048576;
  const small = path.join(work, 'small.html');
  const r = spawnSync(cutsim, ['view', denseOut, '-o', small, '--max-mb', budgetMb.toFixed(4)], { encoding: 'utf8' });
  assert.equal(r.status, 0, r.stderr);
  assert.equal(r.stdout.trim(), small, 'prints the page\'s path');
  assert.match(r.stderr, /one frame in \d+ kept/);
  assert.ok(fs.statSync(small).size <= budgetMb * 1048576, 'the page is within the budget');
  const all = pvdFrames(denseOut, 'surface.pvd');
  const { page } = await open(small);
  const frames = await page.evaluate(() => window.cutsimPlayer.frames());
  const meta = await page.evaluate(() => window.cutsimPlayer.meta.run);
  assert.equal(meta.framesInRun, all.length);
  assert.ok(frames.length < all.length, `${frames.length} of ${all.length} frames kept`);
  assert.ok(frames.length >= 2);
  assert.equal(frames.length, meta.frameIndices.length);
  meta.frameIndices.forEach((k, i) => {
    assert.equal(frames[i].t, all[k].t, `kept frame ${i} is the run's frame ${k}`);
    assert.equal(frames[i].triangles, all[k].triangles);
  });
  assert.equal(meta.frameIndices[0], 0, 'the first frame is kept');
  assert.equal(meta.frameIndices.at(-1), all.length - 1, 'the last frame is kept');
  await page.close();
});

await check('a partial run plays with a banner saying so', async () => {
  const partial = path.join(work, 'partial');
  fs.cpSync(out, partial, { recursive: true });
  // As a run that was stopped leaves it: collections named .partial.pvd and a temporary CSV.
  for (const f of fs.readdirSync(partial)) {
    if (f.endsWith('.pvd')) fs.renameSync(path.join(partial, f), path.join(partial, f.replace(/\.pvd$/, '.partial.pvd')));
  }
  fs.renameSync(path.join(partial, 'steps.csv'), path.join(partial, '.steps.csv.tmp'));
  fs.rmSync(path.join(partial, 'player.html'));
  const r = spawnSync(cutsim, ['view', partial], { encoding: 'utf8' });
  assert.equal(r.status, 0, r.stderr);
  assert.match(r.stderr, /partial run/);
  const { page } = await open(path.join(partial, 'player.html'));
  const banner = await page.evaluate(() => {
    const b = document.getElementById('banner');
    return { shown: getComputedStyle(b).display !== 'none', text: b.textContent };
  });
  assert.ok(banner.shown, 'the banner is shown');
  assert.match(banner.text, /partial run/);
  await page.close();
});

await check('bad folders: exit code 2 and what is wrong', async () => {
  const empty = path.join(work, 'empty');
  fs.mkdirSync(empty, { recursive: true });
  for (const [dir, message] of [[empty, /not a cutsim run folder/], [path.join(work, 'missing'), /no such folder/],
    [html, /not a folder/]]) {
    const r = spawnSync(cutsim, ['view', dir], { encoding: 'utf8' });
    assert.equal(r.status, 2, `${dir}: ${r.stderr}`);
    assert.match(r.stderr, message);
    assert.ok(r.stderr.startsWith(dir + ':'), `the message names the folder first: ${r.stderr}`);
  }
});

await check('cutsim view --png renders a still of the page', async () => {
  const png = path.join(work, 'still.png');
  const r = spawnSync(cutsim, ['view', out, '-o', path.join(work, 'still.html'), '--png', String(expected.length - 1),
    '--png-out', png], { encoding: 'utf8', env: { ...process.env } });
  assert.equal(r.status, 0, r.stderr);
  const image = decodePng(fs.readFileSync(png));
  assert.ok(image.width >= 800 && image.height >= 500, `${image.width} x ${image.height}`);
  // Not a blank page: many pixels differ from the page's background.
  let differ = 0;
  for (let i = 0; i < image.data.length; i += 4) {
    if (distance([image.data[i], image.data[i + 1], image.data[i + 2]], [0x1f, 0x23, 0x29]) > 24) differ++;
  }
  assert.ok(differ / (image.width * image.height) > 0.15, `only ${differ} pixels of ${image.width * image.height} drawn`);
});

await browser.close();
if (failures) {
  console.log(`${failures} checks failed (screenshots in ${work})`);
  process.exit(1);
}
console.log(`all checks passed (screenshots in ${work})`);
