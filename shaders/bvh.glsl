// The flat BVH (prt/point_tracer.h) and what its walks share
// (occlusion.comp.glsl: any hit; hits.comp.glsl: the closest), inserted
// after each one's #version and defines (runtime/gpu_tracer.cpp's program):
// the node layout, the nodes and corners at bindings 0 and 1, and the float
// operations of core/point_tracer.cpp's walks, each result `precise` (no
// fused multiply-add, no reassociation), dot and cross written out in glm's
// order, min and max as C's fmin and fmax. LEAF (defined): kFlatBvhLeaf.

struct Node {
  vec3 lo;
  uint a;  // inner: left child; leaf: first triangle
  vec3 hi;
  uint b;  // inner: right child; leaf: LEAF | triangle count
};

layout(std430, binding = 0) readonly buffer Nodes { Node nodes[]; };
layout(std430, binding = 1) readonly buffer Corners { vec4 corners[]; };  // 3 per triangle

const float kInf = uintBitsToFloat(0x7f800000u);

float pdot(vec3 a, vec3 b) {
  precise float r = a.x * b.x + a.y * b.y + a.z * b.z;
  return r;
}

vec3 pcross(vec3 a, vec3 b) {
  precise vec3 r = vec3(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
  return r;
}

// C's fmin and fmax: a NaN operand (0 * inf: a ray in the plane of a box's
// face) is ignored, where GLSL's min and max leave the result undefined.
float fmin_(float a, float b) {
  precise float r = isnan(a) ? b : (isnan(b) ? a : min(a, b));
  return r;
}

float fmax_(float a, float b) {
  precise float r = isnan(a) ? b : (isnan(b) ? a : max(a, b));
  return r;
}

// The slab test: the ray's (tmin, tmax) through node nd's box. inv = 1 / d.
vec2 box_span(Node nd, vec3 o, vec3 inv) {
  precise vec3 t0 = (nd.lo - o) * inv;
  precise vec3 t1 = (nd.hi - o) * inv;
  const float tmin = fmax_(fmax_(fmin_(t0.x, t1.x), fmin_(t0.y, t1.y)), fmin_(t0.z, t1.z));
  const float tmax = fmin_(fmin_(fmax_(t0.x, t1.x), fmax_(t0.y, t1.y)), fmax_(t0.z, t1.z));
  return vec2(tmin, tmax);
}

// flat_box_hit: does the ray meet the node's box at some t > tnear?
bool slab(Node nd, vec3 o, vec3 inv, float tnear) {
  const vec2 span = box_span(nd, o, inv);
  return span.x <= span.y && span.y > tnear;
}

// flat_box_entry: where the ray enters node k's box, or +inf where it
// misses it (at every t > tnear).
float box_entry(uint k, vec3 o, vec3 inv, float tnear) {
  const vec2 span = box_span(nodes[k], o, inv);
  return span.x <= span.y && span.y > tnear ? span.x : kInf;
}

// flat_triangle_hit: Moller-Trumbore, both faces: does the ray hit
// triangle `tri` at t > tnear? On a hit, uvt = (u, v, t).
bool triangle_hit(uint tri, vec3 o, vec3 d, float tnear, out vec3 uvt) {
  uvt = vec3(0.0);
  const vec3 v0 = corners[3u * tri].xyz, v1 = corners[3u * tri + 1u].xyz, v2 = corners[3u * tri + 2u].xyz;
  precise vec3 e1 = v1 - v0;
  precise vec3 e2 = v2 - v0;
  const vec3 p = pcross(d, e2);
  const float det = pdot(e1, p);
  if (det == 0.0) return false;
  precise float inv_det = 1.0 / det;
  precise vec3 s = o - v0;
  precise float u = pdot(s, p) * inv_det;
  if (!(u >= 0.0 && u <= 1.0)) return false;
  const vec3 q = pcross(s, e1);
  precise float v = pdot(d, q) * inv_det;
  if (!(v >= 0.0 && u + v <= 1.0)) return false;
  precise float t = pdot(e2, q) * inv_det;
  if (!(t > tnear)) return false;
  uvt = vec3(u, v, t);
  return true;
}
