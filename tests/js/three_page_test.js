// The three.js page of `prt export SCENE LIGHTMAP.prt --three DIR` in a real
// browser (docs/WEB.md "The three.js page"): headless Chromium (Debian's,
// software WebGL through SwiftShader) loads the exported page with three.js
// r187 from tests/js/node_modules/three (?three=/three/), which builds the
// room from GLTFLoader and MeshPhysicalMaterial and relights the lightmap into
// their lightMap each frame. Its canvas, at two rotations of the map (two
// frames of one page: prtThree.frame), is compared with `prt render` of the
// same scene, lightmap, map, rotation, camera, size and exposure (--tonemap
// clamp) over the pixels prt render covers (its EXR alpha: the window shows
// the background). Negative control: the page under another map, against
// the first rotation's render.
//
// With the room's probe volume (--probes): the page's sphere, held at one
// place (?object=), lit by three's LightProbeGridWebGL from the probes the
// page relights each frame (their matrices x the rotated map). Its pixels
// are compared with three's own grid shading computed here from the probes
// (threeGridModel, three_grid_model.js: prt render's probe interpolation
// differs from three's by ~10 levels in the room, docs/WEB.md "Probes in
// three.js"), and the page's relit probes with `prt export --probes --bake
// sunset --rotate R`'s JSON; the room's pixels exclude the sphere's.
//
// node three_page_test.js --prt BUILD/prt --source SRC [--images DIR]
// Exit 0 pass, 1 fail, 77 skip (tools.js).
'use strict';
const { missing, chromiumOrSkip, testArgs, run, exrCoverage } = require('./tools');
const fs = require('fs');
const os = require('os');
const path = require('path');
const http = require('http');
const { readPng, writePng } = require('./png');
const { threeGridModel } = require('./three_grid_model');

const { chromium, executable: CHROMIUM } = chromiumOrSkip();
const THREE_DIR = path.join(__dirname, 'node_modules', 'three');
if (!fs.existsSync(path.join(THREE_DIR, 'examples', 'jsm', 'loaders', 'GLTFLoader.js'))) missing('the npm package three');
const args = testArgs('three_page_test.js');

// --- tolerances (sRGB-encoded 8-bit levels, per channel) -----------------
// The target: the mean absolute difference over the covered pixels.
// What differs: the lightmap relit per texel into a half-float target then
// filtered (prt render: the coefficients filtered, then dotted), and
// E / albedo(texel) filtered where prt render divides per fragment by the
// filtered texel albedo (the floor's checker edges).
const kMaxMean = 2.0;
// Against prt's own page (--web) of the same export, which decodes the same
// 8-bit coefficients: what is left is the order of filtering and dividing.
const kMaxMeanWeb = 0.25;
// The negative control (the page under city instead of sunset) must miss it by far.
const kMinMeanNegative = 5 * kMaxMean;
// Covered pixels: most of the frame (the room seen from inside).
const kMinCovered = 0.5;
// The sphere against threeGridModel (as three_client_test.js's probe_grid_room case: 0.17, p99 2).
const kMaxMeanModel = 0.5, kMaxP99Model = 2;
// The page's relit probes against the same sum here (float32 matrices, both
// in double after): relative to the largest coefficient.
const kMaxProbeRel = 1e-5;
const object = { at: [0.3, 1.1, 0.0], size: 1.2 };

const fail = (msg) => { console.error('FAIL: ' + msg); process.exitCode = 1; };
const src = (p) => path.join(args.source, p);


// Serves `dir` at / (the pages in page/ and web/) and three's package at /three/.
function serve(dir) {
  const types = { '.html': 'text/html', '.js': 'text/javascript', '.json': 'application/json' };
  const server = http.createServer((req, res) => {
    const rel = decodeURIComponent(new URL(req.url, 'http://x').pathname);
    const [root, sub] = rel.startsWith('/three/') ? [THREE_DIR, rel.slice(7)] : [dir, rel.slice(1) || 'index.html'];
    const file = path.join(root, sub);
    if (!file.startsWith(root) || !fs.existsSync(file) || !fs.statSync(file).isFile()) {
      res.writeHead(404);
      res.end();
      return;
    }
    res.writeHead(200, { 'Content-Type': types[path.extname(file)] || 'application/octet-stream' });
    fs.createReadStream(file).pipe(res);
  });
  return new Promise((resolve) => server.listen(0, '127.0.0.1', () => resolve(server)));
}


function compare(rgb, ref, mask) {
  let n = 0, sum = 0;
  const maxes = [], diff = Buffer.alloc(rgb.length);
  for (let i = 0; i < mask.length; ++i) {
    if (!mask[i]) continue;
    ++n;
    let d = 0, dmax = 0;
    for (let c = 0; c < 3; ++c) {
      const e = Math.abs(rgb[3 * i + c] - ref[3 * i + c]);
      d += e;
      dmax = Math.max(dmax, e);
      diff[3 * i + c] = Math.min(255, 8 * e);
    }
    sum += d / 3;
    maxes.push(dmax);
  }
  maxes.sort((a, b) => a - b);
  return { pixels: n, mean: n ? sum / n : Infinity, p99: n ? maxes[Math.floor(0.99 * (n - 1))] : Infinity, diff };
}
const show = (m) => `covered pixels ${m.pixels}, mean ${m.mean.toFixed(3)}, p99 ${m.p99}`;

// Every probe's SH in three's convention under the page's map (lighting.json,
// sunset) turned by `rotate`: probes.bin's matrices (docs/FORMAT.md "Probe
// matrices") x the rotated map, prt's signs of k = 1, 3, 5, 7 flipped.
function relitProbes(page, rotate) {
  const SH = require('../../web/prt-sh.js');
  const lighting = JSON.parse(fs.readFileSync(path.join(page, 'lighting.json'), 'utf8'));
  const map = lighting.maps.find((m) => m.name === 'sunset');
  const rot = new SH.Rotation(3);
  rot.set(SH.turned(0, SH.fromEuler(...rotate)));
  const L = rot.apply(map.coefficients);
  const buf = fs.readFileSync(path.join(page, 'probes.bin'));
  const P = buf.readUInt32LE(8), channels = buf.readUInt32LE(80), off = 88 + 16 * P;
  const M = (p, c, k, j) => buf.readFloatLE(off + 4 * ((((p * channels + (channels === 1 ? 0 : c)) * 9 + k) * 9) + j));
  const sign = [1, -1, 1, -1, 1, -1, 1, -1, 1];
  return Array.from({ length: P }, (_, p) => Array.from({ length: 9 }, (_, k) => [0, 1, 2].map((c) => {
    let v = 0;
    for (let j = 0; j < 9; ++j) v += M(p, c, k, j) * L[j][c];
    return sign[k] * v;
  })));
}
function maxDifference(a, b) {
  let worst = 0, largest = 0;
  a.forEach((p, q) => p.forEach((c, k) => c.forEach((x, ch) => {
    worst = Math.max(worst, Math.abs(x - b[q][k][ch]));
    largest = Math.max(largest, Math.abs(x));
  })));
  return { worst, largest };
}

// The page's canvas (rows from the top) after prtThree.frame(state).
async function pageFrame(tab, state, W, H) {
  const b64 = await tab.evaluate(async ([s, w, h]) => {
    await (await self.prtThree).frame(s);
    const gl = document.getElementById('canvas').getContext('webgl2');
    const buf = new Uint8Array(w * h * 4), rgb = new Uint8Array(w * h * 3);
    gl.readPixels(0, 0, w, h, gl.RGBA, gl.UNSIGNED_BYTE, buf);
    for (let y = 0; y < h; ++y)
      for (let x = 0; x < w; ++x)
        for (let c = 0; c < 3; ++c) rgb[3 * (y * w + x) + c] = buf[4 * ((h - 1 - y) * w + x) + c];
    let str = '';
    for (let i = 0; i < rgb.length; i += 8192) str += String.fromCharCode(...rgb.subarray(i, i + 8192));
    return btoa(str);
  }, [state, W, H]);
  return Buffer.from(b64, 'base64');
}

// The room (4 x 2.5 x 4) from a corner near the ceiling; its light comes
// through the window, so a turn of the map changes it much.
const view = { eye: [1.7, 2.0, 1.7], target: [-0.8, 0.5, -1.0], up: [0, 1, 0], fov: 70, width: 320, height: 240 };
const stops = 1.5;
const rotations = [[30, 0, 0], [150, 20, 0]];

async function main() {
  const t0 = Date.now();
  const tmp = fs.mkdtempSync(path.join(os.tmpdir(), 'prt-three-page-'));
  const scene = src('models/room.gltf'), transfer = path.join(tmp, 'room.prt'), page = path.join(tmp, 'page');
  const W = view.width, H = view.height;
  let browser, server;
  try {
    await run(args.prt, ['precompute', scene, '--lightmap', '128x128', '--bands', '3', '--samples', '64', '-o', transfer, '-q']);
    const probes = path.join(tmp, 'probes.prt');
    await run(args.prt, ['precompute', scene, '--probes', '8x5x8', '-o', probes, '-q']);
    await run(args.prt, ['export', scene, transfer, '--three', page, '--web', path.join(tmp, 'web'), '--env', 'sunset',
                         '--probes', probes, '-q']);
    const probeJson = await Promise.all(rotations.map(async (r, i) => {
      const out = path.join(tmp, `probes${i}.json`);
      await run(args.prt, ['export', scene, '--probes', probes, '--bake', src('envmaps/sunset.exr'), '--rotate', r.join(','),
                           '-o', out, '-q']);
      return JSON.parse(fs.readFileSync(out, 'utf8'));
    }));
    const size = ['--width', String(W), '--height', String(H), '--camera', [...view.eye, ...view.target, ...view.up].join(','),
                  '--fov', String(view.fov), '--exposure', String(stops), '--tonemap', 'clamp', '-q'];
    const refs = await Promise.all(rotations.map(async (r, i) => {
      const png = path.join(tmp, `render${i}.png`), exr = path.join(tmp, `render${i}.exr`);
      const base = ['render', scene, transfer, src('envmaps/sunset.exr'), '--rotate', r.join(','), ...size];
      await Promise.all([run(args.prt, [...base, '-o', png]), run(args.prt, [...base, '-o', exr, '--alpha'])]);
      return { png, rgb: readPng(fs.readFileSync(png)).rgb, mask: await exrCoverage(THREE_DIR, exr, W, H) };
    }));
    server = await serve(tmp);
    browser = await chromium.launch({
      executablePath: CHROMIUM,
      args: ['--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--ignore-gpu-blocklist', '--no-sandbox'],
    });
    const tab = await (await browser.newContext({ deviceScaleFactor: 1 })).newPage();
    const errors = [];
    tab.on('pageerror', (e) => errors.push(e.message));
    tab.on('console', (m) => { if (m.type() === 'error') errors.push(m.text()); });
    const q = `?three=/three/&map=sunset&rotate=${rotations[0].join(',')}&exposure=${stops}&auto=0&width=${W}&height=${H}` +
              `&fov=${view.fov}&camera=${[...view.eye, ...view.target, ...view.up].join(',')}` +
              `&object=${object.at.join(',')}&object-size=${object.size}`;
    const base = `http://127.0.0.1:${server.address().port}`;
    await tab.goto(`${base}/page/index.html${q}`);
    await tab.evaluate(() => self.prtThree).catch((e) => { throw new Error('the page failed: ' + e.message); });
    const frames = [];
    // The sphere's pixels: equal over a black and a white clear colour without the room.
    const [ob, ow] = [0x000000, 0xffffff].map((clear) => pageFrame(tab, { room: false, clear }, W, H));
    const [blk, wht] = [await ob, await ow];
    const om = new Uint8Array(W * H).map((_, i) => (blk[3 * i] === wht[3 * i] && blk[3 * i + 1] === wht[3 * i + 1] &&
                                                     blk[3 * i + 2] === wht[3 * i + 2] ? 1 : 0));
    const objectPixels = om.reduce((a, b) => a + b, 0);
    if (objectPixels < 0.02 * W * H) fail(`the sphere covers only ${objectPixels} pixels`);
    const roomMask = (mask) => mask.map((x, i) => x & (1 - om[i]));
    const models = [];
    for (const [i, r] of rotations.entries()) {
      const rgb = await pageFrame(tab, { rotate: r, room: true }, W, H);
      frames.push(rgb);
      // The page's relit probes against the same arithmetic here (probes.bin x
      // the rotated map), and (printed) against prt export's exact relight.
      const got = await tab.evaluate(async () => (await self.prtThree).probes());
      const want = relitProbes(page, r);
      const d = maxDifference(want, got), exact = maxDifference(probeJson[i].probes.map((p) => p.three), got);
      console.log(`rotate ${r}: the page's relit probes against probes.bin x the rotated map: max difference ` +
                  `${d.worst.toExponential(2)} (largest ${d.largest.toFixed(3)}); against prt export --probes's exact relight ` +
                  `(printed: the matrices take the map's 3 bands): ${exact.worst.toFixed(3)}`);
      if (!(d.worst <= kMaxProbeRel * d.largest)) fail(`rotate ${r}: the page's probes are not probes.bin x the rotated map`);
      const doc = { three_grid: probeJson[i].three_grid, probes: got.map((three, q) => ({ three, state: probeJson[i].probes[q].state })) };
      const modelled = threeGridModel(doc, 2 ** stops, view, object, om);
      models.push(modelled);
      const o = compare(rgb, modelled.rgb, modelled.mask);
      console.log(`rotate ${r}: the sphere against three's grid shading computed from the probes: ${show(o)}`);
      if (o.pixels < 0.5 * objectPixels) fail(`rotate ${r}: the model covers only ${o.pixels} of ${objectPixels} pixels`);
      if (!(o.mean <= kMaxMeanModel && o.p99 <= kMaxP99Model)) fail(`rotate ${r}: three's grid does not shade the sphere as the probes say`);
      const m = compare(rgb, refs[i].rgb, roomMask(refs[i].mask));
      console.log(`rotate ${r}: three.js page vs prt render: ${show(m)}`);
      if (m.pixels < kMinCovered * W * H) fail(`rotate ${r}: prt render covers only ${m.pixels} pixels`);
      if (!(m.mean <= kMaxMean)) fail(`rotate ${r}: the three.js page differs from prt render beyond ${kMaxMean} levels`);
      if (args.images) {
        fs.mkdirSync(args.images, { recursive: true });
        fs.writeFileSync(path.join(args.images, `three_page_${i}.png`), writePng(W, H, rgb));
        fs.copyFileSync(refs[i].png, path.join(args.images, `three_page_${i}_render.png`));
        fs.writeFileSync(path.join(args.images, `three_page_${i}_diff.png`), writePng(W, H, m.diff));
      }
    }
    const otherObject = compare(frames[1], models[0].rgb, models[0].mask);
    console.log(`the sphere at the second rotation against the first's model: ${show(otherObject)}`);
    if (!(otherObject.mean >= 5 * kMaxMeanModel)) fail('the sphere is lit the same at both rotations: the probes are not relit');
    const other = compare(frames[1], refs[0].rgb, roomMask(refs[0].mask));
    console.log(`the second rotation's frame against the first's render: ${show(other)}`);
    if (!(other.mean >= kMinMeanNegative)) fail('the two rotations give nearly the same frame: the page does not relight');
    const neg = compare(await pageFrame(tab, { rotate: rotations[0], map: 'city' }, W, H), refs[0].rgb, roomMask(refs[0].mask));
    console.log(`negative control, the page under city instead of sunset: ${show(neg)}`);
    if (!(neg.mean >= kMinMeanNegative)) fail('the negative control (city instead of sunset) passes too close');
    // prt's own page (--web, the same export) at the first rotation: both
    // decode the same 8-bit coefficients, so what three's frame differs from
    // prt render by, beyond its difference from this page, is three's.
    const web = await (await browser.newContext({ viewport: { width: W + 400, height: H + 200 }, deviceScaleFactor: 1 })).newPage();
    await web.goto(`${base}/web/index.html?map=sunset&rotate=${rotations[0].join(',')}&exposure=${stops}&tonemap=clamp` +
                   `&camera=${[...view.eye, ...view.target, ...view.up].join(',')}&fov=${view.fov}&size=${W}x${H}&auto=0`);
    await web.evaluate(() => self.prtReady);
    const webFrame = readPng(await web.locator('#canvas').screenshot());
    const pw = compare(frames[0], webFrame.rgb, roomMask(refs[0].mask)), wr = compare(webFrame.rgb, refs[0].rgb, roomMask(refs[0].mask));
    console.log(`rotate ${rotations[0]}: three.js page vs prt's own page (--web): ${show(pw)}; prt's page vs prt render: ${show(wr)}`);
    if (!(pw.mean <= kMaxMeanWeb)) fail("the three.js page differs from prt's own page beyond " + kMaxMeanWeb + ' levels');
    if (errors.length) fail('page errors: ' + errors.join('; '));
  } finally {
    if (browser) await browser.close();
    if (server) server.close();
    fs.rmSync(tmp, { recursive: true, force: true });
  }
  console.log(`${process.exitCode ? 'FAIL' : 'PASS'} (${((Date.now() - t0) / 1000).toFixed(1)} s)`);
}

main().catch((e) => {
  console.error('FAIL: ' + (e.stack || e));
  process.exit(1);
});
