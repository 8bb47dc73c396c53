// prt-three.js - prt's exports in three.js's own classes (docs/WEB.md,
// "Probes in three.js"). An ES module; it imports nothing, so that it works
// with any copy of three (r187 or later): pass the classes in.
//
// probeGridFromPrt(THREE, LightProbeGridWebGL, doc, {intensity}): the probe volume JSON of
// `prt export SCENE --probes P --bake ENV -o probes.json` (doc, parsed) as a
// three.js LightProbeGridWebGL (three/addons/lighting/LightProbeGridWebGL.js)
// whose texture holds prt's relit probes, baked by prt, not by three:
//
//   const grid = probeGridFromPrt(THREE, LightProbeGridWebGL, await (await fetch('probes.json')).json());
//   scene.add(grid);  // lights MeshLambert/Phong/Standard/Physical/Toon materials inside its box
//
// The grid: doc.three_grid (position, size, resolution) puts three's probe
// (i, j, k), at the centre of cell (i, j, k) of its box, on prt's grid point
// min + (max - min) (i, j, k) / (dims - 1). Each probe's doc.probes[p].three
// is its incident radiance in three's SphericalHarmonics3 convention (prt's
// basis without the Condon-Shortley phase: docs/CONVENTIONS.md), which the
// grid's shader turns into irradiance at the normal and multiplies by albedo
// / pi, as prt does. intensity (default 1) scales every coefficient: three's
// WebGL grid ignores the light's own intensity; 2^stops matches prt render
// --exposure stops.
//
// The texture, as LightProbeGridWebGL's bake() lays it out (r187 source,
// examples/jsm/lighting/LightProbeGridWebGL.js): RGBA float, nx x ny x
// 7 (nz + 2); sub-volume t (0..6) holds the 28 floats c0.rgb c1.rgb ... c8.rgb
// 0 four at a time, probe (i, j, k) at texel (i, j, t (nz + 2) + 1 + k), and
// the first and last slice of each sub-volume repeat its k = 0 and k = nz - 1
// probes (so that linear filtering in z does not blend sub-volumes).
//
// fillProbeGrid(doc, intensity, data): the texture's floats alone, into a
// grid's texture.image.data to update it in place (the three.js page of
// prt export --three relights its probes each frame; docs/WEB.md).
//
// What three does not do that prt does (docs/PROBES.md): it ignores prt's
// probe positions moved off surfaces and each probe's visibility of the
// point; it shades at the point plus half a cell along the normal. An
// invalid probe (inside geometry: stored as zero) would darken three's
// trilinear blend, so it takes the mean of its valid neighbours along the
// axes (6 at most), or stays zero without one.
export function probeGridFromPrt(THREE, LightProbeGridWebGL, doc, { intensity = 1 } = {}) {
  const g = doc.three_grid;
  if (!g || !Array.isArray(doc.probes)) throw new Error('not a prt probe volume JSON with three_grid (prt export --probes)');
  const [nx, ny, nz] = g.resolution;
  const texture = new THREE.Data3DTexture(fillProbeGrid(doc, intensity), nx, ny, 7 * (nz + 2));
  texture.format = THREE.RGBAFormat;
  texture.type = THREE.FloatType;
  texture.minFilter = THREE.LinearFilter;
  texture.magFilter = THREE.LinearFilter;
  texture.generateMipmaps = false;
  texture.needsUpdate = true;
  const grid = new LightProbeGridWebGL(g.size[0], g.size[1], g.size[2], nx, ny, nz);
  grid.position.fromArray(g.position);
  grid.updateBoundingBox();  // it reads position: three calls it only when constructed and baked
  grid.texture = texture;
  return grid;
}

// The grid texture's floats for doc's probes (doc.probes[p].three, x
// intensity), into `data` when given (a grid's texture.image.data: then set
// texture.needsUpdate, as the three.js page does each frame), else a new array.
export function fillProbeGrid(doc, intensity = 1, data = null) {
  const [nx, ny, nz] = doc.three_grid.resolution;
  if (doc.probes.length !== nx * ny * nz) throw new Error(`${doc.probes.length} probes for a ${nx}x${ny}x${nz} grid`);
  const valid = doc.probes.map((p) => p.state !== 'invalid');
  const coefficients = doc.probes.map((p) => p.three.flat().map((x) => x * intensity));
  const index = (i, j, k) => i + nx * (j + ny * k);
  const filled = coefficients.map((c, p) => {
    if (valid[p]) return c;
    const i = p % nx, j = Math.floor(p / nx) % ny, k = Math.floor(p / (nx * ny));
    const sum = new Array(27).fill(0);
    let n = 0;
    for (const [di, dj, dk] of [[1, 0, 0], [-1, 0, 0], [0, 1, 0], [0, -1, 0], [0, 0, 1], [0, 0, -1]]) {
      const a = i + di, b = j + dj, d = k + dk;
      if (a < 0 || b < 0 || d < 0 || a >= nx || b >= ny || d >= nz || !valid[index(a, b, d)]) continue;
      coefficients[index(a, b, d)].forEach((v, q) => { sum[q] += v; });
      ++n;
    }
    return n ? sum.map((v) => v / n) : c;
  });
  const depth = 7 * (nz + 2);
  if (!data) data = new Float32Array(nx * ny * depth * 4);
  filled.forEach((c, p) => {
    const i = p % nx, j = Math.floor(p / nx) % ny, k = Math.floor(p / (nx * ny));
    const f = [...c, 0];
    for (let t = 0; t < 7; ++t) {
      const slices = [t * (nz + 2) + 1 + k];
      if (k === 0) slices.push(t * (nz + 2));
      if (k === nz - 1) slices.push(t * (nz + 2) + nz + 1);
      for (const z of slices) data.set(f.slice(4 * t, 4 * t + 4), 4 * (i + nx * (j + ny * z)));
    }
  });
  return data;
}
