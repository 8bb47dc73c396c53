// prt-sh.js - prt's real spherical harmonics and their rotation, for the
// relighting page (a browser global PrtSH) and its node test (require).
//
// Convention (docs/CONVENTIONS.md): real orthonormal SH with the
// Condon-Shortley phase, z polar axis, index k = l(l+1)+m, world +Y up.
// The basis is evaluated by the recurrence of shaders/relight.comp.glsl
// (core/sh.cpp's). Rotating the lighting by R gives L'(d) = L(R^T d)
// (prt/render.h), as prt's sh::Rotation does.
//
// Rotation: band l of L' is D_l L_l, D_l the (2l+1)^2 matrix that maps band
// l's coefficients of a function to those of the rotated function. It is
// found, exactly up to rounding, by least squares over a fixed set of
// directions d_i: A_l L'_l = B_l L_l with A_l[i][m] = Y_lm(d_i) and
// B_l[i][m] = Y_lm(R^T d_i), so D_l = (A_l^T A_l)^-1 A_l^T B_l; the
// pseudo-inverse is computed once per band, B_l once per rotation.
(function (root) {
  'use strict';

  // Y_k(x, y, z) for k < bands^2, (x, y, z) a unit vector; a Float64Array.
  function basis(bands, x, y, z, out) {
    const n = bands * bands;
    const Y = out || new Float64Array(n);
    let pmm = 0.28209479177387814;  // Y_00 = 1 / (2 sqrt(pi))
    let c = Math.SQRT2, s = 0;
    for (let m = 0; m < bands; ++m) {
      if (m > 0) {
        pmm *= -Math.sqrt((2 * m + 1) / (2 * m));
        const c1 = c * x - s * y;
        s = c * y + s * x;
        c = c1;
      }
      let p2 = 0, p1 = pmm;
      for (let l = m; l < bands; ++l) {
        let p = pmm;
        if (l === m + 1) {
          p = Math.sqrt(2 * m + 3) * z * pmm;
        } else if (l > m + 1) {
          const l2 = l * l, m2 = m * m, lm1 = (l - 1) * (l - 1);
          p = Math.sqrt((4 * l2 - 1) / (l2 - m2)) * (z * p1 - Math.sqrt((lm1 - m2) / (4 * lm1 - 1)) * p2);
        }
        if (l > m) {
          p2 = p1;
          p1 = p;
        }
        const k = l * (l + 1);
        if (m === 0) {
          Y[k] = p;
        } else {
          Y[k + m] = p * c;
          Y[k - m] = p * s;
        }
      }
    }
    return Y;
  }

  // 3x3 matrices are row-major arrays of 9 numbers: M[3 * row + col].
  function axisAngle(ax, ay, az, angle) {
    const len = Math.hypot(ax, ay, az);
    const x = ax / len, y = ay / len, z = az / len;
    const c = Math.cos(angle), s = Math.sin(angle), t = 1 - c;
    return [t * x * x + c, t * x * y - s * z, t * x * z + s * y,
            t * x * y + s * z, t * y * y + c, t * y * z - s * x,
            t * x * z - s * y, t * y * z + s * x, t * z * z + c];
  }
  function mul(A, B) {
    const C = new Array(9).fill(0);
    for (let i = 0; i < 3; ++i)
      for (let j = 0; j < 3; ++j)
        for (let k = 0; k < 3; ++k) C[3 * i + j] += A[3 * i + k] * B[3 * k + j];
    return C;
  }
  // prt's --rotate yaw,pitch,roll (degrees): R = Ry(yaw) Rx(pitch) Rz(roll).
  function fromEuler(yaw, pitch, roll) {
    const k = Math.PI / 180;
    return mul(mul(axisAngle(0, 1, 0, yaw * k), axisAngle(1, 0, 0, pitch * k)), axisAngle(0, 0, 1, roll * k));
  }
  // prt render's frame rotation: Ry(spin) times the base rotation.
  function turned(spinDeg, base) { return mul(axisAngle(0, 1, 0, spinDeg * Math.PI / 180), base); }

  // Solves G X = Bt for X (G symmetric positive definite, n x n; Bt n x cols),
  // by Gaussian elimination with partial pivoting; row-major arrays.
  function solve(G, Bt, n, cols) {
    const a = G.slice(), b = Bt.slice();
    for (let i = 0; i < n; ++i) {
      let p = i;
      for (let r = i + 1; r < n; ++r) if (Math.abs(a[r * n + i]) > Math.abs(a[p * n + i])) p = r;
      if (p !== i) {
        for (let j = 0; j < n; ++j) [a[i * n + j], a[p * n + j]] = [a[p * n + j], a[i * n + j]];
        for (let j = 0; j < cols; ++j) [b[i * cols + j], b[p * cols + j]] = [b[p * cols + j], b[i * cols + j]];
      }
      for (let r = i + 1; r < n; ++r) {
        const f = a[r * n + i] / a[i * n + i];
        if (f === 0) continue;
        for (let j = i; j < n; ++j) a[r * n + j] -= f * a[i * n + j];
        for (let j = 0; j < cols; ++j) b[r * cols + j] -= f * b[i * cols + j];
      }
    }
    for (let i = n - 1; i >= 0; --i)
      for (let j = 0; j < cols; ++j) {
        let v = b[i * cols + j];
        for (let r = i + 1; r < n; ++r) v -= a[i * n + r] * b[r * cols + j];
        b[i * cols + j] = v / a[i * n + i];
      }
    return b;
  }

  class Rotation {
    constructor(bands) {
      this.bands = bands;
      // Directions: a Fibonacci spiral, more than twice the largest band's size.
      const N = Math.max(16, 4 * (2 * bands - 1));
      this.dirs = [];
      for (let i = 0; i < N; ++i) {
        const z = 1 - (2 * i + 1) / N, r = Math.sqrt(1 - z * z), phi = i * Math.PI * (3 - Math.sqrt(5));
        this.dirs.push([r * Math.cos(phi), r * Math.sin(phi), z]);
      }
      const Ys = this.dirs.map((d) => basis(bands, d[0], d[1], d[2]));
      this.pinv = [];  // per band: (2l+1) x N
      for (let l = 0; l < bands; ++l) {
        const w = 2 * l + 1, k0 = l * l;
        const G = new Array(w * w).fill(0), At = new Array(w * N);
        for (let i = 0; i < N; ++i)
          for (let a = 0; a < w; ++a) {
            At[a * N + i] = Ys[i][k0 + a];
            for (let b = 0; b < w; ++b) G[a * w + b] += Ys[i][k0 + a] * Ys[i][k0 + b];
          }
        this.pinv.push(solve(G, At, w, N));
      }
      this.D = null;
    }
    // R: row-major 3x3 rotation of the lighting.
    set(R) {
      const N = this.dirs.length, bands = this.bands;
      const Yr = this.dirs.map((d) => {
        // R^T d
        const x = R[0] * d[0] + R[3] * d[1] + R[6] * d[2];
        const y = R[1] * d[0] + R[4] * d[1] + R[7] * d[2];
        const z = R[2] * d[0] + R[5] * d[1] + R[8] * d[2];
        return basis(bands, x, y, z);
      });
      this.D = [];
      for (let l = 0; l < bands; ++l) {
        const w = 2 * l + 1, k0 = l * l, P = this.pinv[l], D = new Float64Array(w * w);
        for (let a = 0; a < w; ++a)
          for (let b = 0; b < w; ++b) {
            let v = 0;
            for (let i = 0; i < N; ++i) v += P[a * N + i] * Yr[i][k0 + b];
            D[a * w + b] = v;
          }
        this.D.push(D);
      }
    }
    // light: array of [r, g, b] per coefficient (at least bands^2); returns the rotated array.
    apply(light) {
      const out = [];
      for (let l = 0; l < this.bands; ++l) {
        const w = 2 * l + 1, k0 = l * l, D = this.D[l];
        for (let a = 0; a < w; ++a) {
          const v = [0, 0, 0];
          for (let b = 0; b < w; ++b) {
            const d = D[a * w + b], s = light[k0 + b];
            v[0] += d * s[0];
            v[1] += d * s[1];
            v[2] += d * s[2];
          }
          out.push(v);
        }
      }
      return out;
    }
  }

  const api = { basis, axisAngle, mul, fromEuler, turned, Rotation };
  if (typeof module !== 'undefined' && module.exports) module.exports = api;
  else root.PrtSH = api;
})(typeof self !== 'undefined' ? self : this);
