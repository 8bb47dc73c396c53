// prt-viewer.js - relights a prt glTF export (model.glb, docs/FORMAT.md) in
// WebGL2 under the SH lighting of lighting.json, as prt render draws it
// (runtime/renderer.cpp, shaders/*.glsl): per-vertex radiance = the
// transfer row dotted with the rotated lighting (mono transfers: one row
// for the three colour channels), Gouraud-interpolated, over the environment
// drawn as background at the pixel's view direction, then exposure, tone map
// and sRGB encoding per pixel. No third-party code; see docs/WEB.md.
//
// Where the transfer lives: an RGBA32F texture read in the vertex shader by
// gl_VertexID (WebGL2 guarantees only 16 vertex attributes; 16 bands of RGB
// transfer need 192 vec4s), laid out as relight.comp.glsl's buffer: per
// vertex CHANNELS runs of VEC4S texels, each channel zero padded.
//
// A lightmap (prt precompute SCENE --lightmap, exported by write_gltf_lightmap):
// the scene's objects drawn with their lightmap UVs (TEXCOORD_1); each
// fragment samples the 8-bit coefficient textures of its primitive's page
// (a lightmap of many pages has images of its own per page; per page one
// TEXTURE_2D_ARRAY layer per 4 coefficients) bilinearly, decodes value =
// bias + scale x byte / 255 and dots it with the rotated lighting, as the lightmap pass of
// prt render relights texels and samples the result (the two are equal: both
// are linear in the texel values); with detail (the default, as prt render)
// the material's albedo at the fragment replaces the texel's
// (lightmap_albedo.rgb16f). The PNGs are decoded here (DecompressionStream),
// not by the browser, so their bytes arrive unchanged (no colour management,
// no premultiplied alpha).
//
// Test hooks: URL query map, rotate=yaw,pitch,roll, spin (degrees about +Y),
// exposure, tonemap, camera=ex,ey,ez,tx,ty,tz,ux,uy,uz, fov, size=WxH,
// auto=0|1, model=0 (background only), detail=0|1 (lightmaps); window.prtReady resolves after the
// first frame is drawn (with the exposure it was drawn at); window.prtViewer.set({...}) draws a frame with new
// settings and resolves when it is on the canvas.
(function () {
  'use strict';
  const SH = self.PrtSH, PNG = self.PrtPNG;
  const $ = (id) => document.getElementById(id);
  const status = $('status');

  let resolveReady, rejectReady;
  self.prtReady = new Promise((res, rej) => { resolveReady = res; rejectReady = rej; });

  function fail(message) {
    status.textContent = 'error: ' + message;
    rejectReady(new Error(message));
    throw new Error(message);
  }

  // --- GLB --------------------------------------------------------------
  function parseGlb(buf) {
    const dv = new DataView(buf);
    if (buf.byteLength < 20 || dv.getUint32(0, true) !== 0x46546c67) fail('model.glb: not a binary glTF');
    let offset = 12, json = null, bin = null;
    while (offset + 8 <= buf.byteLength) {
      const len = dv.getUint32(offset, true), type = dv.getUint32(offset + 4, true);
      const body = buf.slice(offset + 8, offset + 8 + len);
      if (type === 0x4e4f534a) json = JSON.parse(new TextDecoder().decode(body));
      else if (type === 0x004e4942) bin = body;
      offset += 8 + len;
    }
    if (!json || !bin) fail('model.glb: no JSON or BIN chunk');
    const comps = { SCALAR: 1, VEC2: 2, VEC3: 3, VEC4: 4 };
    const accessor = (index) => {
      const a = json.accessors[index], v = json.bufferViews[a.bufferView];
      const n = comps[a.type], start = (v.byteOffset || 0) + (a.byteOffset || 0);
      const Type = a.componentType === 5126 ? Float32Array : a.componentType === 5125 ? Uint32Array
                 : a.componentType === 5123 ? Uint16Array : null;
      if (!Type) fail('model.glb: accessor ' + index + ' has an unsupported component type');
      const stride = v.byteStride || n * Type.BYTES_PER_ELEMENT;
      if (stride === n * Type.BYTES_PER_ELEMENT) return new Type(bin, start, a.count * n);
      const out = new Type(a.count * n), dv2 = new DataView(bin);
      for (let i = 0; i < a.count; ++i)
        for (let c = 0; c < n; ++c) {
          const o = start + i * stride + c * Type.BYTES_PER_ELEMENT;
          out[i * n + c] = Type === Float32Array ? dv2.getFloat32(o, true) : Type === Uint32Array ? dv2.getUint32(o, true) : dv2.getUint16(o, true);
        }
      return out;
    };
    const info = json.asset && json.asset.extras && json.asset.extras.prt;
    if (!info || info.basis !== 'sh') fail('model.glb: no asset.extras.prt with an SH transfer (prt export)');
    // The bytes of a buffer view (images).
    const view = (index) => {
      const v = json.bufferViews[index];
      return new Uint8Array(bin, v.byteOffset || 0, v.byteLength);
    };
    return { json, info, accessor, view };
  }

  // The per-vertex model (write_gltf): one primitive, the transfer rows in
  // the attributes info.attributes names.
  function vertexGeometry(glb) {
    const { json, info, accessor } = glb;
    const prim = json.meshes[0].primitives[0];
    const positions = accessor(prim.attributes.POSITION);
    const vertices = positions.length / 3;
    const rows = info.attributes.map((name) => {
      if (prim.attributes[name] === undefined) fail('model.glb: attribute ' + name + ' missing');
      return accessor(prim.attributes[name]);
    });
    return { vertices, positions, indices: accessor(prim.indices), rows };
  }

  // --- PNG -> RGBA8 (prt-png.js; inflated here by the browser) -----------
  async function decodePng(bytes, what) {
    let png, px;
    try {
      png = PNG.chunks(bytes, what);
      const stream = new Blob(png.idat).stream().pipeThrough(new DecompressionStream('deflate'));
      px = PNG.unfilter(new Uint8Array(await new Response(stream).arrayBuffer()), png.width, png.height, png.channels, what);
    } catch (e) {
      fail(e.message);
    }
    const { width, height, channels } = png;
    return { width, height, rgba: PNG.rgba(px, width, height, channels) };
  }

  // The image of glTF texture `index`, decoded.
  function textureImage(glb, index, what) {
    const t = glb.json.textures[index], img = t && glb.json.images[t.source];
    if (!img || img.bufferView === undefined) fail(`model.glb: ${what}: texture ${index} has no embedded image`);
    return decodePng(glb.view(img.bufferView), `model.glb: ${what} (image ${t.source})`);
  }

  // --- shaders ------------------------------------------------------------
  const toneGlsl = `
uniform float u_gain;  // 2^exposure
uniform int u_tone;    // 0 clamp, 1 reinhard, 2 aces; 3 linear radiance (the exposure's measurement, frameExposure)
float tone(float v) {
  v = max(v * u_gain, 0.0);
  if (u_tone == 1) return v / (1.0 + v);
  if (u_tone == 2) return clamp(v * (2.51 * v + 0.03) / (v * (2.43 * v + 0.59) + 0.14), 0.0, 1.0);
  return min(v, 1.0);
}
float encode(float v) { return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055; }
vec4 display(vec3 c) {
  if (u_tone == 3) return vec4(c, 1.0);
  return vec4(encode(tone(c.r)), encode(tone(c.g)), encode(tone(c.b)), 1.0);
}
`;
  const meshVert = (coeffs, vec4s, channels) => `#version 300 es
precision highp float; precision highp int; precision highp sampler2D;
#define COEFFS ${coeffs}
#define VEC4S ${vec4s}
#define CHANNELS ${channels}
in vec3 a_position;
uniform mat4 u_view_proj;
uniform sampler2D u_transfer;
uniform int u_width;
layout(std140) uniform Light { vec4 L[VEC4S * 4]; };
out vec3 v_radiance;
vec4 fetch(int i) { return texelFetch(u_transfer, ivec2(i % u_width, i / u_width), 0); }
void main() {
  const int FETCHES = (COEFFS + 3) / 4;
  int base = gl_VertexID * (CHANNELS * VEC4S);
  vec3 r = vec3(0.0);
  for (int i = 0; i < FETCHES; ++i) {
    vec3 l0 = L[4 * i].rgb, l1 = L[4 * i + 1].rgb, l2 = L[4 * i + 2].rgb, l3 = L[4 * i + 3].rgb;
#if CHANNELS == 1
    vec4 t = fetch(base + i);
    r += t.x * l0 + t.y * l1 + t.z * l2 + t.w * l3;
#else
    vec4 tr = fetch(base + i), tg = fetch(base + VEC4S + i), tb = fetch(base + 2 * VEC4S + i);
    r += vec3(dot(tr, vec4(l0.r, l1.r, l2.r, l3.r)), dot(tg, vec4(l0.g, l1.g, l2.g, l3.g)),
              dot(tb, vec4(l0.b, l1.b, l2.b, l3.b)));
#endif
  }
  v_radiance = r;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}`;
  const meshFrag = `#version 300 es
precision highp float; precision highp int;
in vec3 v_radiance;
out vec4 o_color;
${toneGlsl}
void main() { o_color = display(v_radiance); }`;
  // The lightmap's shaders: K + sum over layers g of dot(texel_g, A[3g + c])
  // is bias . L + (scale x byte / 255) . L per channel c, folded on the CPU
  // each frame (lightmapModel's light()).
  const lightmapVert = `#version 300 es
precision highp float;
in vec3 a_position;
in vec2 a_uv0;
in vec2 a_uv1;
uniform mat4 u_view_proj;
out vec2 v_uv0;
out vec2 v_uv1;
void main() {
  v_uv0 = a_uv0;
  v_uv1 = a_uv1;
  gl_Position = u_view_proj * vec4(a_position, 1.0);
}`;
  // shaders/lightmap.frag.glsl's detail: the material's albedo over the texel's.
  const lightmapFrag = (groups) => `#version 300 es
precision highp float; precision highp int; precision highp sampler2D; precision highp sampler2DArray;
#define GROUPS ${groups}
in vec2 v_uv0;
in vec2 v_uv1;
out vec4 o_color;
uniform sampler2DArray u_coefficients;
uniform sampler2D u_texel_albedo;
uniform sampler2D u_base;
uniform vec4 u_base_color;
uniform int u_has_texture;
uniform int u_base_uv;
uniform int u_detail;
layout(std140) uniform Light { vec4 K; vec4 A[3 * GROUPS]; };
${toneGlsl}
void main() {
  vec3 r = K.rgb;
  for (int g = 0; g < GROUPS; ++g) {
    vec4 t = texture(u_coefficients, vec3(v_uv1, float(g)));
    r += vec3(dot(t, A[3 * g]), dot(t, A[3 * g + 1]), dot(t, A[3 * g + 2]));
  }
  if (u_detail != 0) {
    vec3 albedo = u_base_color.rgb;
    if (u_has_texture != 0) albedo *= texture(u_base, u_base_uv == 1 ? v_uv1 : v_uv0).rgb;
    vec3 texel = texture(u_texel_albedo, v_uv1).rgb;
    for (int c = 0; c < 3; ++c)
      if (texel[c] > 1e-3) r[c] *= clamp(albedo[c], 0.0, 1.0) / texel[c];
  }
  o_color = display(r);
}`;
  const bgVert = `#version 300 es
precision highp float;
out vec2 v_ndc;
void main() {
  vec2 p = vec2(float((gl_VertexID & 1) << 2) - 1.0, float((gl_VertexID & 2) << 1) - 1.0);
  v_ndc = p;
  gl_Position = vec4(p, 1.0, 1.0);
}`;
  // shaders/background.frag.glsl's lookup (lat-long maps).
  const bgFrag = `#version 300 es
precision highp float; precision highp int; precision highp sampler2D;
in vec2 v_ndc;
out vec4 o_color;
uniform vec3 u_forward, u_right, u_up;
uniform mat3 u_rot_t;
uniform sampler2D u_latlong;
${toneGlsl}
const float kPi = 3.14159265358979323846;
void main() {
  vec3 d = normalize(u_rot_t * normalize(u_forward + v_ndc.x * u_right + v_ndc.y * u_up));
  float theta = acos(clamp(d.y, -1.0, 1.0));
  float phi = atan(-d.x, d.z);
  if (phi < 0.0) phi += 2.0 * kPi;
  o_color = display(textureLod(u_latlong, vec2(phi / (2.0 * kPi), theta / kPi), 0.0).rgb);
}`;

  function program(gl, vs, fs, name) {
    const p = gl.createProgram();
    for (const [type, src] of [[gl.VERTEX_SHADER, vs], [gl.FRAGMENT_SHADER, fs]]) {
      const s = gl.createShader(type);
      gl.shaderSource(s, src);
      gl.compileShader(s);
      if (!gl.getShaderParameter(s, gl.COMPILE_STATUS)) fail(name + ' shader: ' + gl.getShaderInfoLog(s));
      gl.attachShader(p, s);
    }
    ['a_position', 'a_uv0', 'a_uv1'].forEach((a, i) => gl.bindAttribLocation(p, i, a));
    gl.linkProgram(p);
    if (!gl.getProgramParameter(p, gl.LINK_STATUS)) fail(name + ' program: ' + gl.getProgramInfoLog(p));
    const u = {};
    const n = gl.getProgramParameter(p, gl.ACTIVE_UNIFORMS);
    for (let i = 0; i < n; ++i) {
      const name2 = gl.getActiveUniform(p, i).name.replace(/\[0\]$/, '');
      u[name2] = gl.getUniformLocation(p, name2);
    }
    return { p, u };
  }

  // --- camera (glm::lookAt, glm::perspective; column-major) ---------------
  const sub = (a, b) => [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
  const dot = (a, b) => a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
  const cross = (a, b) => [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]];
  const norm = (a) => { const l = Math.hypot(a[0], a[1], a[2]); return [a[0] / l, a[1] / l, a[2] / l]; };
  const scale = (a, s) => [a[0] * s, a[1] * s, a[2] * s];
  const add = (a, b) => [a[0] + b[0], a[1] + b[1], a[2] + b[2]];
  function viewProj(cam, aspect) {
    const f = norm(sub(cam.target, cam.eye)), s = norm(cross(f, cam.up)), u = cross(s, f);
    const V = [s[0], u[0], -f[0], 0, s[1], u[1], -f[1], 0, s[2], u[2], -f[2], 0,
               -dot(s, cam.eye), -dot(u, cam.eye), dot(f, cam.eye), 1];
    const dist = Math.hypot(...sub(cam.target, cam.eye)), near = dist * 1e-3, far = dist * 1e3;
    const t = Math.tan(cam.fov * Math.PI / 360);
    const P = [1 / (aspect * t), 0, 0, 0, 0, 1 / t, 0, 0, 0, 0, -(far + near) / (far - near), -1,
               0, 0, -2 * far * near / (far - near), 0];
    const M = new Float32Array(16);
    for (let c = 0; c < 4; ++c)
      for (let r = 0; r < 4; ++r) {
        let v = 0;
        for (let k = 0; k < 4; ++k) v += P[4 * k + r] * V[4 * c + k];
        M[4 * c + r] = v;
      }
    return { M, f, s, u, t };
  }

  // --- the two kinds of model -----------------------------------------------
  // Each draws itself with the rotated lighting L (n = bands^2 RGB triples)
  // after the background: draw(viewProj, L, gain, tone, state).

  // Per-vertex transfer: an RGBA32F texture [vertex][channel][vec4s] from
  // the glTF's [channel][k] rows, read in the vertex shader.
  function vertexModel(gl, glb) {
    const model = vertexGeometry(glb);
    const bands = glb.info.bands, channels = glb.info.channels, n = bands * bands;
    const vec4s = (n + 3) >> 2;
    const maxTex = gl.getParameter(gl.MAX_TEXTURE_SIZE);
    const texels = model.vertices * channels * vec4s, width = Math.min(maxTex, 8192);
    const height = Math.ceil(texels / width);
    if (height > maxTex) fail(`the transfer (${texels} texels) does not fit this WebGL's ${maxTex}^2 texture`);
    const data = new Float32Array(width * height * 4);
    for (let v = 0; v < model.vertices; ++v)
      for (let c = 0; c < channels; ++c)
        for (let k = 0; k < n; ++k) {
          const j = c * n + k;
          data[((v * channels + c) * vec4s) * 4 + k] = model.rows[j >> 2][4 * v + (j & 3)];
        }
    const transferTex = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, transferTex);
    gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, width, height);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, width, height, gl.RGBA, gl.FLOAT, data);
    for (const p of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D, p, gl.NEAREST);

    const indices = model.indices instanceof Uint32Array ? model.indices : new Uint32Array(model.indices);
    const vao = geometry(gl, [model.positions], indices);
    const mesh = program(gl, meshVert(n, vec4s, channels), meshFrag, 'mesh');
    const light = uniformBlock(gl, mesh, vec4s * 16);
    return {
      vertices: model.vertices,
      describe: () => `${model.vertices} vertices, ${indices.length / 3} triangles, ${bands} bands, ` +
                      `${channels === 1 ? 'mono' : 'RGB'} ${glb.info.mode || ''} transfer` +
                      // A translucent material (prt precompute --material subsurface): its record's name.
                      (glb.info.subsurface ? `, translucent (${glb.info.subsurface.name || 'subsurface'})` : ''),
      draw(M, L, gain, tone) {
        light.data.fill(0);
        for (let k = 0; k < n; ++k) light.data.set(L[k], 4 * k);
        gl.useProgram(mesh.p);
        light.bind();
        gl.uniformMatrix4fv(mesh.u.u_view_proj, false, M);
        gl.uniform1f(mesh.u.u_gain, gain);
        gl.uniform1i(mesh.u.u_tone, tone);
        gl.activeTexture(gl.TEXTURE1);
        gl.bindTexture(gl.TEXTURE_2D, transferTex);
        gl.uniform1i(mesh.u.u_transfer, 1);
        gl.uniform1i(mesh.u.u_width, width);
        gl.bindVertexArray(vao);
        gl.drawElements(gl.TRIANGLES, indices.length, gl.UNSIGNED_INT, 0);
      },
    };
  }

  // A vertex array of float attributes 0, 1, ... (tightly packed arrays of
  // 3, 2, 2 components) and 32-bit indices.
  function geometry(gl, attributes, indices) {
    const vao = gl.createVertexArray();
    gl.bindVertexArray(vao);
    attributes.forEach((data, a) => {
      gl.bindBuffer(gl.ARRAY_BUFFER, gl.createBuffer());
      gl.bufferData(gl.ARRAY_BUFFER, data, gl.STATIC_DRAW);
      gl.enableVertexAttribArray(a);
      gl.vertexAttribPointer(a, a === 0 ? 3 : 2, gl.FLOAT, false, 0, 0);
    });
    gl.bindBuffer(gl.ELEMENT_ARRAY_BUFFER, gl.createBuffer());
    gl.bufferData(gl.ELEMENT_ARRAY_BUFFER, indices, gl.STATIC_DRAW);
    gl.bindVertexArray(null);
    return vao;
  }

  // The uniform block Light of `prog` (binding 0): data (floats), bind()
  // uploads and binds it.
  function uniformBlock(gl, prog, floats) {
    gl.uniformBlockBinding(prog.p, gl.getUniformBlockIndex(prog.p, 'Light'), 0);
    const buffer = gl.createBuffer(), data = new Float32Array(floats);
    gl.bindBuffer(gl.UNIFORM_BUFFER, buffer);
    gl.bufferData(gl.UNIFORM_BUFFER, data.byteLength, gl.DYNAMIC_DRAW);
    return {
      data,
      bind() {
        gl.bindBuffer(gl.UNIFORM_BUFFER, buffer);
        gl.bufferSubData(gl.UNIFORM_BUFFER, 0, data);
        gl.bindBufferBase(gl.UNIFORM_BUFFER, 0, buffer);
      },
    };
  }

  function texture2d(gl, width, height, format, type, internal, data, wrap, filter) {
    const t = gl.createTexture();
    gl.bindTexture(gl.TEXTURE_2D, t);
    gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
    gl.texStorage2D(gl.TEXTURE_2D, 1, internal, width, height);
    gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, width, height, format, type, data);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, filter || gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, filter || gl.LINEAR);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, wrap[0]);
    gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, wrap[1]);
    return t;
  }

  // Per page of a lightmap (docs/FORMAT.md "Lightmap export"): its
  // coefficient textures in one texture array (layer g holds coefficients
  // 4g .. 4g + 3) and its texel albedo (lighting.json's lightmap_albedo:
  // every page's W x H, one after another).
  async function lightmapPages(gl, glb, lighting, pages, W, H, groups) {
    const { info } = glb;
    const pageTextures = pages > 1 ? info.textures : [info.textures];
    if (!Array.isArray(pageTextures) || pageTextures.length !== pages ||
        !pageTextures.every((t) => Array.isArray(t) && t.length === groups))
      fail('model.glb: asset.extras.prt: textures is not ' + groups + ' coefficient textures per page for ' + pages + ' pages');
    const a = lighting.lightmap_albedo;
    if (!a || a.width !== W || a.height !== H || (a.pages || 1) !== pages)
      fail('lighting.json: no lightmap_albedo of the lightmap\'s size and pages');
    const half = new Uint16Array(await fetchOk(a.file));
    if (half.length !== pages * W * H * 3) fail(a.file + ': ' + half.length + ' values, expected ' + pages * W * H * 3);
    const clampWrap = [gl.CLAMP_TO_EDGE, gl.CLAMP_TO_EDGE], out = [];
    for (let p = 0; p < pages; ++p) {
      const coefficients = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D_ARRAY, coefficients);
      gl.texStorage3D(gl.TEXTURE_2D_ARRAY, 1, gl.RGBA8, W, H, groups);
      for (let g = 0; g < groups; ++g) {
        const what = 'coefficient texture ' + g + (pages > 1 ? ' of page ' + p : '');
        const img = await textureImage(glb, pageTextures[p][g], what);
        if (img.width !== W || img.height !== H) fail(`model.glb: ${what} is ${img.width}x${img.height}, the lightmap ${W}x${H}`);
        gl.texSubImage3D(gl.TEXTURE_2D_ARRAY, 0, 0, 0, g, W, H, 1, gl.RGBA, gl.UNSIGNED_BYTE, img.rgba);
      }
      for (const q of [gl.TEXTURE_MIN_FILTER, gl.TEXTURE_MAG_FILTER]) gl.texParameteri(gl.TEXTURE_2D_ARRAY, q, gl.LINEAR);
      for (const q of [gl.TEXTURE_WRAP_S, gl.TEXTURE_WRAP_T]) gl.texParameteri(gl.TEXTURE_2D_ARRAY, q, gl.CLAMP_TO_EDGE);
      const albedo = texture2d(gl, W, H, gl.RGB, gl.HALF_FLOAT, gl.RGB16F, half.subarray(p * W * H * 3, (p + 1) * W * H * 3),
                               clampWrap);
      out.push({ coefficients, albedo });
    }
    return out;
  }

  // A lightmap (docs/FORMAT.md "Lightmap export"): every node's primitives
  // in one vertex array (world-space vertices: prt writes no node
  // transforms), drawn per material and page (a primitive's
  // extras.prt_lightmap_page, its TEXCOORD_1 local to that page) with that
  // page's textures (lightmapPages).
  async function lightmapModel(gl, glb, lighting) {
    const { json, info, accessor } = glb;
    const bands = info.bands, channels = info.channels, n = bands * bands, stride = info.coefficients;
    const W = info.lightmap.width, H = info.lightmap.height, pages = info.lightmap.pages || 1;
    const uvSet = 'TEXCOORD_' + info.lightmap.texcoord, groups = Math.ceil(stride / 4);
    if (stride !== channels * n || info.scale.length !== stride || info.bias.length !== stride || info.bits !== 8 ||
        !(Number.isInteger(pages) && pages >= 1))
      fail('model.glb: asset.extras.prt: an inconsistent lightmap description (docs/FORMAT.md "Lightmap export")');
    if (groups > gl.getParameter(gl.MAX_ARRAY_TEXTURE_LAYERS))
      fail(`model.glb: ${groups} coefficient textures exceed this WebGL's ${gl.getParameter(gl.MAX_ARRAY_TEXTURE_LAYERS)} texture layers`);
    const maxSize = gl.getParameter(gl.MAX_TEXTURE_SIZE);
    if (W > maxSize || H > maxSize) fail(`model.glb: a ${W}x${H} lightmap page exceeds this WebGL's ${maxSize} texels a side`);

    // Geometry, gathered per material and page.
    const positions = [], uv0 = [], uv1 = [], batchOf = new Map();
    let vertices = 0, triangles = 0, objects = 0;
    for (const nodeIndex of json.scenes[json.scene || 0].nodes) {
      const node = json.nodes[nodeIndex];
      if (node.matrix || node.translation || node.rotation || node.scale || node.children)
        fail('model.glb: node ' + nodeIndex + ' has a transform or children (prt export writes world-space vertices)');
      if (node.mesh === undefined) continue;
      ++objects;
      for (const prim of json.meshes[node.mesh].primitives) {
        if (prim.mode !== undefined && prim.mode !== 4) fail('model.glb: a primitive that is not triangles');
        if (prim.attributes[uvSet] === undefined) fail('model.glb: node ' + nodeIndex + ' has no ' + uvSet);
        const page = (prim.extras && prim.extras.prt_lightmap_page) || 0;
        if (!(Number.isInteger(page) && page >= 0 && page < pages))
          fail(`model.glb: node ${nodeIndex}: a primitive on lightmap page ${page} of ${pages}`);
        const p = accessor(prim.attributes.POSITION), count = p.length / 3;
        const t1 = accessor(prim.attributes[uvSet]);
        const t0 = prim.attributes.TEXCOORD_0 !== undefined ? accessor(prim.attributes.TEXCOORD_0) : new Float32Array(2 * count);
        const idx = accessor(prim.indices);
        positions.push(p);
        uv0.push(t0);
        uv1.push(t1);
        const material = prim.material === undefined ? -1 : prim.material, key = material + '/' + page;
        if (!batchOf.has(key)) batchOf.set(key, { material, page, list: [] });
        const list = batchOf.get(key).list;
        for (let i = 0; i < idx.length; ++i) list.push(idx[i] + vertices);
        vertices += count;
        triangles += idx.length / 3;
      }
    }
    const concat = (parts) => {
      const out = new Float32Array(parts.reduce((s, a) => s + a.length, 0));
      let o = 0;
      for (const a of parts) { out.set(a, o); o += a.length; }
      return out;
    };
    const batches = [], all = [];
    for (const { material, page, list } of batchOf.values()) {
      batches.push({ material, page, first: all.length, count: list.length });
      for (const i of list) all.push(i);
    }
    const vao = geometry(gl, [concat(positions), concat(uv0), concat(uv1)], new Uint32Array(all));

    // Materials: base colour factor x texture (sRGB; linear after sampling).
    const repeat = [gl.REPEAT, gl.REPEAT];
    const materials = new Map();
    for (const { material: key } of batches) {
      if (materials.has(key)) continue;
      const m = key >= 0 ? json.materials[key] : {};
      const pbr = m.pbrMetallicRoughness || {};
      const entry = { color: pbr.baseColorFactor || [1, 1, 1, 1], texture: null, uv: 0 };
      // One albedo for all (--albedo): every fragment's too, as prt render.
      if (info.albedo) entry.color = [...info.albedo, 1];
      else if (pbr.baseColorTexture) {
        const img = await textureImage(glb, pbr.baseColorTexture.index, `material ${m.name || key}`);
        entry.texture = texture2d(gl, img.width, img.height, gl.RGBA, gl.UNSIGNED_BYTE, gl.SRGB8_ALPHA8, img.rgba, repeat);
        entry.uv = pbr.baseColorTexture.texCoord || 0;
      }
      materials.set(key, entry);
    }
    const pageTextures = await lightmapPages(gl, glb, lighting, pages, W, H, groups);

    const prog = program(gl, lightmapVert, lightmapFrag(groups), 'lightmap');
    const light = uniformBlock(gl, prog, 4 + 12 * groups);
    return {
      vertices,
      lightmap: { width: W, height: H, pages, objects, triangles },
      describe: () => `${objects} objects, ${triangles} triangles, ${pages > 1 ? pages + ' pages of ' : ''}${W}x${H} ` +
                      `lightmap, ${bands} bands, ${channels === 1 ? 'mono' : 'RGB'} ${info.mode || ''} transfer`,
      draw(M, L, gain, tone, state) {
        // value_j = bias_j + scale_j t_j (t = byte / 255, what the sampler
        // returns); radiance_c = sum_j value_j L[k_j][c] over the j of
        // channel c (every j for a 1-channel row).
        const d = light.data;
        d.fill(0);
        for (let j = 0; j < stride; ++j) {
          const k = j % n, c = Math.floor(j / n), g = j >> 2, i = j & 3;
          for (let ch = 0; ch < 3; ++ch) {
            if (channels !== 1 && c !== ch) continue;
            d[ch] += info.bias[j] * L[k][ch];
            d[4 + (3 * g + ch) * 4 + i] = info.scale[j] * L[k][ch];
          }
        }
        gl.useProgram(prog.p);
        light.bind();
        gl.uniformMatrix4fv(prog.u.u_view_proj, false, M);
        gl.uniform1f(prog.u.u_gain, gain);
        gl.uniform1i(prog.u.u_tone, tone);
        gl.uniform1i(prog.u.u_detail, state.detail ? 1 : 0);
        gl.uniform1i(prog.u.u_coefficients, 1);
        gl.uniform1i(prog.u.u_texel_albedo, 2);
        gl.uniform1i(prog.u.u_base, 3);
        gl.bindVertexArray(vao);
        for (const b of batches) {
          const m = materials.get(b.material), t = pageTextures[b.page];
          gl.uniform4fv(prog.u.u_base_color, m.color);
          gl.uniform1i(prog.u.u_has_texture, m.texture ? 1 : 0);
          gl.uniform1i(prog.u.u_base_uv, m.uv);
          gl.activeTexture(gl.TEXTURE1);
          gl.bindTexture(gl.TEXTURE_2D_ARRAY, t.coefficients);
          gl.activeTexture(gl.TEXTURE2);
          gl.bindTexture(gl.TEXTURE_2D, t.albedo);
          gl.activeTexture(gl.TEXTURE3);
          gl.bindTexture(gl.TEXTURE_2D, m.texture);
          gl.drawElements(gl.TRIANGLES, b.count, gl.UNSIGNED_INT, 4 * b.first);
        }
      },
    };
  }

  // --- the page -----------------------------------------------------------
  const q = new URLSearchParams(location.search);
  const numbers = (text, count, what) => {
    const v = text.split(',').map(Number);
    if (v.length !== count || !v.every(Number.isFinite)) fail(`?${what}=: ${count} comma-separated numbers expected`);
    return v;
  };

  async function fetchOk(url, kind) {
    const r = await fetch(url);
    if (!r.ok) fail(url + ': HTTP ' + r.status);
    return kind === 'json' ? r.json() : r.arrayBuffer();
  }

  // --- exposure auto ---------------------------------------------------------
  // prt render's rule (frame_exposure, include/prt/render.h; the same two
  // constants): the stops that put the 99th percentile of the shown pixels'
  // largest channel (linear radiance) at 1. A high percentile of the largest
  // channel: at most 1% of the model clips under the clamp tone map, a sun's
  // few pixels do not darken the rest, and a dark interior is shown by its own
  // light. rgba: linear RGBA floats; a pixel is shown where alpha >= 0.5
  // (every pixel when none is); 0 stops when none is positive.
  const kAutoExposurePercentile = 0.99, kAutoExposureTarget = 1.0, kMaxExposureStops = 64;
  function frameExposure(rgba) {
    const gather = (coveredOnly) => {
      const top = [];
      for (let i = 0; i + 3 < rgba.length; i += 4) {
        if (coveredOnly && !(rgba[i + 3] >= 0.5)) continue;
        const r = rgba[i], g = rgba[i + 1], b = rgba[i + 2];
        if (!isFinite(r) || !isFinite(g) || !isFinite(b)) continue;
        top.push(Math.max(r, g, b, 0));
      }
      return top;
    };
    let top = gather(true);
    if (!top.length) top = gather(false);
    if (!top.length) return 0;
    top.sort((a, b) => a - b);
    const v = top[Math.floor(kAutoExposurePercentile * (top.length - 1))];
    return v > 0 ? Math.min(kMaxExposureStops, Math.max(-kMaxExposureStops, Math.log2(kAutoExposureTarget / v))) : 0;
  }

  async function main() {
    const canvas = $('canvas');
    const gl = canvas.getContext('webgl2', { antialias: false, preserveDrawingBuffer: true, alpha: false });
    if (!gl) fail('this browser has no WebGL2');
    const lighting = await fetchOk('lighting.json', 'json');
    const glb = parseGlb(await fetchOk(lighting.model || 'model.glb'));
    const bands = glb.info.bands, channels = glb.info.channels;
    if (lighting.bands < bands) fail('lighting.json has ' + lighting.bands + ' bands, the model ' + bands);
    const model = glb.info.format === 'prt SH lightmap' ? await lightmapModel(gl, glb, lighting) : vertexModel(gl, glb);
    const bg = program(gl, bgVert, bgFrag, 'background');
    const emptyVao = gl.createVertexArray();

    // Maps: the SH coefficients in lighting.json, the lat-long background
    // (RGB half floats, row 0 the top) fetched when first shown.
    const maps = lighting.maps;
    const mapSelect = $('map');
    for (const m of maps) {
      mapSelect.add(new Option(m.name, m.name));
      if (m.thumbnail) {  // click to pick
        const img = new Image();
        img.src = m.thumbnail;
        img.alt = img.title = m.name;
        img.dataset.map = m.name;
        img.onclick = () => { apply({ map: m.name }); requestDraw(); };
        $('thumbs').appendChild(img);
      }
    }
    const textures = new Map();
    async function mapTexture(m) {
      if (textures.has(m.name)) return textures.get(m.name);
      const half = new Uint16Array(await fetchOk(m.file));
      if (half.length !== m.width * m.height * 3) fail(m.file + ': ' + half.length + ' values, expected ' + m.width * m.height * 3);
      const t = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, t);
      gl.pixelStorei(gl.UNPACK_ALIGNMENT, 1);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGB16F, m.width, m.height);
      gl.texSubImage2D(gl.TEXTURE_2D, 0, 0, 0, m.width, m.height, gl.RGB, gl.HALF_FLOAT, half);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MIN_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_MAG_FILTER, gl.LINEAR);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_S, gl.REPEAT);
      gl.texParameteri(gl.TEXTURE_2D, gl.TEXTURE_WRAP_T, gl.CLAMP_TO_EDGE);
      textures.set(m.name, t);
      return t;
    }

    // State: prt render's options. rotate is --rotate, spin the extra turn about +Y.
    const init = lighting.initial;
    const home = { eye: init.camera.slice(0, 3), target: init.camera.slice(3, 6), up: init.camera.slice(6, 9) };
    const state = {
      map: init.map, rotate: init.rotate.slice(), spin: init.spin || 0, exposure: init.exposure,
      tonemap: init.tonemap || 'clamp', fov: init.fov, auto: false, model: true, detail: true,
      eye: home.eye.slice(), target: home.target.slice(), up: home.up.slice(),
    };
    const tones = { clamp: 0, reinhard: 1, aces: 2 };
    let fixedSize = null;
    function apply(s) {
      if (s.map !== undefined) {
        if (!maps.some((m) => m.name === s.map)) fail('no map named ' + s.map + ' (' + maps.map((m) => m.name).join(', ') + ')');
        state.map = s.map;
      }
      if (s.rotate !== undefined) state.rotate = s.rotate.slice();
      if (s.spin !== undefined) state.spin = +s.spin;
      if (s.exposure !== undefined) state.exposure = +s.exposure;
      if (s.tonemap !== undefined) {
        if (!(s.tonemap in tones)) fail('tonemap: clamp, reinhard or aces');
        state.tonemap = s.tonemap;
      }
      if (s.fov !== undefined) state.fov = +s.fov;
      if (s.camera !== undefined) {
        state.eye = s.camera.slice(0, 3);
        state.target = s.camera.slice(3, 6);
        state.up = s.camera.slice(6, 9);
      }
      if (s.auto !== undefined) state.auto = !!s.auto;
      if (s.model !== undefined) state.model = !!s.model;
      if (s.detail !== undefined) state.detail = !!s.detail;
      if (s.size !== undefined) fixedSize = s.size;
      mapSelect.value = state.map;
      for (const img of $('thumbs').children) img.classList.toggle('on', img.dataset.map === state.map);
      $('exposure').value = state.exposure;
      $('exposure-value').textContent = (+state.exposure).toFixed(1);
      $('tonemap').value = state.tonemap;
      $('auto').checked = state.auto;
      $('detail').checked = state.detail;
      $('spin').value = ((state.spin % 360) + 360) % 360;
      $('spin-value').textContent = Math.round(((state.spin % 360) + 360) % 360) + '\u00b0';
    }
    const fromUrl = {};
    if (q.has('map')) fromUrl.map = q.get('map');
    if (q.has('rotate')) fromUrl.rotate = numbers(q.get('rotate'), 3, 'rotate');
    if (q.has('spin')) fromUrl.spin = numbers(q.get('spin'), 1, 'spin')[0];
    if (q.has('exposure')) fromUrl.exposure = numbers(q.get('exposure'), 1, 'exposure')[0];
    if (q.has('tonemap')) fromUrl.tonemap = q.get('tonemap');
    if (q.has('camera')) fromUrl.camera = numbers(q.get('camera'), 9, 'camera');
    if (q.has('fov')) fromUrl.fov = numbers(q.get('fov'), 1, 'fov')[0];
    if (q.has('model')) fromUrl.model = q.get('model') !== '0';
    if (q.has('detail')) fromUrl.detail = q.get('detail') !== '0';
    fromUrl.auto = q.has('auto') ? q.get('auto') !== '0' : !!init.auto;
    if (q.has('size')) {
      const m = /^(\d+)x(\d+)$/.exec(q.get('size'));
      if (!m) fail('?size=WxH expected');
      fromUrl.size = [+m[1], +m[2]];
    }
    apply(fromUrl);

    const rotation = new SH.Rotation(bands);
    let frames = 0, fpsTime = performance.now(), fps = 0;

    function resize() {
      let w, h;
      if (fixedSize) [w, h] = fixedSize;
      else {
        // The window below the bar and above the status line.
        const dpr = self.devicePixelRatio || 1;
        const cw = Math.max(16, innerWidth - 16), ch = Math.max(16, innerHeight - $('bar').offsetHeight - status.offsetHeight - 16);
        w = Math.round(cw * dpr);
        h = Math.round(ch * dpr);
        canvas.style.width = cw + 'px';
        canvas.style.height = ch + 'px';
      }
      if (fixedSize) { canvas.style.width = w + 'px'; canvas.style.height = h + 'px'; }
      if (canvas.width !== w || canvas.height !== h) { canvas.width = w; canvas.height = h; }
    }

    async function draw() {
      resize();
      const m = maps.find((x) => x.name === state.map);
      const tex = await mapTexture(m);
      const R = SH.turned(state.spin, SH.fromEuler(state.rotate[0], state.rotate[1], state.rotate[2]));
      rotation.set(R);
      const L = rotation.apply(m.coefficients);
      const W = canvas.width, H = canvas.height;
      if (measureExposure) {
        measureExposure = false;
        const stops = firstFrameExposure(tex, R, L, W, H);
        if (stops !== null) apply({ exposure: stops });
      }
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      drawFrame(tex, R, L, W, H, Math.pow(2, state.exposure), tones[state.tonemap], true);
      const err = gl.getError();
      if (err !== gl.NO_ERROR) fail('WebGL error 0x' + err.toString(16));
      ++frames;
      const now = performance.now();
      if (now - fpsTime > 500) { fps = frames * 1000 / (now - fpsTime); frames = 0; fpsTime = now; }
      status.textContent = `${model.describe()} | ${W}x${H} | ${fps ? fps.toFixed(1) : '-'} fps`;
    }

    // --exposure auto (lighting.json's initial.auto_exposure, unless the URL
    // gives ?exposure=): once, from the first frame, then kept (the slider,
    // other maps and the turn leave it). The frame is drawn linear (tone 3)
    // into a float target, the model alone (alpha 1 where it covers, 0
    // elsewhere), read back and measured by frameExposure. Without
    // EXT_color_buffer_float (no float target to read) the page keeps
    // lighting.json's exposure (prt export's fallback, docs/WEB.md).
    let measureExposure = !!init.auto_exposure && !q.has('exposure');
    function firstFrameExposure(tex, R, L, W, H) {
      if (!gl.getExtension('EXT_color_buffer_float')) return null;
      const color = gl.createTexture();
      gl.bindTexture(gl.TEXTURE_2D, color);
      gl.texStorage2D(gl.TEXTURE_2D, 1, gl.RGBA32F, W, H);
      const depth = gl.createRenderbuffer();
      gl.bindRenderbuffer(gl.RENDERBUFFER, depth);
      gl.renderbufferStorage(gl.RENDERBUFFER, gl.DEPTH_COMPONENT24, W, H);
      const fb = gl.createFramebuffer();
      gl.bindFramebuffer(gl.FRAMEBUFFER, fb);
      gl.framebufferTexture2D(gl.FRAMEBUFFER, gl.COLOR_ATTACHMENT0, gl.TEXTURE_2D, color, 0);
      gl.framebufferRenderbuffer(gl.FRAMEBUFFER, gl.DEPTH_ATTACHMENT, gl.RENDERBUFFER, depth);
      let stops = null;
      if (gl.checkFramebufferStatus(gl.FRAMEBUFFER) === gl.FRAMEBUFFER_COMPLETE) {
        const rgba = new Float32Array(W * H * 4);
        drawFrame(tex, R, L, W, H, 1, 3, false);
        gl.readPixels(0, 0, W, H, gl.RGBA, gl.FLOAT, rgba);
        let covered = false;
        for (let i = 3; i < rgba.length && !covered; i += 4) covered = rgba[i] >= 0.5;
        if (!covered) {  // nothing of the model in view: the background is the frame
          drawFrame(tex, R, L, W, H, 1, 3, true);
          gl.readPixels(0, 0, W, H, gl.RGBA, gl.FLOAT, rgba);
        }
        stops = frameExposure(rgba);
      }
      gl.bindFramebuffer(gl.FRAMEBUFFER, null);
      gl.deleteFramebuffer(fb);
      gl.deleteRenderbuffer(depth);
      gl.deleteTexture(color);
      return stops;
    }

    // The frame into the bound framebuffer (W x H): the background (when
    // `background`; else cleared to transparent black), then the model.
    function drawFrame(tex, R, L, W, H, gain, tone, background) {
      const aspect = W / H;
      const cam = { eye: state.eye, target: state.target, up: state.up, fov: state.fov };
      const vp = viewProj(cam, aspect);
      gl.viewport(0, 0, W, H);
      gl.clearColor(0, 0, 0, background ? 1 : 0);
      gl.clearDepth(1);
      gl.clear(gl.COLOR_BUFFER_BIT | gl.DEPTH_BUFFER_BIT);
      gl.disable(gl.DEPTH_TEST);
      gl.disable(gl.CULL_FACE);
      gl.useProgram(bg.p);
      gl.uniform3fv(bg.u.u_forward, vp.f);
      gl.uniform3fv(bg.u.u_right, scale(vp.s, vp.t * aspect));
      gl.uniform3fv(bg.u.u_up, scale(vp.u, vp.t));
      gl.uniformMatrix3fv(bg.u.u_rot_t, false, new Float32Array(R));  // row-major R read column-major: R^T
      gl.uniform1f(bg.u.u_gain, gain);
      gl.uniform1i(bg.u.u_tone, tone);
      gl.activeTexture(gl.TEXTURE0);
      gl.bindTexture(gl.TEXTURE_2D, tex);
      gl.uniform1i(bg.u.u_latlong, 0);
      gl.bindVertexArray(emptyVao);
      if (background) gl.drawArrays(gl.TRIANGLES, 0, 3);
      if (state.model) {
        gl.enable(gl.DEPTH_TEST);
        gl.depthFunc(gl.LESS);
        model.draw(vp.M, L, gain, tone, state);
      }
      gl.bindVertexArray(null);
    }

    // Redraw on demand; the auto-turn animates at 20 degrees per second.
    let pending = false, last = performance.now();
    function requestDraw() {
      if (pending) return;
      pending = true;
      requestAnimationFrame(async (t) => {
        pending = false;
        if (state.auto) { apply({ spin: state.spin + 20 * Math.min(0.1, (t - last) / 1000) }); }
        last = t;
        await draw();
        if (state.auto) requestDraw();
      });
    }

    mapSelect.onchange = () => { apply({ map: mapSelect.value }); requestDraw(); };
    $('exposure').oninput = () => { apply({ exposure: +$('exposure').value }); requestDraw(); };
    $('tonemap').onchange = () => { apply({ tonemap: $('tonemap').value }); requestDraw(); };
    $('detail').onchange = () => { apply({ detail: $('detail').checked }); requestDraw(); };
    $('detail-label').hidden = !model.lightmap;
    $('auto').onchange = () => { apply({ auto: $('auto').checked }); last = performance.now(); requestDraw(); };
    $('spin').oninput = () => { apply({ spin: +$('spin').value }); requestDraw(); };
    $('reset').onclick = () => { apply({ camera: [...home.eye, ...home.target, ...home.up], fov: init.fov }); requestDraw(); };
    addEventListener('resize', requestDraw);

    // Orbit camera: drag turns the eye about the target (about up, and about
    // the camera's right axis), the wheel moves it nearer or farther.
    let drag = null;
    canvas.addEventListener('pointerdown', (e) => { drag = [e.clientX, e.clientY]; canvas.setPointerCapture(e.pointerId); });
    canvas.addEventListener('pointerup', () => { drag = null; });
    canvas.addEventListener('pointermove', (e) => {
      if (!drag) return;
      const dx = e.clientX - drag[0], dy = e.clientY - drag[1];
      drag = [e.clientX, e.clientY];
      const up = norm(state.up);
      let off = sub(state.eye, state.target);
      const turn = (v, axis, a) => {  // Rodrigues
        const c = Math.cos(a), s = Math.sin(a);
        return add(add(scale(v, c), scale(cross(axis, v), s)), scale(axis, dot(axis, v) * (1 - c)));
      };
      off = turn(off, up, -dx * 0.01);
      const right = norm(cross(up, off));
      const tilted = turn(off, right, -dy * 0.01);
      if (Math.abs(dot(norm(tilted), up)) < 0.995) off = tilted;
      state.eye = add(state.target, off);
      requestDraw();
    });
    canvas.addEventListener('wheel', (e) => {
      e.preventDefault();
      const off = sub(state.eye, state.target);
      state.eye = add(state.target, scale(off, Math.exp(e.deltaY * 0.001)));
      requestDraw();
    }, { passive: false });

    const nextFrame = () => new Promise((res) => requestAnimationFrame(() => requestAnimationFrame(res)));
    self.prtViewer = {
      state,
      // Draws one frame with these settings (the URL's keys, as numbers and
      // arrays); resolves once it is on the canvas.
      async set(s) {
        apply(s);
        await draw();
        gl.finish();
        await nextFrame();
        return { width: canvas.width, height: canvas.height };
      },
    };
    await draw();
    gl.finish();
    await nextFrame();
    resolveReady({ vertices: model.vertices, bands, channels, lightmap: model.lightmap, maps: maps.map((m) => m.name),
                   width: canvas.width, height: canvas.height, exposure: state.exposure });
    if (state.auto) requestDraw();
  }

  main().catch((e) => {
    status.textContent = 'error: ' + e.message;
    rejectReady(e);
  });
})();
