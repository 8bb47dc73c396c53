// The relighting page of `prt export --web` in a real browser (docs/WEB.md):
// headless Chromium (Debian's, software WebGL through SwiftShader) draws the
// exported page at a fixed size, camera, environment rotation, exposure and
// map; its canvas is compared pixel by pixel with `prt render` of the same
// mesh, transfer, map, camera, rotation, exposure and size. Negative
// controls: the page with the environment turned 90 degrees more, and under
// another map, must fail the same comparison.
//
// node web_page_test.js --prt BUILD/prt --source SRC [--images DIR]
//   --images DIR: also write DIR/web_{mono,rgb}_{page,render}.png (the docs' pictures)
// Exit 0 pass, 1 fail, 77 skip (tools.js).
'use strict';
const { missing, chromiumOrSkip, testArgs } = require('./tools');
const fs = require('fs');
const os = require('os');
const path = require('path');
const http = require('http');
const { execFileSync } = require('child_process');
const { readPng, writePng } = require('./png');

const { chromium, executable: CHROMIUM } = chromiumOrSkip();

const args = testArgs('web_page_test.js');

// --- tolerances (sRGB-encoded 8-bit levels, per channel) -----------------
// A model pixel: one whose colour differs from the page's own frame without
// the model (?model=0, the background alone) by more than this in some
// channel. The page's background is the map in half floats with WebGL's
// bilinear filter: within about 1 level of prt render's (measured: 0.016 mean).
const kMaskLevels = 6;
// Coverage, the IoU of the two model masks: both renderers rasterise the
// same triangles with the same matrices; a silhouette pixel can go either
// way, and one whose model colour is within kMaskLevels of the background
// behind it falls in or out of a mask on a 1-level difference. Measured
// 0.9985 (mono) and 0.9988 (RGB); the negative controls give 0.15.
const kMinIoU = 0.99;  // tolerances.minIoU
// Over the pixels both call model: the mean absolute difference. Radiance is
// dot(transfer, rotated lighting) in float on both sides, Gouraud
// interpolation and the same tone map: what is left is float rounding, the
// 8-bit quantisation and the few edge pixels. Measured 0.096; the negative
// controls give 25 and 91.
const kMaxMeanModel = 1.0;
// ... and the 99th percentile of the per-pixel largest channel difference:
// measured 1; the negative controls give 112 and 183.
const kMaxP99Model = 4;
// Background pixels (neither calls model): mean absolute difference.
// Measured 0.016 (half-float texels, interpolation precision); the negative
// controls give 3 and 4.
const kMaxMeanBackground = 1.5;

const fail = (msg) => { console.error('FAIL: ' + msg); process.exitCode = 1; };

function run(cmd, argv) {
  try {
    return execFileSync(cmd, argv, { stdio: ['ignore', 'pipe', 'pipe'] }).toString();
  } catch (e) {
    const err = String(e.stderr || '');
    // prt render without an OpenGL 4.5 context: the GL tests' rule (tests/README.md).
    if (/no OpenGL 4\.5/.test(err) && process.env.PRT_REQUIRE_GL !== '1') missing('an OpenGL 4.5 context for prt render');
    throw new Error(`${path.basename(cmd)} ${argv.join(' ')}: exit ${e.status}\n${err}`);
  }
}

function compare(a, b, bg) {
  const n = a.width * a.height;
  let inter = 0, uni = 0, sumModel = 0, sumBg = 0, nBg = 0;
  const maxes = [];
  for (let i = 0; i < n; ++i) {
    let ma = false, mb = false, d = 0, dmax = 0;
    for (let c = 0; c < 3; ++c) {
      const j = 3 * i + c;
      if (Math.abs(a.rgb[j] - bg.rgb[j]) > kMaskLevels) ma = true;
      if (Math.abs(b.rgb[j] - bg.rgb[j]) > kMaskLevels) mb = true;
      const e = Math.abs(a.rgb[j] - b.rgb[j]);
      d += e;
      dmax = Math.max(dmax, e);
    }
    if (ma || mb) ++uni;
    if (ma && mb) {
      ++inter;
      sumModel += d / 3;
      maxes.push(dmax);
    } else if (!ma && !mb) {
      sumBg += d / 3;
      ++nBg;
    }
  }
  maxes.sort((x, y) => x - y);
  return {
    modelPixels: inter, iou: uni ? inter / uni : 0, meanModel: inter ? sumModel / inter : Infinity,
    p99Model: maxes.length ? maxes[Math.min(maxes.length - 1, Math.floor(0.99 * maxes.length))] : Infinity,
    meanBackground: nBg ? sumBg / nBg : 0,
  };
}
const tolerances = { minIoU: kMinIoU, maxMeanModel: kMaxMeanModel, maxP99Model: kMaxP99Model,
                     maxMeanBackground: kMaxMeanBackground };
// Lightmaps: the page relights the glTF's 8-bit coefficients (bias + scale
// x byte / 255, docs/FORMAT.md "Lightmap export"), prt render the float
// rows. Each coefficient is off by up to scale / 510, and 9 to 48 of them of
// either sign add up per pixel: in the room (dim, interreflected, exposure
// +1.5) that is a level or two nearly everywhere. Measured: room mean 0.93,
// p99 5 levels; wall (mono, brighter) 0.12 and 1. The negative controls
// give 25 and 12 (mean) there.
const lightmapTolerances = { ...tolerances, maxMeanModel: 2.0, maxP99Model: 8 };

const passesWithin = (m, t) => m.iou >= t.minIoU && m.meanModel <= t.maxMeanModel && m.p99Model <= t.maxP99Model &&
                               m.meanBackground <= t.maxMeanBackground;
const show = (m) => `model pixels ${m.modelPixels}, IoU ${m.iou.toFixed(4)}, mean ${m.meanModel.toFixed(3)}, ` +
                    `p99 ${m.p99Model}, background mean ${m.meanBackground.toFixed(3)}`;

function serve(dir) {
  const types = { '.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json' };
  const server = http.createServer((req, res) => {
    const rel = decodeURIComponent(new URL(req.url, 'http://x').pathname).replace(/^\/+/, '') || 'index.html';
    const file = path.join(dir, rel);
    if (!file.startsWith(dir) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      res.writeHead(404);
      res.end();
      return;
    }
    res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}

// One exported page against prt render. `c`: scene (a path under the
// source tree), precompute (its arguments), camera (9 numbers; default: the
// page's initial camera turned and raised), exposure, negatives (also the
// negative controls), controls (also the controls' checks), textured (a
// lightmap with a textured material: the detail toggle must change the
// frame), tolerances (this case's; default: the per-vertex ones), pages (a
// lightmap of that many pages: the page must draw them all).
async function runCase(browser, tmp, name, c) {
  const mesh = path.join(args.source, c.scene);
  const transfer = path.join(tmp, name + '.prt');
  // Few bands and rays: the comparison is of the two renderers, not of the transfer.
  run(args.prt, ['precompute', mesh, '-o', transfer, ...c.precompute, '-q']);
  const page = path.join(tmp, name);
  run(args.prt, ['export', mesh, transfer, '--web', page, '--env', 'studio', '-q']);
  const lighting = JSON.parse(fs.readFileSync(path.join(page, 'lighting.json')));
  const bands = +c.precompute[c.precompute.indexOf('--bands') + 1];
  if (lighting.bands !== bands || !lighting.maps.some((m) => m.name === 'forest') || lighting.initial.map !== 'studio')
    fail('lighting.json: ' + JSON.stringify(lighting).slice(0, 200));
  const tol = c.tolerances || tolerances;

  // A camera off the default one: turned 35 degrees about +Y around the
  // target and raised, so the page's camera maths and --camera are both exercised.
  const i0 = lighting.initial.camera, a = 35 * Math.PI / 180;
  const off = [i0[0] - i0[3], i0[1] - i0[4], i0[2] - i0[5]];
  const eye = [i0[3] + Math.cos(a) * off[0] + Math.sin(a) * off[2], i0[4] + 0.3 * Math.hypot(...off),
               i0[5] - Math.sin(a) * off[0] + Math.cos(a) * off[2]];
  const camera = (c.camera || [...eye, i0[3], i0[4], i0[5], 0, 1, 0]).map((v) => +v.toFixed(6));
  const target = camera.slice(3, 6);
  const W = 256, H = 192, fov = 35, rotate = [40, 20, 10], exposure = c.exposure, map = 'studio';
  const rendered = path.join(tmp, name + '.png');
  run(args.prt, ['render', mesh, transfer, path.join(args.source, 'envmaps', map + '.exr'), '-o', rendered,
                 '--width', String(W), '--height', String(H), '--camera', camera.join(','), '--fov', String(fov),
                 '--rotate', rotate.join(','), '--exposure', String(exposure), '-q']);
  const prt = readPng(fs.readFileSync(rendered));

  const server = await serve(page);
  try {
    const context = await browser.newContext({ viewport: { width: 1000, height: H + 200 }, deviceScaleFactor: 1 });
    const tab = await context.newPage();
    const errors = [];
    tab.on('pageerror', (e) => errors.push(e.message));
    tab.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    const q = `?map=${map}&rotate=${rotate.join(',')}&exposure=${exposure}&camera=${camera.join(',')}` +
              `&fov=${fov}&size=${W}x${H}&auto=0`;
    await tab.goto(`http://127.0.0.1:${server.address().port}/index.html${q}`);
    const info = await tab.evaluate(() => self.prtReady);
    const canvas = tab.locator('#canvas');
    const shot = async () => readPng(await canvas.screenshot());
    const web = await shot();
    await tab.evaluate(() => prtViewer.set({ model: false }));
    const bg = await shot();
    const status = await tab.locator('#status').textContent();
    if (web.width !== W || web.height !== H || prt.width !== W || prt.height !== H)
      throw new Error(`sizes: page ${web.width}x${web.height}, prt render ${prt.width}x${prt.height}, expected ${W}x${H}`);
    const m = compare(web, prt, bg);
    const passes = (x) => passesWithin(x, tol);
    const pages = info.lightmap && info.lightmap.pages > 1 ? `${info.lightmap.pages} pages of ` : '';
    console.log(`${name}: page (${info.lightmap ? `lightmap ${pages}${info.lightmap.width}x${info.lightmap.height}, ` : ''}` +
                `${info.vertices} vertices, ${info.bands} bands, ${info.channels} channel(s); ` +
                `"${status}") vs prt render: ${show(m)}`);
    if (!passes(m)) fail(name + ': the page differs from prt render beyond the tolerances');
    if (m.modelPixels < 0.1 * W * H) fail(name + ': the model covers only ' + m.modelPixels + ' pixels');
    if (c.pages && !(info.lightmap && info.lightmap.pages === c.pages))
      fail(`${name}: the page read ${info.lightmap && info.lightmap.pages} lightmap pages, expected ${c.pages}`);
    if (c.negatives) {
      await tab.evaluate(() => prtViewer.set({ model: true, spin: 90 }));
      const mt = compare(await shot(), prt, bg);
      await tab.evaluate(() => prtViewer.set({ spin: 0, map: 'forest' }));
      const mo = compare(await shot(), prt, bg);
      await tab.evaluate(() => prtViewer.set({ map: 'studio' }));
      console.log(`${name}: negative control, environment turned 90 degrees more: ${show(mt)}`);
      console.log(`${name}: negative control, map forest instead of studio: ${show(mo)}`);
      if (passes(mt)) fail(name + ': the comparison passes with the environment turned 90 degrees');
      if (passes(mo)) fail(name + ': the comparison passes under another map');
    }
    if (c.textured) {
      // The detail toggle: without it the textured floor is the texel's
      // albedo, bilinear at lightmap resolution; the frame must change.
      await tab.evaluate(() => prtViewer.set({ model: true, detail: false }));
      const flat = compare(await shot(), web, bg);
      await tab.evaluate(() => prtViewer.set({ detail: true }));
      console.log(`${name}: detail off against on: ${show(flat)}`);
      if (!(flat.meanModel > 0.5)) fail(`${name}: turning texture detail off did not change the frame`);
    }
    if (c.controls) {
      // The controls move what they should: a drag orbits the eye about the
      // target, the wheel moves it away, the turn advances the spin, a
      // thumbnail, the picker and the exposure slider set the state.
      await tab.evaluate(() => prtViewer.set({ map: 'studio', spin: 0 }));
      const before = await tab.evaluate(() => prtViewer.state.eye.slice());
      const box = await canvas.boundingBox();
      await tab.mouse.move(box.x + W / 2, box.y + H / 2);
      await tab.mouse.down();
      await tab.mouse.move(box.x + W / 2 + 40, box.y + H / 2 + 10, { steps: 4 });
      await tab.mouse.up();
      await tab.mouse.wheel(0, 200);
      await tab.evaluate(() => new Promise((r) => requestAnimationFrame(() => requestAnimationFrame(r))));
      const after = await tab.evaluate(() => prtViewer.state.eye.slice());
      const dist = (e) => Math.hypot(e[0] - target[0], e[1] - target[1], e[2] - target[2]);
      const moved = Math.hypot(after[0] - before[0], after[1] - before[1], after[2] - before[2]);
      // The wheel: exp(200 x 0.001) = 1.22 times the distance.
      if (!(moved > 0.05 * dist(before)) || !(Math.abs(dist(after) / dist(before) - Math.exp(0.2)) < 1e-6))
        fail(`${name}: orbit/wheel: eye ${before} -> ${after}`);
      await tab.check('#auto');
      await tab.waitForTimeout(300);
      const spin = await tab.evaluate(() => prtViewer.state.spin);
      await tab.uncheck('#auto');
      if (!(spin > 0)) fail(`${name}: the turn did not advance the spin (${spin})`);
      await tab.click('#thumbs img[data-map="city"]');
      const picked = await tab.evaluate(() => prtViewer.state.map);
      if (picked !== 'city') fail(`${name}: the city thumbnail picked ${picked}`);
      await tab.selectOption('#map', 'forest');
      await tab.locator('#exposure').fill('-2');
      const st = await tab.evaluate(() => ({ map: prtViewer.state.map, exposure: prtViewer.state.exposure }));
      if (st.map !== 'forest' || st.exposure !== -2) fail(`${name}: picker/slider: ${JSON.stringify(st)}`);
      console.log(`${name}: controls: orbit moved the eye ${moved.toFixed(3)}, wheel x${(dist(after) / dist(before)).toFixed(3)}, ` +
                  `turn ${spin.toFixed(1)} degrees in 0.3 s, thumbnail, picker and exposure set the state`);
    }
    if (errors.length) fail(name + ': page errors: ' + errors.join('; '));
    if (args.images) {
      fs.mkdirSync(args.images, { recursive: true });
      fs.writeFileSync(path.join(args.images, `web_${name}_page.png`), writePng(W, H, web.rgb));
      fs.copyFileSync(rendered, path.join(args.images, `web_${name}_render.png`));
    }
    await context.close();
  } finally {
    server.close();
  }
}

async function main() {
  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'prt-web-'));
  const t0 = Date.now();
  const browser = await chromium.launch({
    executablePath: CHROMIUM,
    args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'],
  });
  try {
    // Mono (one row for R, G and B) and RGB transfers take different shader paths.
    const obj = 'models/scene.obj';
    await runCase(browser, tmp, 'mono', { scene: obj, precompute: ['--bands', '4', '--samples', '64'], exposure: 0.5,
                                          negatives: true, controls: true });
    await runCase(browser, tmp, 'rgb', { scene: obj, exposure: 0.5, precompute: ['--bands', '3', '--samples', '32',
                                         '--mode', 'interreflected', '--albedo', '0.9,0.5,0.3'] });
    // Lightmaps: the room (its materials, a textured floor, interreflected:
    // RGB rows), seen from inside; the wall on the floor with one albedo
    // (mono rows), from outside.
    await runCase(browser, tmp, 'lightmap_room', {
      scene: 'models/room.gltf', exposure: 1.5, camera: [1.7, 1.7, 1.8, -0.6, 0.6, -0.9, 0, 1, 0],
      precompute: ['--lightmap', '64x64', '--bands', '3', '--samples', '64', '--mode', 'interreflected'],
      tolerances: lightmapTolerances, negatives: true, textured: true });
    // A lightmap of many pages (UVs prt makes, packed into 3 pages): the
    // glTF's images and primitives per page (docs/FORMAT.md "Lightmap
    // export"), each page's textures bound to its primitives; prt render
    // draws the same file from its pages stacked into one atlas.
    await runCase(browser, tmp, 'lightmap_pages', {
      scene: 'models/room.gltf', exposure: 1.5, camera: [1.7, 1.7, 1.8, -0.6, 0.6, -0.9, 0, 1, 0], pages: 3,
      precompute: ['--lightmap', '48x48', '--lightmap-uv', 'auto', '--pages', '3', '--bands', '3', '--samples', '64',
                   '--mode', 'interreflected'],
      tolerances: lightmapTolerances, textured: true });
    await runCase(browser, tmp, 'lightmap_wall', {
      scene: 'models/wall-on-floor.gltf', exposure: 0,
      precompute: ['--lightmap', '64x64', '--bands', '4', '--samples', '64', '--albedo', '0.7,0.7,0.7'],
      tolerances: lightmapTolerances });
  } finally {
    await browser.close();
    fs.rmSync(tmp, { recursive: true, force: true });
  }
  console.log(`${process.exitCode ? 'FAIL' : 'PASS'} (${((Date.now() - t0) / 1000).toFixed(1)} s)`);
}

main().catch((e) => {
  console.error('FAIL: ' + (e.stack || e));
  process.exit(1);
});
