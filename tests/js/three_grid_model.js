// three.js r187's probe-grid shading computed in node from prt's probe JSON
// (shared by three_client_test.js and three_page_test.js).
'use strict';

// three.js r187's own shading of the probe-lit sphere, computed here from
// prt's probe JSON (doc) as its grid shader does it
// (lightprobes_pars_fragment: the point plus half a cell along the normal,
// clamped to the outer probe centres, trilinear; shGetIrradianceAt's
// constants; x albedo 0.8 / pi; sRGB bytes), at the pixels inside the
// sphere's mask (one pixel in from its edge) whose camera ray meets the
// sphere (centre o.at, radius: o.size over the unit sphere's box diagonal
// 2 sqrt 3). A wrong packing of the grid's texture, a wrong sign or order of
// the SH, or a misplaced grid makes three's pixels differ from these.
function threeGridModel(doc, intensity, v, o, om) {
  const g = doc.three_grid, res = g.resolution;
  const min = g.position.map((x, a) => x - g.size[a] / 2), spacing = g.size.map((x, a) => x / res[a]);
  const coefficient = (i, j, k) => doc.probes[i + res[0] * (j + res[1] * k)].three;
  const r = o.size / (2 * Math.sqrt(3));
  const sub = (a, b) => a.map((x, i) => x - b[i]), dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const norm = (a) => { const l = Math.sqrt(dot(a, a)); return a.map((x) => x / l); };
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const f = norm(sub(v.target, v.eye)), right = norm(cross(f, v.up)), up = cross(right, f);
  const tan = Math.tan((v.fov * Math.PI) / 360), aspect = v.width / v.height;
  const srgb = (x) => (x <= 0.0031308 ? 12.92 * x : 1.055 * Math.pow(x, 1 / 2.4) - 0.055);
  const rgb = Buffer.alloc(v.width * v.height * 3), mask = new Uint8Array(v.width * v.height);
  for (let y = 1; y < v.height - 1; ++y)
    for (let x = 1; x < v.width - 1; ++x) {
      const idx = y * v.width + x;
      if (!(om[idx] && om[idx - 1] && om[idx + 1] && om[idx - v.width] && om[idx + v.width])) continue;
      const sx = ((2 * (x + 0.5)) / v.width - 1) * tan * aspect, sy = (1 - (2 * (y + 0.5)) / v.height) * tan;
      const d = norm([0, 1, 2].map((a) => f[a] + sx * right[a] + sy * up[a]));
      const oc = sub(v.eye, o.at), b = dot(oc, d), disc = b * b - (dot(oc, oc) - r * r);
      if (disc <= 0) continue;
      const p = v.eye.map((e, a) => e + (-b - Math.sqrt(disc)) * d[a]), n = norm(sub(p, o.at));
      if (-dot(n, d) < 0.2) continue;  // grazing: the triangulated silhouette differs
      const w = [0, 1, 2].map((a) => {
        const u = Math.min(Math.max((p[a] + 0.5 * spacing[a] * n[a] - min[a]) / g.size[a], 0.5 / res[a]), 1 - 0.5 / res[a]);
        const t = u * res[a] - 0.5, i0 = Math.min(Math.floor(t), res[a] - 2);
        return [i0, t - i0];
      });
      const c = Array.from({ length: 9 }, () => [0, 0, 0]);
      for (let corner = 0; corner < 8; ++corner) {
        const bit = [corner & 1, (corner >> 1) & 1, (corner >> 2) & 1];
        const weight = bit.reduce((acc, on, a) => acc * (on ? w[a][1] : 1 - w[a][1]), 1);
        const probe = coefficient(...bit.map((on, a) => w[a][0] + on));
        for (let k = 0; k < 9; ++k) for (let ch = 0; ch < 3; ++ch) c[k][ch] += weight * probe[k][ch] * intensity;
      }
      const [nx, ny, nz] = n;
      for (let ch = 0; ch < 3; ++ch) {
        const e = 0.886227 * c[0][ch] + 2 * 0.511664 * (c[1][ch] * ny + c[2][ch] * nz + c[3][ch] * nx) +
                  2 * 0.429043 * (c[4][ch] * nx * ny + c[5][ch] * ny * nz + c[7][ch] * nx * nz) +
                  c[6][ch] * (0.743125 * nz * nz - 0.247708) + 0.429043 * c[8][ch] * (nx * nx - ny * ny);
        rgb[3 * idx + ch] = Math.round(255 * srgb(Math.min(1, (Math.max(e, 0) * 0.8) / Math.PI)));
      }
      mask[idx] = 1;
    }
  return { rgb, mask };
}

module.exports = { threeGridModel };
