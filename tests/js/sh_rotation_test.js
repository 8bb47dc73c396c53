// web/prt-sh.js (the relighting page's SH basis and rotation) against prt:
// the page's rotation of `prt project`'s coefficients must equal
// `prt project --rotate` of the same map, for several rotations and up to
// 16 bands (the most prt render draws), and its basis must integrate to the
// identity (orthonormality) - the convention the transfer was computed in.
//
// node sh_rotation_test.js --prt BUILD/prt --source SRC
'use strict';
const path = require('path');
const { execFileSync } = require('child_process');
const SH = require('../../web/prt-sh.js');

const args = {};
for (let i = 2; i < process.argv.length; i += 2) args[process.argv[i].replace(/^--/, '')] = process.argv[i + 1];
if (!args.prt || !args.source) {
  console.error('usage: node sh_rotation_test.js --prt BUILD/prt --source SRC');
  process.exit(2);
}

// prt project --rotate computes to 1e-12 in double (its --help); the page's
// least-squares fit is exact up to the rounding of a (2l+1)-square solve:
// measured 3e-16 (4 bands) and 6e-16 (16 bands) relative to the largest
// coefficient. 1e-9 leaves room and is far below a float's 6e-8, the
// precision the GPU uses; a wrong convention is off by O(1).
const kMaxRelError = 1e-9;
// Orthonormality by a quadrature exact for band-limited products
// (Gauss-Legendre in cos theta x uniform in phi): off by rounding only.
const kMaxGramError = 1e-10;

let failed = false;
const project = (bands, rotate) => JSON.parse(execFileSync(args.prt, ['project', path.join(args.source, 'envmaps', 'sunset.exr'),
  '--bands', String(bands), '-q', ...(rotate ? ['--rotate', rotate.join(',')] : [])]).toString()).coefficients;

for (const bands of [4, 16]) {
  const base = project(bands);
  for (const rotate of [[40, 20, 10], [0, 90, 0], [-120, 33, 250]]) {
    const want = project(bands, rotate);
    const rot = new SH.Rotation(bands);
    rot.set(SH.fromEuler(...rotate));
    const got = rot.apply(base);
    let err = 0, scale = 0;
    for (let k = 0; k < bands * bands; ++k)
      for (let c = 0; c < 3; ++c) {
        err = Math.max(err, Math.abs(got[k][c] - want[k][c]));
        scale = Math.max(scale, Math.abs(want[k][c]));
      }
    const ok = err <= kMaxRelError * scale;
    console.log(`${ok ? 'ok  ' : 'FAIL'} ${bands} bands, --rotate ${rotate}: max error ${(err / scale).toExponential(2)} of the largest coefficient`);
    failed = failed || !ok;
  }
  // turned(): prt render's per-frame Ry(spin) x base, against --rotate yaw+spin (pitch, roll 0).
  const want = project(bands, [70, 0, 0]);
  const rot = new SH.Rotation(bands);
  rot.set(SH.turned(30, SH.fromEuler(40, 0, 0)));
  const got = rot.apply(base);
  let err = 0;
  for (let k = 0; k < bands * bands; ++k) for (let c = 0; c < 3; ++c) err = Math.max(err, Math.abs(got[k][c] - want[k][c]));
  const okSpin = err <= kMaxRelError * Math.abs(want[0][0]) * 10;
  console.log(`${okSpin ? 'ok  ' : 'FAIL'} ${bands} bands, spin 30 after --rotate 40: max error ${err.toExponential(2)}`);
  failed = failed || !okSpin;
}

// Gram matrix of the basis at 8 bands.
{
  const bands = 8, n = bands * bands, nt = 16, np = 32;
  // Gauss-Legendre nodes on [-1, 1] by Newton's method.
  const nodes = [], weights = [];
  for (let i = 0; i < nt; ++i) {
    let x = Math.cos(Math.PI * (i + 0.75) / (nt + 0.5)), dp = 0;
    for (let it = 0; it < 100; ++it) {
      let p0 = 1, p1 = x;
      for (let k = 2; k <= nt; ++k) [p0, p1] = [p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k];
      dp = nt * (x * p1 - p0) / (x * x - 1);
      const dx = p1 / dp;
      x -= dx;
      if (Math.abs(dx) < 1e-16) break;
    }
    nodes.push(x);
    weights.push(2 / ((1 - x * x) * dp * dp));
  }
  const G = new Float64Array(n * n);
  for (let i = 0; i < nt; ++i)
    for (let j = 0; j < np; ++j) {
      const z = nodes[i], r = Math.sqrt(1 - z * z), phi = 2 * Math.PI * j / np, w = weights[i] * 2 * Math.PI / np;
      const Y = SH.basis(bands, r * Math.cos(phi), r * Math.sin(phi), z);
      for (let a = 0; a < n; ++a) for (let b = 0; b < n; ++b) G[a * n + b] += w * Y[a] * Y[b];
    }
  let err = 0;
  for (let a = 0; a < n; ++a) for (let b = 0; b < n; ++b) err = Math.max(err, Math.abs(G[a * n + b] - (a === b ? 1 : 0)));
  const ok = err <= kMaxGramError;
  console.log(`${ok ? 'ok  ' : 'FAIL'} basis orthonormal at ${bands} bands: max |G - I| ${err.toExponential(2)}`);
  failed = failed || !ok;
}
process.exit(failed ? 1 : 0);
