// prt-three-page.js - the three.js page of `prt export SCENE LIGHTMAP.prt
// --three DIR` (docs/WEB.md "The three.js page"): the scene built from
// three.js's own classes, relit each frame as prt's own page relights it.
//
//   model.glb (the scene's materials, its coefficient textures: docs/FORMAT.md
//   "Lightmap export") through three's GLTFLoader; each mesh gets a
//   MeshPhysicalMaterial (the glTF material's colour and texture, metalness
//   0, roughness 1, specularIntensity 0: three's standard materials take the
//   specular layer's energy out of the diffuse, which prt's diffuse transfer
//   never does) whose lightMap (channel 1: TEXCOORD_1) is a WebGLRenderTarget
//   per lightmap page.
//
//   Each frame: the map's SH (lighting.json) rotated by rotate and spin
//   (prt-sh.js, as prt-viewer.js), then a full-screen pass per page
//   (RawShaderMaterial) decodes the coefficient textures (bias + scale x
//   byte / 255, decoded by prt-png.js so that no colour management touches
//   them), dots them with the rotated lighting (the radiance B prt render
//   gives the texel), and writes E = pi B / albedo(texel)
//   (lightmap_albedo.rgb16f), the irradiance three's lightMap holds: three
//   draws E x albedo(fragment) / pi, prt render's detail mode. The exposure
//   (2^stops) is the lightMapIntensity and the background's gain; clamp is
//   three's NoToneMapping with sRGB output.
//
//   With probes (prt export --three --probes P: lighting.json's "probes"):
//   a sphere (MeshLambertMaterial, albedo 0.8) moving on a circle inside the
//   probe grid, lit by three's LightProbeGridWebGL (web/prt-three.js). Each
//   frame relights every probe from its SH transfer matrices (probes.bin,
//   docs/FORMAT.md "Probe matrices") and the rotated map (3 bands), in
//   three's convention (prt's signs of k = 1, 3, 5, 7 flipped), times
//   2^stops, into the grid's texture in place. The grid and the sphere are
//   drawn as a second scene over the first (depth kept): three's grid lights
//   every lit material in its box, and the room has its lightMap already.
//
// URL parameters (tests and links): three=URL_PREFIX (index.html), map=NAME,
// rotate=yaw,pitch,roll, spin=DEGREES, exposure=STOPS, auto=0|1 (turn),
// camera=eye,target,up (9 numbers), fov=DEGREES, width=, height= (the
// canvas), object=x,y,z (the sphere held there; else it moves),
// object-size=DIAGONAL (its bounding box's, as prt render --object-size),
// room=0 (the sphere alone, over the clear colour). window.prtThree resolves after the first frame to
// { frame(state), probes() } : probes() gives the relit probes (three's
// convention, before the exposure) of the last frame; frame(state) draws a frame with state's rotate/spin/map/exposure and
// resolves after it; window.prtThreeError holds a failure's message.
import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';
import { probeGridFromPrt, fillProbeGrid } from './prt-three.js';

const SH = self.PrtSH, PNG = self.PrtPNG;
const $ = (id) => document.getElementById(id);
let resolveReady, rejectReady;
self.prtThree = new Promise((res, rej) => { resolveReady = res; rejectReady = rej; });

function fail(message) {
  self.prtThreeError = message;
  $('status').textContent = 'error: ' + message;
  rejectReady(new Error(message));
  throw new Error(message);
}

async function fetchOk(url) {
  const r = await fetch(url);
  if (!r.ok) fail(`${url}: HTTP ${r.status}`);
  return r.arrayBuffer();
}

// A glTF image's PNG bytes decoded as stored (RGBA8), as prt-viewer.js does.
async function decodePng(bytes, what) {
  const png = PNG.chunks(bytes, what);
  const stream = new Blob(png.idat).stream().pipeThrough(new DecompressionStream('deflate'));
  const px = PNG.unfilter(new Uint8Array(await new Response(stream).arrayBuffer()), png.width, png.height, png.channels, what);
  const { width, height, channels } = png;
  return { width, height, rgba: PNG.rgba(px, width, height, channels) };
}

// RGB half floats -> RGBA half floats (alpha 1), three's HalfFloatType data.
function rgbaHalf(half, count) {
  const out = new Uint16Array(count * 4);
  for (let i = 0; i < count; ++i) {
    out.set(half.subarray(3 * i, 3 * i + 3), 4 * i);
    out[4 * i + 3] = 0x3c00;
  }
  return out;
}

function dataTexture(data, width, height, type, flipY = false) {
  const t = new THREE.DataTexture(data, width, height, THREE.RGBAFormat, type);
  t.flipY = flipY;
  t.colorSpace = THREE.NoColorSpace;
  t.minFilter = t.magFilter = type === THREE.UnsignedByteType ? THREE.NearestFilter : THREE.LinearFilter;
  t.generateMipmaps = false;
  t.needsUpdate = true;
  return t;
}

// The relighting pass: E = pi (K + sum_g dot(coefficients_g, A[3g + c])) /
// albedo(texel), per texel (texelFetch: one fragment per texel).
function relightMaterial(groups, pageTextures, albedo) {
  const uniforms = { u_K: { value: new THREE.Vector3() }, u_A: { value: [] }, u_albedo: { value: albedo } };
  for (let i = 0; i < 3 * groups; ++i) uniforms.u_A.value.push(new THREE.Vector4());
  let sum = '';
  for (let g = 0; g < groups; ++g) {
    uniforms['u_c' + g] = { value: pageTextures[g] };
    sum += `  t = texelFetch(u_c${g}, p, 0);\n  r += vec3(dot(t, u_A[${3 * g}]), dot(t, u_A[${3 * g + 1}]), dot(t, u_A[${3 * g + 2}]));\n`;
  }
  const samplers = Array.from({ length: groups }, (_, g) => `uniform sampler2D u_c${g};`).join('\n');
  return new THREE.RawShaderMaterial({
    glslVersion: THREE.GLSL3,
    uniforms,
    depthTest: false,
    depthWrite: false,
    vertexShader: `precision highp float;
in vec3 position;
void main() { gl_Position = vec4(position.xy, 0.0, 1.0); }`,
    fragmentShader: `precision highp float; precision highp sampler2D;
${samplers}
uniform sampler2D u_albedo;
uniform vec3 u_K;
uniform vec4 u_A[${3 * groups}];
out vec4 o_color;
void main() {
  ivec2 p = ivec2(gl_FragCoord.xy);
  vec3 r = u_K;
  vec4 t;
${sum}  vec3 a = texelFetch(u_albedo, p, 0).rgb;
  vec3 e = 3.14159265358979 * r;
  for (int c = 0; c < 3; ++c) if (a[c] > 1e-3) e[c] /= a[c];
  o_color = vec4(e, 1.0);
}`,
  });
}

// The lightmap's pages: coefficient textures, texel albedo, a render target
// and the pass that fills it.
async function lightmapPages(parser, info, lighting, groups) {
  const W = info.lightmap.width, H = info.lightmap.height, pages = info.lightmap.pages || 1;
  const a = lighting.lightmap_albedo;
  if (!a || a.width !== W || a.height !== H || (a.pages || 1) !== pages)
    fail("lighting.json: no lightmap_albedo of the lightmap's size and pages");
  const half = new Uint16Array(await fetchOk(a.file));
  if (half.length !== pages * W * H * 3) fail(`${a.file}: ${half.length} values, expected ${pages * W * H * 3}`);
  const pageTextures = pages > 1 ? info.textures : [info.textures];
  const out = [];
  for (let p = 0; p < pages; ++p) {
    const coefficients = [];
    for (let g = 0; g < groups; ++g) {
      const tex = parser.json.textures[pageTextures[p][g]];
      const view = await parser.getDependency('bufferView', parser.json.images[tex.source].bufferView);
      const img = await decodePng(new Uint8Array(view), `model.glb: coefficient texture ${g} of page ${p}`);
      if (img.width !== W || img.height !== H) fail(`model.glb: coefficient texture ${g} is ${img.width}x${img.height}, the lightmap ${W}x${H}`);
      coefficients.push(dataTexture(img.rgba, W, H, THREE.UnsignedByteType));
    }
    const albedo = dataTexture(rgbaHalf(half.subarray(p * W * H * 3, (p + 1) * W * H * 3), W * H), W, H, THREE.HalfFloatType);
    albedo.minFilter = albedo.magFilter = THREE.NearestFilter;
    const target = new THREE.WebGLRenderTarget(W, H, { type: THREE.HalfFloatType, depthBuffer: false,
                                                       minFilter: THREE.LinearFilter, magFilter: THREE.LinearFilter });
    target.texture.generateMipmaps = false;
    target.texture.channel = 1;  // TEXCOORD_1: the lightmap's UVs
    const pass = new THREE.Mesh(new THREE.PlaneGeometry(2, 2), relightMaterial(groups, coefficients, albedo));
    pass.frustumCulled = false;
    const scene = new THREE.Scene();
    scene.add(pass);
    out.push({ target, pass, scene });
  }
  return out;
}

// value_j = bias_j + scale_j t_j; E's numerator per channel c: sum_j value_j L[k_j][c].
function setLight(page, info, L) {
  const n = info.bands * info.bands, u = page.pass.material.uniforms;
  const K = [0, 0, 0];
  for (const v of u.u_A.value) v.set(0, 0, 0, 0);
  for (let j = 0; j < info.coefficients; ++j) {
    const k = j % n, c = Math.floor(j / n), g = j >> 2, i = j & 3;
    for (let ch = 0; ch < 3; ++ch) {
      if (info.channels !== 1 && c !== ch) continue;
      K[ch] += info.bias[j] * L[k][ch];
      u.u_A.value[3 * g + ch].setComponent(i, info.scale[j] * L[k][ch]);
    }
  }
  u.u_K.value.set(...K);
}

// The scene's meshes on MeshPhysicalMaterial with their page's lightMap.
function lightmapMaterials(root, info, pages) {
  const made = new Map();
  root.traverse((o) => {
    if (!o.isMesh) return;
    const page = o.geometry.userData.prt_lightmap_page || 0;
    if (!o.geometry.attributes.uv1) fail(`model.glb: mesh ${o.name} has no TEXCOORD_1`);
    const key = o.material.uuid + '/' + page;
    if (!made.has(key)) {
      const m = new THREE.MeshPhysicalMaterial({ color: o.material.color, map: o.material.map, metalness: 0, roughness: 1,
                                                 specularIntensity: 0, side: o.material.side,
                                                 lightMap: pages[page].target.texture });
      if (info.albedo) {  // one albedo for all (--albedo), as prt render
        m.color.setRGB(...info.albedo, THREE.LinearSRGBColorSpace);
        m.map = null;
      }
      made.set(key, m);
    }
    o.material = made.get(key);
  });
  return [...made.values()];
}

// The map as prt render's background: a sphere about the camera, looked up
// as shaders/background.frag.glsl does (lat-long, the direction turned by R^T).
function backgroundSphere() {
  const material = new THREE.ShaderMaterial({
    uniforms: { u_map: { value: null }, u_rot_t: { value: new THREE.Matrix3() }, u_gain: { value: 1 } },
    side: THREE.BackSide, depthTest: false, depthWrite: false,
    vertexShader: `varying vec3 v_dir;
void main() { v_dir = position; gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }`,
    fragmentShader: `uniform sampler2D u_map; uniform mat3 u_rot_t; uniform float u_gain;
varying vec3 v_dir;
const float PI = 3.14159265358979;
void main() {
  vec3 d = normalize(u_rot_t * normalize(v_dir));
  float theta = acos(clamp(d.y, -1.0, 1.0)), phi = atan(-d.x, d.z);
  if (phi < 0.0) phi += 2.0 * PI;
  gl_FragColor = vec4(u_gain * textureLod(u_map, vec2(phi / (2.0 * PI), theta / PI), 0.0).rgb, 1.0);
  #include <tonemapping_fragment>
  #include <colorspace_fragment>
}`,
  });
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(1, 64, 32), material);
  sphere.renderOrder = -1;
  sphere.frustumCulled = false;
  return sphere;
}

// probes.bin (docs/FORMAT.md "Probe matrices"): its probes' matrices.
function parseMatrices(buf, count) {
  const dv = new DataView(buf);
  if (String.fromCharCode(...new Uint8Array(buf, 0, 8)) !== 'PRTPMAT1') fail('probes.bin: not a prt probe matrices file');
  const P = dv.getUint32(8, true), out = dv.getUint32(72, true), inn = dv.getUint32(76, true), channels = dv.getUint32(80, true);
  if (P !== count || out !== 9 || inn !== 9 || (channels !== 1 && channels !== 3))
    fail(`probes.bin: ${P} probes, ${out} x ${inn} matrices, ${channels} channels; expected ${count}, 9 x 9`);
  const offset = 88 + 16 * P;
  if (buf.byteLength !== offset + 4 * P * channels * 81) fail('probes.bin: truncated');
  return { channels, m: new Float32Array(buf, offset, P * channels * 81) };
}

const kThreeSign = [1, -1, 1, -1, 1, -1, 1, -1, 1];  // prt's Condon-Shortley phase off (docs/CONVENTIONS.md)

// Every probe's incident radiance SH under L (prt's, >= 9 coefficients), in
// three's convention, into doc.probes[p].three.
function relightProbes(doc, mats, L) {
  const { channels, m } = mats;
  doc.probes.forEach((probe, p) => {
    for (let k = 0; k < 9; ++k)
      for (let c = 0; c < 3; ++c) {
        const base = ((p * channels + (channels === 1 ? 0 : c)) * 9 + k) * 9;
        let v = 0;
        for (let j = 0; j < 9; ++j) v += m[base + j] * L[j][c];
        probe.three[k][c] = kThreeSign[k] * v;
      }
  });
}

// The probe grid and its moving sphere (a second scene), or null.
async function probeScene(lighting, THREE_LightProbeGrid, state) {
  if (!lighting.probes) return null;
  const doc = JSON.parse(new TextDecoder().decode(await fetchOk(lighting.probes.json)));
  const mats = parseMatrices(await fetchOk(lighting.probes.matrices), doc.probes.length);
  const grid = probeGridFromPrt(THREE, THREE_LightProbeGrid, doc, { intensity: 1 });
  const g = doc.three_grid;
  const size = state.objectSize || 0.3 * Math.min(...g.size);
  const sphere = new THREE.Mesh(new THREE.SphereGeometry(size / (2 * Math.sqrt(3)), 48, 24),
                                new THREE.MeshLambertMaterial({ color: new THREE.Color().setRGB(0.8, 0.8, 0.8, THREE.LinearSRGBColorSpace) }));
  const scene = new THREE.Scene();
  scene.add(grid, sphere);
  return {
    scene, doc,
    update(L, gain, time) {
      relightProbes(doc, mats, L);
      fillProbeGrid(doc, gain, grid.texture.image.data);
      grid.texture.needsUpdate = true;
      if (state.object) sphere.position.fromArray(state.object);
      else {  // a circle about the grid's centre, a quarter of its smaller side across
        const a = (time / 1000) * 0.5, r = 0.25 * Math.min(g.size[0], g.size[2]);
        sphere.position.set(g.position[0] + r * Math.cos(a), g.position[1], g.position[2] + r * Math.sin(a));
      }
    },
  };
}

const numbers = (q, name, count) => {
  if (!q.has(name)) return null;
  const v = q.get(name).split(',').map(Number);
  if (v.length !== count || !v.every(Number.isFinite)) fail(`?${name}=: ${count} comma-separated numbers expected`);
  return v;
};

// The first frame's state: lighting.json's initial, then the URL's.
function initialState(lighting) {
  const q = new URLSearchParams(location.search), init = lighting.initial;
  const s = { map: q.get('map') || init.map, rotate: numbers(q, 'rotate', 3) || init.rotate.slice(),
              spin: (numbers(q, 'spin', 1) || [init.spin || 0])[0], exposure: (numbers(q, 'exposure', 1) || [init.exposure])[0],
              auto: q.has('auto') ? q.get('auto') === '1' : !!init.auto, camera: numbers(q, 'camera', 9) || init.camera,
              fov: (numbers(q, 'fov', 1) || [init.fov])[0], width: (numbers(q, 'width', 1) || [960])[0],
              height: (numbers(q, 'height', 1) || [720])[0], object: numbers(q, 'object', 3),
              objectSize: (numbers(q, 'object-size', 1) || [0])[0], room: q.get('room') !== '0' };
  if (!lighting.maps.some((m) => m.name === s.map)) fail(`?map=${s.map}: not among lighting.json's maps`);
  return s;
}

async function mapTexture(m, cache) {
  if (!cache.has(m.name)) {
    const half = new Uint16Array(await fetchOk(m.file));
    cache.set(m.name, dataTexture(rgbaHalf(half, m.width * m.height), m.width, m.height, THREE.HalfFloatType));
  }
  return cache.get(m.name);
}

function controls(lighting, state, redraw) {
  const select = $('map'), exposure = $('exposure'), auto = $('auto');
  for (const m of lighting.maps) select.add(new Option(m.name, m.name, false, m.name === state.map));
  const show = () => { $('exposure-value').textContent = state.exposure.toFixed(1); };
  exposure.value = state.exposure;
  auto.checked = state.auto;
  show();
  select.onchange = () => { state.map = select.value; redraw(); };
  exposure.oninput = () => { state.exposure = Number(exposure.value); show(); redraw(); };
  auto.onchange = () => { state.auto = auto.checked; redraw(); };
}

async function main() {
  const lighting = JSON.parse(new TextDecoder().decode(await fetchOk('lighting.json')));
  const gltf = await new GLTFLoader().loadAsync(lighting.model || 'model.glb');
  const info = gltf.parser.json.asset.extras && gltf.parser.json.asset.extras.prt;
  if (!info || info.format !== 'prt SH lightmap') fail('model.glb: not a prt SH lightmap export (prt export --three)');
  if (info.bits !== 8 || info.scale.length !== info.coefficients || info.coefficients !== info.channels * info.bands ** 2)
    fail('model.glb: asset.extras.prt: an inconsistent lightmap description (docs/FORMAT.md "Lightmap export")');
  const groups = Math.ceil(info.coefficients / 4);
  const pages = await lightmapPages(gltf.parser, info, lighting, groups);
  const materials = lightmapMaterials(gltf.scene, info, pages);
  const state = initialState(lighting);
  const canvas = $('canvas');
  const renderer = new THREE.WebGLRenderer({ canvas, antialias: false, preserveDrawingBuffer: true });
  renderer.setPixelRatio(1);
  renderer.setSize(state.width, state.height, false);
  renderer.toneMapping = THREE.NoToneMapping;  // prt's clamp (other tone maps: not matched, docs/WEB.md)
  renderer.outputColorSpace = THREE.SRGBColorSpace;
  const scene = new THREE.Scene(), sphere = backgroundSphere();
  scene.add(sphere, gltf.scene);
  const [ex, ey, ez, tx, ty, tz, ux, uy, uz] = state.camera;
  const dist = Math.hypot(ex - tx, ey - ty, ez - tz);
  // prt render's projection: glm::perspective(fov, W / H, dist 1e-3, dist 1e3), glm::lookAt.
  const camera = new THREE.PerspectiveCamera(state.fov, state.width / state.height, dist * 1e-3, dist * 1e3);
  camera.position.set(ex, ey, ez);
  camera.up.set(ux, uy, uz);
  camera.lookAt(tx, ty, tz);
  sphere.position.copy(camera.position);
  sphere.scale.setScalar(dist * 100);
  const rotation = new SH.Rotation(info.bands), cache = new Map();
  const { LightProbeGridWebGL } = lighting.probes ? await import('three/addons/lighting/LightProbeGridWebGL.js') : {};
  const probes = await probeScene(lighting, LightProbeGridWebGL, state);

  async function frame() {
    const m = lighting.maps.find((x) => x.name === state.map);
    if (!m) fail(`no map ${state.map}`);
    const R = SH.turned(state.spin, SH.fromEuler(state.rotate[0], state.rotate[1], state.rotate[2]));
    rotation.set(R);
    const L = rotation.apply(m.coefficients);
    for (const page of pages) {
      setLight(page, info, L);
      renderer.setRenderTarget(page.target);
      renderer.render(page.scene, camera);
    }
    renderer.setRenderTarget(null);
    const gain = 2 ** state.exposure;
    for (const mat of materials) mat.lightMapIntensity = gain;
    const u = sphere.material.uniforms;
    u.u_map.value = await mapTexture(m, cache);
    u.u_rot_t.value.set(...R).transpose();  // set() takes R row-major; the lookup turns by R^T
    u.u_gain.value = gain;
    gltf.scene.visible = sphere.visible = state.room;
    renderer.setClearColor(state.clear === undefined ? 0 : state.clear);
    renderer.autoClear = true;
    renderer.render(scene, camera);
    if (probes) {
      probes.update(L, gain, performance.now());
      renderer.autoClear = false;  // over the room, its depth kept
      renderer.render(probes.scene, camera);
    }
    $('status').textContent = `three.js r${THREE.REVISION} | ${state.map} | rotate ${state.rotate.join(',')} spin ` +
                              `${state.spin.toFixed(1)} | ${materials.length} materials, ${pages.length} lightmap pages`;
  }

  let last = performance.now();
  function tick(now) {
    if (state.auto) {
      state.spin = (state.spin + 20 * (now - last) / 1000) % 360;  // 20 degrees per second, as prt's page
      frame();
    }
    last = now;
    requestAnimationFrame(tick);
  }
  controls(lighting, state, () => frame());
  await frame();
  requestAnimationFrame(tick);
  resolveReady({
    probes: () => probes && probes.doc.probes.map((p) => p.three.map((c) => c.slice())),
    async frame(s) {
      Object.assign(state, s);
      await frame();
    },
  });
}

main().catch((e) => {
  if (!self.prtThreeError) {
    self.prtThreeError = String(e && e.message || e);
    $('status').textContent = 'error: ' + self.prtThreeError;
  }
  rejectReady(e);
});
