// three.js's lightmap UV unwrapper (r187, examples/jsm/utils/unwrapUVs.js)
// run under Node on a mesh file, for a side-by-side comparison with
// `prt unwrap` (docs/LIGHTMAPS.md "Lightmap UVs made by prt"):
//
//   node tests/js/unwrap_three.mjs IN OUT.obj [--resolution R] [--padding P]
//        [--texels-per-unit D] [--mode lightmap|normal]
//
// IN: .obj (v, vt, vn, f; polygons fan-triangulated; negative indices), .off
// (OFF header, polygon faces fan-triangulated) or .gltf/.glb (three's
// GLTFLoader.parse; images, textures and texture references are stripped
// first, so none is needed; node transforms apply: the geometry is what
// three.js shows). One THREE.Mesh per OBJ/OFF file, one per glTF primitive
// (GLTFLoader's), all under one THREE.Group; unwrapUVs(group, {attribute:
// 'uv1', mode, resolution, padding, texelsPerUnit}) makes the UVs, and only
// that call is timed (performance.now()).
//
// Defaults: resolution 1024, padding 2 (prt unwrap's; three's own default
// padding is 4), texels-per-unit 0 (fit the atlas), mode lightmap.
//
// OUT.obj: the unwrapped geometry in world space: one `o` per mesh, `v` its
// vertices (as three.js places them: skinning and morphs in their current
// pose, then the mesh's world matrix; winding turned over under a mirroring
// world matrix, as three.js's front face is), `vt` the new uv1, `f v/vt` per
// triangle. Numbers are written as the shortest decimal that reads back as
// the same float32.
//
// vt and prt's reader: three.js holds uv1 in glTF's convention (origin at
// the atlas's top-left, v down), which is also prt's (Scene::uv_sets). prt
// reads an OBJ through Assimp and stores 1 - vt.y (scene/scene.cpp,
// load_obj: "OBJ's vt counts v up from the image's bottom"), so this script
// writes vt = (u, 1 - v): prt then holds u exactly, and v exactly where
// v >= 0.5 (1 - v is exact in float32 there); below 0.5, 1 - v is rounded to
// float32 once, so prt holds v within 2^-25 (3e-8 of the atlas, 3e-5 of a
// texel at 1024).
//
// stdout: one JSON line {"seconds", "resolution", "padding", "texelsPerUnit"
// (the density three.js used), "charts" (charts.length), "warnings"
// (excludedFaces, tinyFaces, singleTriangleCharts), then "mode",
// "requestedTexelsPerUnit" (--texels-per-unit: three.js fits the atlas
// instead, with a warning on stderr, when the charts do not fit at it),
// "meshes", "triangles", "vertices" (of OUT.obj)}.
// Exit status: 0 written; 1 unwrapUVs returned null (the charts do not fit)
// or IN cannot be read; 2 a usage error; 77 three.js is not installed
// (npm ci --prefix tests/js).
import { readFileSync, writeFileSync, renameSync, rmSync } from 'node:fs';
import path from 'node:path';
import { performance } from 'node:perf_hooks';

let THREE, GLTFLoader, unwrapUVs;
try {
  THREE = await import('three');
  ({ GLTFLoader } = await import('three/addons/loaders/GLTFLoader.js'));
  ({ unwrapUVs } = await import('three/addons/utils/unwrapUVs.js'));
} catch (e) {
  console.error(`unwrap_three.mjs: three.js is not installed (npm ci --prefix tests/js): ${e.message}`);
  process.exit(77);
}

const USAGE = 'usage: node tests/js/unwrap_three.mjs IN OUT.obj [--resolution R] [--padding P] ' +
              '[--texels-per-unit D] [--mode lightmap|normal]';

function usage(message) {
  console.error(`unwrap_three.mjs: ${message}\n${USAGE}`);
  process.exit(2);
}

function fail(message) {
  console.error(`unwrap_three.mjs: ${message}`);
  process.exit(1);
}

function parseArgs(argv) {
  const opts = { resolution: 1024, padding: 2, texelsPerUnit: 0, mode: 'lightmap' };
  const positional = [];
  const number = (name, value) => {
    if (value === undefined) usage(`${name} needs a value`);
    const x = Number(value);
    if (value.trim() === '' || !Number.isFinite(x)) usage(`${name}: ${value} is not a number`);
    return x;
  };
  for (let i = 0; i < argv.length; i++) {
    const a = argv[i];
    if (a === '--resolution') opts.resolution = number(a, argv[++i]);
    else if (a === '--padding') opts.padding = number(a, argv[++i]);
    else if (a === '--texels-per-unit') opts.texelsPerUnit = number(a, argv[++i]);
    else if (a === '--mode') opts.mode = argv[++i];
    else if (a === '-h' || a === '--help') { console.log(USAGE); process.exit(0); }
    else if (a.startsWith('--')) usage(`unknown option ${a}`);
    else positional.push(a);
  }
  if (positional.length !== 2) usage('expected IN and OUT.obj');
  if (!Number.isInteger(opts.resolution) || opts.resolution < 4) usage('--resolution: an integer >= 4');
  if (!(opts.padding >= 0) || !(2 * opts.padding + 1 < opts.resolution))
    usage('--padding: >= 0, and 2 padding + 1 below the resolution');
  if (!(opts.texelsPerUnit >= 0)) usage('--texels-per-unit: >= 0 (0: fit the atlas)');
  if (opts.mode !== 'lightmap' && opts.mode !== 'normal') usage('--mode: lightmap or normal');
  if (path.extname(positional[1]).toLowerCase() !== '.obj') usage('OUT must be a .obj file');
  return { input: positional[0], output: positional[1], ...opts };
}

// ---- readers -----------------------------------------------------------------

// Lines without comments (# to the end) or blank ones, split into words.
function wordLines(text) {
  const lines = [];
  for (const raw of text.split(/\r?\n/)) {
    const hash = raw.indexOf('#');
    const line = (hash >= 0 ? raw.slice(0, hash) : raw).trim();
    if (line) lines.push(line.split(/\s+/));
  }
  return lines;
}

// A geometry from per-corner arrays: vertices shared by equal (v, vt, vn).
function indexedGeometry(corners, positions, uvs, normals, name) {
  const key = new Map(), pos = [], uv = [], nrm = [], index = [];
  const hasUv = corners.some((c) => c[1] >= 0), hasNormal = corners.some((c) => c[2] >= 0);
  for (const [v, t, n] of corners) {
    const k = `${v}/${t}/${n}`;
    let i = key.get(k);
    if (i === undefined) {
      i = key.size;
      key.set(k, i);
      pos.push(positions[3 * v], positions[3 * v + 1], positions[3 * v + 2]);
      if (hasUv) uv.push(t >= 0 ? uvs[2 * t] : 0, t >= 0 ? uvs[2 * t + 1] : 0);
      if (hasNormal) nrm.push(n >= 0 ? normals[3 * n] : 0, n >= 0 ? normals[3 * n + 1] : 0, n >= 0 ? normals[3 * n + 2] : 0);
    }
    index.push(i);
  }
  const g = new THREE.BufferGeometry();
  g.name = name;
  g.setAttribute('position', new THREE.Float32BufferAttribute(pos, 3));
  if (hasUv) g.setAttribute('uv', new THREE.Float32BufferAttribute(uv, 2));
  if (hasNormal) g.setAttribute('normal', new THREE.Float32BufferAttribute(nrm, 3));
  g.setIndex(index);
  return g;
}

function readObj(file) {
  const positions = [], uvs = [], normals = [], corners = [];
  // 1-based, or negative: relative to the end of the list so far.
  const resolve = (word, count, what, line) => {
    if (word === undefined || word === '') return -1;
    const i = Number.parseInt(word, 10);
    const r = i > 0 ? i - 1 : i < 0 ? count + i : NaN;
    if (!(r >= 0 && r < count)) fail(`${file}: line ${line}: ${what} index ${word} is out of range (${count})`);
    return r;
  };
  wordLines(readFileSync(file, 'utf8')).forEach((w, n) => {
    if (w[0] === 'v') positions.push(Number(w[1]), Number(w[2]), Number(w[3]));
    else if (w[0] === 'vt') uvs.push(Number(w[1]), Number(w[2] ?? 0));
    else if (w[0] === 'vn') normals.push(Number(w[1]), Number(w[2]), Number(w[3]));
    else if (w[0] === 'f') {
      const face = w.slice(1).map((c) => {
        const [v, t, nn] = c.split('/');
        return [resolve(v, positions.length / 3, 'v', n + 1), resolve(t, uvs.length / 2, 'vt', n + 1),
                resolve(nn, normals.length / 3, 'vn', n + 1)];
      });
      for (let k = 1; k + 1 < face.length; k++) corners.push(face[0], face[k], face[k + 1]);
    }
  });
  if (positions.some((x) => !Number.isFinite(x))) fail(`${file}: a vertex is not three finite numbers`);
  return [new THREE.Mesh(indexedGeometry(corners, positions, uvs, normals, path.basename(file)))];
}

function readOff(file) {
  const lines = wordLines(readFileSync(file, 'utf8'));
  if (lines.length === 0 || !/^[A-Z]*OFF$/.test(lines[0][0])) fail(`${file}: no OFF header`);
  let at = 0, counts = lines[0].slice(1);
  if (counts.length < 2) counts = lines[++at];
  const nv = Number.parseInt(counts[0], 10), nf = Number.parseInt(counts[1], 10);
  if (!(nv >= 0 && nf >= 0) || lines.length < at + 1 + nv + nf) fail(`${file}: the counts (${counts.join(' ')}) do not match the file`);
  const positions = [], corners = [];
  for (let i = 0; i < nv; i++) {
    const w = lines[at + 1 + i];
    positions.push(Number(w[0]), Number(w[1]), Number(w[2]));
  }
  if (positions.some((x) => !Number.isFinite(x))) fail(`${file}: a vertex is not three finite numbers`);
  for (let i = 0; i < nf; i++) {
    const w = lines[at + 1 + nv + i], n = Number.parseInt(w[0], 10);
    const face = w.slice(1, 1 + n).map((x) => Number.parseInt(x, 10));
    if (face.length !== n || face.some((v) => !(v >= 0 && v < nv))) fail(`${file}: face ${i} is malformed`);
    for (let k = 1; k + 1 < n; k++) corners.push([face[0], -1, -1], [face[k], -1, -1], [face[k + 1], -1, -1]);
  }
  return [new THREE.Mesh(indexedGeometry(corners, positions, [], [], path.basename(file)))];
}

// The bytes of every buffer of a glTF (a .glb's BIN chunk, data: URIs, or
// files beside it) as one GLB holding a single buffer, the JSON without
// images, textures, samplers and the materials' texture references.
function gltfAsGlb(file) {
  const bytes = readFileSync(file);
  let json, bin = null;
  if (bytes.length >= 12 && bytes.readUInt32LE(0) === 0x46546c67) {  // 'glTF'
    let at = 12;
    while (at + 8 <= bytes.length) {
      const length = bytes.readUInt32LE(at), type = bytes.readUInt32LE(at + 4);
      const chunk = bytes.subarray(at + 8, at + 8 + length);
      if (type === 0x4e4f534a) json = JSON.parse(chunk.toString('utf8'));  // JSON
      else if (type === 0x004e4942) bin = chunk;  // BIN
      at += 8 + length;
    }
    if (!json) fail(`${file}: a GLB without a JSON chunk`);
  } else {
    json = JSON.parse(bytes.toString('utf8'));
  }
  const required = json.extensionsRequired ?? [];
  for (const ext of ['KHR_draco_mesh_compression', 'EXT_meshopt_compression'])
    if (required.includes(ext)) fail(`${file}: ${ext} is not supported here`);
  // Buffers, joined (4-byte aligned) into one.
  const parts = [], offsets = [];
  let total = 0;
  for (const [i, b] of (json.buffers ?? []).entries()) {
    let data;
    if (b.uri === undefined) data = bin ?? fail(`${file}: buffer ${i} has no data`);
    else if (b.uri.startsWith('data:')) data = Buffer.from(b.uri.slice(b.uri.indexOf(',') + 1), 'base64');
    else data = readFileSync(path.join(path.dirname(file), decodeURIComponent(b.uri)));
    offsets.push(total);
    parts.push(data.subarray(0, b.byteLength));
    total += b.byteLength;
    const pad = (4 - (total % 4)) % 4;
    if (pad) parts.push(Buffer.alloc(pad));
    total += pad;
  }
  for (const v of json.bufferViews ?? []) {
    v.byteOffset = (v.byteOffset ?? 0) + offsets[v.buffer];
    v.buffer = 0;
  }
  json.buffers = total > 0 ? [{ byteLength: total }] : [];
  // No images: textures and every reference to one go.
  delete json.images;
  delete json.textures;
  delete json.samplers;
  for (const m of json.materials ?? []) {
    const pbr = m.pbrMetallicRoughness ?? {};
    m.pbrMetallicRoughness = pbr.baseColorFactor ? { baseColorFactor: pbr.baseColorFactor } : {};
    for (const k of ['normalTexture', 'occlusionTexture', 'emissiveTexture', 'extensions']) delete m[k];
  }
  const keep = (ext) => !ext.startsWith('KHR_materials_') && !ext.startsWith('KHR_texture_') && !ext.startsWith('EXT_texture_');
  if (json.extensionsRequired) json.extensionsRequired = json.extensionsRequired.filter(keep);
  if (json.extensionsUsed) json.extensionsUsed = json.extensionsUsed.filter(keep);
  // GLB: header, JSON chunk (space padded), BIN chunk (zero padded).
  let text = Buffer.from(JSON.stringify(json), 'utf8');
  if (text.length % 4) text = Buffer.concat([text, Buffer.alloc(4 - (text.length % 4), 0x20)]);
  const body = Buffer.concat(parts);
  const chunks = [Buffer.alloc(8), text];
  chunks[0].writeUInt32LE(text.length, 0);
  chunks[0].writeUInt32LE(0x4e4f534a, 4);
  if (body.length) {
    const h = Buffer.alloc(8);
    h.writeUInt32LE(body.length, 0);
    h.writeUInt32LE(0x004e4942, 4);
    chunks.push(h, body);
  }
  const header = Buffer.alloc(12);
  const length = 12 + chunks.reduce((s, c) => s + c.length, 0);
  header.writeUInt32LE(0x46546c67, 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(length, 8);
  const glb = Buffer.concat([header, ...chunks]);
  return glb.buffer.slice(glb.byteOffset, glb.byteOffset + glb.byteLength);
}

async function readGltf(file) {
  const loader = new GLTFLoader();
  const gltf = await new Promise((resolve, reject) => loader.parse(gltfAsGlb(file), '', resolve, reject))
    .catch((e) => fail(`${file}: GLTFLoader: ${e?.message ?? e}`));
  return [gltf.scene];
}

// ---- output ------------------------------------------------------------------

// The shortest decimal that reads back as the same float32 as x.
function f32(x) {
  const f = Math.fround(x);
  if (f === 0) return '0';
  for (let p = 6; p < 9; p++) {
    const s = f.toPrecision(p);
    if (Math.fround(Number(s)) === f) return String(Number(s));
  }
  return String(Number(f.toPrecision(9)));
}

// OBJ text of the unwrapped meshes (world space; vt = (u, 1 - v), see the top).
function objText(meshes, attribute) {
  const out = ['# three.js r' + THREE.REVISION + ' unwrapUVs (tests/js/unwrap_three.mjs): world-space vertices, vt = (u, 1 - v) of ' + attribute];
  let base = 0, triangles = 0;
  const p = new THREE.Vector3();
  meshes.forEach((mesh, k) => {
    const g = mesh.geometry, uv = g.getAttribute(attribute), index = g.index;
    const name = (mesh.name || g.name || `mesh ${k}`).replace(/\s+/g, '_');
    out.push(`o ${name}`);
    const n = g.getAttribute('position').count;
    for (let i = 0; i < n; i++) {
      mesh.getVertexPosition(i, p).applyMatrix4(mesh.matrixWorld);
      out.push(`v ${f32(p.x)} ${f32(p.y)} ${f32(p.z)}`);
    }
    for (let i = 0; i < n; i++) out.push(`vt ${f32(uv.getX(i))} ${f32(1 - uv.getY(i))}`);
    const mirror = mesh.matrixWorld.determinant() < 0;
    const count = index ? index.count : n;
    const at = (j) => (index ? index.getX(j) : j) + base + 1;
    for (let j = 0; j + 2 < count; j += 3) {
      const [a, b, c] = mirror ? [at(j), at(j + 2), at(j + 1)] : [at(j), at(j + 1), at(j + 2)];
      out.push(`f ${a}/${a} ${b}/${b} ${c}/${c}`);
      triangles++;
    }
    base += n;
  });
  return { text: out.join('\n') + '\n', vertices: base, triangles };
}

// ---- main ----------------------------------------------------------------------

const args = parseArgs(process.argv.slice(2));
const ext = path.extname(args.input).toLowerCase();
let objects;
try {
  if (ext === '.obj') objects = readObj(args.input);
  else if (ext === '.off') objects = readOff(args.input);
  else if (ext === '.gltf' || ext === '.glb') objects = await readGltf(args.input);
  else usage(`${args.input}: expected .obj, .off, .gltf or .glb`);
} catch (e) {
  fail(`${args.input}: ${e.message}`);
}
const group = new THREE.Group();
for (const o of objects) group.add(o);
group.updateMatrixWorld(true);

const options = { attribute: 'uv1', mode: args.mode, resolution: args.resolution, padding: args.padding,
                  texelsPerUnit: args.texelsPerUnit };
const start = performance.now();
const result = unwrapUVs(group, options);
const seconds = (performance.now() - start) / 1000;
if (result === null)
  fail(`unwrapUVs returned null after ${seconds.toFixed(3)} s: the charts do not fit a ${args.resolution} x ` +
       `${args.resolution} atlas with padding ${args.padding}` +
       (args.texelsPerUnit > 0 ? ` at ${args.texelsPerUnit} texels per unit` : ''));

const meshes = result.meshes.map((m) => m.mesh);
const { text, vertices, triangles } = objText(meshes, 'uv1');
const tmp = `${args.output}.tmp-${process.pid}`;
try {
  writeFileSync(tmp, text);
  renameSync(tmp, args.output);
} catch (e) {
  rmSync(tmp, { force: true });
  fail(`${args.output}: cannot be written: ${e.message}`);
}
console.log(JSON.stringify({
  seconds, resolution: result.resolution, padding: result.padding, texelsPerUnit: result.texelsPerUnit,
  charts: result.charts.length, warnings: result.warnings,
  mode: args.mode, requestedTexelsPerUnit: args.texelsPerUnit, meshes: meshes.length, triangles, vertices,
}));
